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
  p.relax = 1.5;  // Jacobi sweeps diverge above 1
  expect_refused(p, "Jacobi");
  p = Params{};
  p.relax_b = 1.2;
  expect_refused(p, "relax_b");
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
  EXPECT_EQ(parse_solver("chebyshev"), SmoothingSolver::chebyshev);
  EXPECT_THROW(parse_solver("gauss-seidel"), InvalidParameter);  // not local: refused, naming the replacement
}

// The frame-wide estimates: the rest density of particles with a density but no mass is the
// median density unless given (and only for the fields that use volumes); the reference speed of
// the velocity weighting the 95th-percentile speed unless given. resolve_frame_estimates fills
// those and the spacing, nothing else.
TEST(Params, FrameWideEstimatesAreResolvedUnlessGiven) {
  ParticleSet ps = test::lattice_block(5, 5, 4, 0.1f);
  Attribute density, velocity;
  density.name = "density";
  velocity.name = "v";
  velocity.components = 3;
  for (std::size_t i = 0; i < ps.size(); ++i) {
    density.values.push_back(float(900 + i % 7 * 50));  // 900 … 1200, median 1050
    for (float c : {float(i % 20), 0.0f, 0.0f}) velocity.values.push_back(c);  // speeds 0 … 19
  }
  ps.attributes = {density, velocity};
  Params in;
  in.field = FieldMethod::sph;
  in.velocity_weighted = true;
  const Params p = resolve_frame_estimates(ps, in);
  EXPECT_GT(p.spacing, 0.0);
  EXPECT_DOUBLE_EQ(p.rest_density, 1050.0);
  EXPECT_DOUBLE_EQ(p.velocity_reference, 18.0);
  EXPECT_EQ(p.voxel_size, 0.0) << "the rest is left to resolve_params";
  in.rest_density = 1000;
  in.velocity_reference = 5;
  const Params given = resolve_frame_estimates(ps, in);
  EXPECT_DOUBLE_EQ(given.rest_density, 1000.0);
  EXPECT_DOUBLE_EQ(given.velocity_reference, 5.0);
  in = Params{};  // the distance field uses no volumes: nothing to estimate
  EXPECT_DOUBLE_EQ(resolve_frame_estimates(ps, in).rest_density, 0.0);
}

TEST(Params, DerivedValuesFollowTheSpacing) {
  Params in;
  in.spacing = 0.2;
  const Params p = resolve_params(test::lattice_block(4, 4, 4, 0.2f), in);
  EXPECT_DOUBLE_EQ(p.voxel_size, 0.1);
  EXPECT_DOUBLE_EQ(p.relax, 1.0);  // undamped Jacobi steps (Chebyshev accelerates them)
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
