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

// The per-vertex lists must give exactly the grid's answer however the vertices wander: small
// steps (the early exit and the certification by reach − moved), large jumps (refresh), dense
// clusters with more than kCapacity particles in range (reach shortened to the first left out)
// and vertices far from every particle (grid fallback).
TEST(Constraint, NeighbourCacheProjectsExactlyAsTheGrid) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<Vec3f> particles;
  for (int i = 0; i < 600; ++i) particles.push_back({u(rng), u(rng), u(rng)});
  for (int i = 0; i < 200; ++i) particles.push_back(Vec3f{0.5f, 0.5f, 0.5f} + Vec3f{u(rng), u(rng), u(rng)} * 0.1f);
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
      x[i] = cache.project(c, i, y);
      ++compared;
      if (!(x[i] == expected)) ++mismatches;
    }
  }
  EXPECT_EQ(compared, 60000u);
  EXPECT_EQ(mismatches, 0u);
}

}  // namespace
}  // namespace meniscus
