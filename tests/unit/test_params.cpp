// Tests of parameter validation and derivation.
#include <gtest/gtest.h>

#include <limits>

#include "meniscus/errors.hpp"
#include "meniscus/params.hpp"
#include "meniscus/reconstruct.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

void expect_refused(const Params& p, const std::string& name) {
  try {
    p.validate();
    ADD_FAILURE() << "accepted invalid " << name;
  } catch (const InvalidParameter& e) {
    EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
  }
}

TEST(Params, DefaultsAreValidAndSatisfyWilliamsFlatnessCondition) {
  const Params p = resolve_params(test::lattice_block(6, 6, 6, 0.1f), Params{});
  EXPECT_NO_THROW(p.validate());
  // r_outer² > d²/2 + r_inner² (Williams 2008): a lattice of spacing d surfaces flat.
  EXPECT_GT(p.r_outer * p.r_outer, p.spacing * p.spacing / 2 + p.r_inner * p.r_inner);
}

TEST(Params, RefusesOutOfRangeValuesNamingTheParameter) {
  Params p;
  p.r_outer = -1;
  expect_refused(p, "r_outer");
  p = Params{};
  p.r_inner = 0.2;
  p.r_outer = 0.2;
  expect_refused(p, "r_inner");
  p = Params{};
  p.relax = 2;
  expect_refused(p, "relax");
  p = Params{};
  p.relax = 1.5;  // over-relaxed Gauss-Seidel: accepted
  EXPECT_NO_THROW(p.validate());
  p.solver = SmoothingSolver::jacobi;  // Jacobi diverges above 1
  expect_refused(p, "Jacobi");
  p = Params{};
  p.steps_b = -3;
  expect_refused(p, "steps_b");
  p = Params{};
  p.voxel_size = 1.0;
  p.r_outer = 0.1;
  expect_refused(p, "voxel_size");
  p = Params{};
  p.spacing = std::numeric_limits<double>::quiet_NaN();
  expect_refused(p, "spacing");
  EXPECT_THROW(parse_extractor("spheres"), InvalidParameter);
  EXPECT_EQ(parse_extractor("cubes"), Extractor::cubes);
  EXPECT_EQ(parse_solver("jacobi"), SmoothingSolver::jacobi);
}

TEST(Params, DerivedValuesFollowTheSpacing) {
  Params in;
  in.spacing = 0.2;
  const Params p = resolve_params(test::lattice_block(4, 4, 4, 0.2f), in);
  EXPECT_DOUBLE_EQ(p.voxel_size, 0.1);
  EXPECT_DOUBLE_EQ(p.relax, 1.3);  // over-relaxed Gauss-Seidel A sweeps
  Params jacobi = in;
  jacobi.solver = SmoothingSolver::jacobi;
  EXPECT_DOUBLE_EQ(resolve_params(test::lattice_block(4, 4, 4, 0.2f), jacobi).relax, 1.0);
  EXPECT_DOUBLE_EQ(p.r_outer, 0.2);
  EXPECT_DOUBLE_EQ(p.r_inner, 0.1);
  EXPECT_DOUBLE_EQ(p.transfer_radius, 0.4);
  EXPECT_GT(p.threads, 0);
  EXPECT_GT(p.max_memory_gb, 0);
}

TEST(Params, SpacingOfADisorderedFluidIsNotTheNearestNeighbourDistance) {
  // Particles at density 1/d³ but placed at random (hard-core d/2): the nearest-neighbour
  // distance is well under d, the density spacing is d.
  const float d = 0.1f;
  ParticleSet ps = test::lattice_block(20, 20, 20, d, 0.45f, 99);
  const double s = estimate_spacing(ps);
  EXPECT_GT(s, 0.9 * d);
  EXPECT_LT(s, 1.1 * d);
}

}  // namespace
}  // namespace meniscus
