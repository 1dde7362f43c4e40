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

}  // namespace
}  // namespace meniscus
