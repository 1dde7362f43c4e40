// Tests of the constraint projection against brute-force nearest particles.
#include <gtest/gtest.h>

#include <cmath>
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

// Two particles closer than 2 r_inner: their inner shells overlap in a lens, and the smoothing
// presses vertices into the crease between them. A vertex pushed into the lens must come out at
// the nearest point of the crease, not bounce between the two shells (radial projections onto one
// shell land inside the other) and end on the far side of the outer shell.
TEST(Constraint, VertexInTheLensOfTwoInnerShellsGoesToTheNearestCreasePoint) {
  const float r_in = 0.5f, r_out = 1.0f;
  const std::vector<Vec3f> particles{{0, 0, 0}, {0.9f, 0, 0}};
  const HashGrid grid(particles, r_out);
  const ShellConstraint c{&grid, r_in, r_out};
  // The crease: the circle x = 0.45, radius √(0.25 − 0.2025) = 0.2179 about the x axis.
  const float rho = std::sqrt(r_in * r_in - 0.45f * 0.45f);
  for (const Vec3f x : {Vec3f{0.45f, 0.15f, 0}, Vec3f{0.40f, 0, 0.18f}, Vec3f{0.52f, -0.1f, 0.1f}}) {
    const Vec3f y = project_vertex(c, x);
    const Vec3f radial = Vec3f{0, x.y, x.z} / std::sqrt(x.y * x.y + x.z * x.z);
    const Vec3f crease{0.45f, radial.y * rho, radial.z * rho};
    EXPECT_LT(length(y - crease), 1e-5f) << x.x << " " << x.y << " " << x.z;
    EXPECT_GE(length(y - particles[0]), r_in * (1 - 1e-5f));
    EXPECT_GE(length(y - particles[1]), r_in * (1 - 1e-5f));
  }
}

// Far from the origin the coordinates' own rounding (an ulp of 128 is 1.5e-5) exceeds the radii's:
// the projection must still settle in one step next to where the vertex was, and not fall through
// to the ray search, which would put the vertex on the outer shell: a jump of r_outer − r_inner
// that makes the bilaplacian sweeps raise the energy until their damping gives out.
TEST(Constraint, ProjectionFarFromTheOriginMovesTheVertexOnlyToTheShell) {
  const float r_in = 0.005f, r_out = 0.01f;
  const Vec3f o{128.3f, -97.1f, 203.7f};
  std::mt19937 rng(8);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<Vec3f> particles;
  for (int k = 0; k < 5; ++k)
    for (int j = 0; j < 5; ++j)
      for (int i = 0; i < 5; ++i)
        particles.push_back(o + Vec3f{float(i) + 0.1f * u(rng), float(j) + 0.1f * u(rng), float(k) + 0.1f * u(rng)} * 0.01f);
  const HashGrid grid(particles, r_out);
  const ShellConstraint c{&grid, r_in, r_out};
  int checked = 0;
  for (int n = 0; n < 2000; ++n) {
    const Vec3f x = o + Vec3f{u(rng), u(rng), u(rng)} * 0.02f + Vec3f{0.02f, 0.02f, 0.02f};
    float before = INFINITY;
    for (const Vec3f& p : particles) before = std::min(before, length(x - p));
    // Vertices just inside an inner shell, as a smoothing step leaves them.
    if (before > r_in || before < 0.9f * r_in) continue;
    ++checked;
    const Vec3f y = project_vertex(c, x);
    float after = INFINITY;
    for (const Vec3f& p : particles) after = std::min(after, length(y - p));
    EXPECT_GE(after, r_in - 1e-4f);  // the shell, within the coordinates' rounding (4.9e-5 here)
    EXPECT_LE(after, r_out);
    // The nearest feasible point is within the depth (≤ 0.1 r_in), or on a crease near it.
    EXPECT_LT(length(y - x), 0.5f * r_in) << "moved " << length(y - x) / r_in << " r_inner";
  }
  EXPECT_GT(checked, 20);
}

// A surface particle's inner shell is thin along the normal, and the accelerated sweeps can carry
// a vertex resting on it past its centre. Projected out along the line from the centre, the vertex
// would land on the far side, taking the surface across the particle; it must come back where its
// move entered the shell. A vertex that was inside already goes out along the line from the centre.
TEST(Constraint, VertexCarriedPastTheCentreOfAThinShellGoesBackWhereItEntered) {
  const std::vector<Vec3f> particles{{0, 0, 0}};
  const HashGrid grid(particles, 2.0f);
  Ellipsoid flat;  // axes 2, 2, 1/4 (unit volume): thin along z
  flat.metric = SymMat3{0.5f, 0, 0, 0.5f, 0, 4.0f};
  flat.max_axis = 2;
  flat.min_axis = 0.25f;
  const std::vector<Ellipsoid> shells{flat};
  const EllipsoidConstraint c{&grid, shells, 0.5f, 1.0f, 2.0f};
  const Vec3f from{0.1f, 0, 0.2f};  // metric 0.80: in the shell, above the particle
  const Vec3f x{0.1f, 0, -0.05f};   // metric 0.21: inside the inner shell, below the centre
  const Vec3f y = project_vertex(c, x, from);
  EXPECT_NEAR(length(flat.metric * y), 0.5f, 1e-5f);
  EXPECT_GT(y.z, 0.0f) << "the vertex went out on the far side of the particle";
  EXPECT_LT(length(cross(y - from, x - from)), 1e-6f);  // on its path
  EXPECT_NEAR(y.z, 0.12437f, 1e-4f);  // where (0.1, 0, z) meets |A y| = 0.5: 16 z² = 0.25 − 0.0025
  const Vec3f radial = project_vertex(c, x, x);  // no earlier position outside: from the centre
  EXPECT_LT(radial.z, 0.0f);
  EXPECT_NEAR(length(flat.metric * radial), 0.5f, 1e-5f);
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
      const Vec3f expected = project_vertex(c, y, x[i]);
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
      const Vec3f from = left[i];
      left[i] = walker.project(thin, i, walk[i], from);
      walk_mismatches += !(left[i] == project_vertex(thin, walk[i], from));
    }
  EXPECT_EQ(walk_mismatches, 0u);
}

}  // namespace
}  // namespace meniscus
