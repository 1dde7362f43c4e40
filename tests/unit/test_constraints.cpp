// Tests of the constraint projection against brute-force nearest particles.
#include <gtest/gtest.h>

#include <random>

#include "smooth/constraint_impl.hpp"
#include "smooth/constraints.hpp"

namespace meniscus {
namespace {

TEST(Constraint, ProjectToShellMovesRadially) {
  const Vec3f p{1, 2, 3};
  EXPECT_EQ(project_to_shell(p + Vec3f{0.7f, 0, 0}, p, 0.5f, 1.0f), (p + Vec3f{0.7f, 0, 0}));  // inside: untouched
  const Vec3f in = project_to_shell(p + Vec3f{0, 0.1f, 0}, p, 0.5f, 1.0f);
  EXPECT_NEAR(in.y - p.y, 0.5f, 1e-6f);
  EXPECT_NEAR(in.x, p.x, 1e-6f);
  const Vec3f out = project_to_shell(p + Vec3f{0, 0, -3}, p, 0.5f, 1.0f);
  EXPECT_NEAR(out.z - p.z, -1.0f, 1e-6f);
  EXPECT_NEAR(length(project_to_shell(p, p, 0.5f, 1.0f) - p), 0.5f, 1e-6f);  // on the particle
}

TEST(Constraint, ProjectedVerticesSatisfyTheShellOfTheirNearestParticle) {
  std::mt19937 rng(21);
  std::uniform_real_distribution<float> u(0.0f, 2.0f);
  std::vector<Vec3f> particles;
  for (int i = 0; i < 400; ++i) particles.push_back({u(rng), u(rng), u(rng)});
  const float r_in = 0.1f, r_out = 0.2f;
  const HashGrid grid(particles, r_out);
  const ShellConstraint c{&grid, r_in, r_out};
  std::uniform_real_distribution<float> w(-0.5f, 2.5f);
  std::vector<Vec3f> x(3000);
  for (auto& v : x) v = {w(rng), w(rng), w(rng)};
  project_vertices(c, x);
  std::size_t violations = 0;
  for (const Vec3f& v : x) {
    float best = INFINITY;
    for (const Vec3f& p : particles) best = std::min(best, length(v - p));
    if (best < r_in * (1 - 1e-5f) || best > r_out * (1 + 1e-5f)) ++violations;
  }
  EXPECT_EQ(violations, 0u);
}

/// `uniform` particles spread over the unit cube and 200 packed into a 0.1-wide cluster at its
/// centre (where the caches' lists are truncated), drawn from `rng`.
std::vector<Vec3f> cloud_with_cluster(std::mt19937& rng, int uniform) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<Vec3f> particles;
  for (int i = 0; i < uniform; ++i) particles.push_back({u(rng), u(rng), u(rng)});
  for (int i = 0; i < 200; ++i) particles.push_back(Vec3f{0.5f, 0.5f, 0.5f} + Vec3f{u(rng), u(rng), u(rng)} * 0.1f);
  return particles;
}

// The per-vertex lists must give exactly the grid's answer however the vertices wander: small
// steps (the early exit and the certification by reach − moved), large jumps (refresh), dense
// clusters with more than kCapacity particles in range (reach shortened to the first left out)
// and vertices far from every particle (grid fallback).
TEST(Constraint, NeighbourCacheProjectsExactlyAsTheGrid) {
  std::mt19937 rng(5);
  const std::vector<Vec3f> particles = cloud_with_cluster(rng, 600);
  const float r_in = 0.05f, r_out = 0.1f;
  const HashGrid grid(particles, 2 * r_out);
  const ShellConstraint c{&grid, r_in, r_out};
  std::uniform_real_distribution<float> w(-0.2f, 1.2f);
  std::vector<Vec3f> x(2000);
  for (auto& v : x) v = {w(rng), w(rng), w(rng)};
  NeighbourCache cache;
  cache.build(c, x);
  std::normal_distribution<float> step(0.0f, 1.0f);
  std::size_t compared = 0, mismatches = 0;
  for (int sweep = 0; sweep < 30; ++sweep) {
    const float size = sweep % 10 == 9 ? 0.3f : 0.004f * float(1 + sweep % 3);
    for (uint32_t i = 0; i < x.size(); ++i) {
      const Vec3f y = x[i] + Vec3f{step(rng), step(rng), step(rng)} * size;
      const Vec3f expected = project_vertex(c, y);
      x[i] = cache.project(c, i, y, x[i]);  // x[i]: where the previous projection left it
      ++compared;
      if (!(x[i] == expected)) ++mismatches;
    }
  }
  EXPECT_EQ(compared, 60000u);
  EXPECT_EQ(mismatches, 0u);
}

// The same for ellipsoid constraints: random ellipsoids (axes 0.25-2, random orientation, so the
// Lipschitz bound 1/σ̃₃ is 4), a dense cluster (lists truncated), small steps (slack and the
// certification by reach − L·moved), large jumps (refresh) and far vertices (exact fallback); the
// cache must answer exactly as project_vertex.
TEST(Constraint, EllipsoidCacheProjectsExactlyAsTheSearch) {
  std::mt19937 rng(8);
  const std::vector<Vec3f> particles = cloud_with_cluster(rng, 500);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const float r_in = 0.05f, r_out = 0.1f;
  const HashGrid grid(particles, 2 * r_out);
  std::normal_distribution<float> g(0.0f, 1.0f);
  std::uniform_real_distribution<float> axis(0.25f, 2.0f);
  std::vector<Ellipsoid> ellipsoids(particles.size());
  float max_axis = 0;
  for (Ellipsoid& e : ellipsoids) {
    // A random orthonormal frame (Gram-Schmidt of two Gaussian vectors) and random axes.
    const Vec3f a = normalized(Vec3f{g(rng), g(rng), g(rng)});
    const Vec3f b = normalized(cross(a, normalized(Vec3f{g(rng), g(rng), g(rng)})));
    const Vec3f frame[3] = {a, b, cross(a, b)};
    const float s[3] = {axis(rng), axis(rng), axis(rng)};
    SymMat3 m;
    for (int k = 0; k < 3; ++k) {
      const float inv = 1.0f / s[k];
      const Vec3f v = frame[k];
      m.xx += inv * v.x * v.x, m.xy += inv * v.x * v.y, m.xz += inv * v.x * v.z;
      m.yy += inv * v.y * v.y, m.yz += inv * v.y * v.z, m.zz += inv * v.z * v.z;
    }
    e.metric = m;
    e.max_axis = std::max({s[0], s[1], s[2]});
    e.min_axis = std::min({s[0], s[1], s[2]});
    e.det = 1.0f / (s[0] * s[1] * s[2]);
    max_axis = std::max(max_axis, e.max_axis);
  }
  const EllipsoidConstraint c{&grid, ellipsoids, r_in, r_out, max_axis};
  std::uniform_real_distribution<float> w(-0.2f, 1.2f);
  std::vector<Vec3f> x(1500);
  for (auto& v : x) v = {w(rng), w(rng), w(rng)};
  EllipsoidCache cache;
  cache.build(c, x);
  std::size_t compared = 0, mismatches = 0, unmoved = 0;
  for (int sweep = 0; sweep < 24; ++sweep) {
    const float size = sweep % 8 == 7 ? 0.3f : 0.002f * float(1 + sweep % 3);
    for (uint32_t i = 0; i < x.size(); ++i) {
      const Vec3f y = x[i] + Vec3f{g(rng), g(rng), g(rng)} * size;
      const Vec3f expected = project_vertex(c, y);
      x[i] = cache.project(c, i, y, x[i]);  // x[i]: where the previous projection left it
      ++compared;
      unmoved += expected == y;
      if (!(x[i] == expected)) ++mismatches;
    }
  }
  EXPECT_EQ(compared, 36000u);
  EXPECT_GT(unmoved, compared / 4) << "the small steps should mostly stay inside the shells (the cache's fast paths)";
  EXPECT_EQ(mismatches, 0u);

  // Points walking through the dense cluster, independently of where the projection puts them:
  // lists truncated to the kCapacity nearest, whose certification by reach − L·moved decides
  // (thin inner shells, so that the points are mostly feasible and no ray search slows the test).
  const EllipsoidConstraint thin{&grid, ellipsoids, 0.1f * r_in, r_out, max_axis};
  std::vector<Vec3f> walk(600);
  for (auto& v : walk) v = Vec3f{0.5f, 0.5f, 0.5f} + Vec3f{u(rng), u(rng), u(rng)} * 0.1f;
  EllipsoidCache walker;
  walker.build(thin, walk);
  std::vector<Vec3f> left = walk;  // where each point's previous projection left it
  std::size_t walk_mismatches = 0;
  for (int step = 0; step < 60; ++step)
    for (uint32_t i = 0; i < walk.size(); ++i) {
      walk[i] += Vec3f{g(rng), g(rng), g(rng)} * 0.003f;
      left[i] = walker.project(thin, i, walk[i], left[i]);
      walk_mismatches += !(left[i] == project_vertex(thin, walk[i]));
    }
  EXPECT_EQ(walk_mismatches, 0u);
}

}  // namespace
}  // namespace meniscus
