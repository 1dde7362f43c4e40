// A local surface (README "A local surface"): every vertex's final position is a function of the
// particles within R_local = local_reach(p) of it, bit for bit. Each real frame in tests/data and
// a synthetic splash is surfaced, changed (a particle beyond R_local, a particle and a droplet of
// 20 joining the surface, a splash removed), surfaced again; every vertex farther than R_local
// from the change must come back bit-identical, and some near it must have moved (so that the
// check is not vacuous). The default schedule, --field anisotropic and --extract cubes.
#include <gtest/gtest.h>

#include "meniscus/io.hpp"
#include "meniscus/reconstruct.hpp"
#include "support/io_helpers.hpp"
#include "support/locality.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

using test::Variant;
using test::variant_params;

const char* name(Variant v) { return test::to_string(v); }

class LocalFrame : public ::testing::TestWithParam<std::tuple<std::string, Variant>> {};

TEST_P(LocalFrame, ChangesFartherThanRLocalMoveNoVertex) {
  const auto& [file, variant] = GetParam();
  if (test::large_for_sanitizers(file)) GTEST_SKIP() << "a large frame: the Release run has it";
  if (test::kSanitized && variant != Variant::standard && test::count_before(file, "_particles") > 2500)
    GTEST_SKIP() << "the other variants on the two smallest frames only there: the Release run has this one";
  const ParticleSet base = read_particles(test::data_file("ply/" + file));
  const Params p = resolve_frame_estimates(base, variant_params(variant));
  const double reach = local_reach(resolve_params(base, p));
  if (variant == Variant::standard) {
    EXPECT_LE(reach, 40 * p.spacing);  // README: R_local ≤ 40 d by default
  }
  const auto changes = test::frame_changes(base, p.spacing, reach);
  const std::size_t region = test::expect_local(file + " " + name(variant), base, p, changes, reach);
  EXPECT_GT(region, 0u);
}

INSTANTIATE_TEST_SUITE_P(
    Frames, LocalFrame,
    ::testing::Combine(::testing::Values("dam_break_frame_23_24389_particles.ply", "dam_break_frame_9_6859_particles.ply",
                                         "bunny_frame_14_7705_particles.ply", "double_dam_break_frame_26_4732_particles.ply",
                                         "cube_2366_particles.ply", "free_particles_1000_particles.ply",
                                         "fluid_250_particles.ply", "sphysics_dam_break_IPART_29814_particles.ply"),
                       ::testing::Values(Variant::standard, Variant::anisotropic, Variant::cubes)),
    [](const auto& test_param) {
      std::string n = std::get<0>(test_param.param);
      n = n.substr(0, n.find('.'));
      return n + "_" + name(std::get<1>(test_param.param));
    });

// The synthetic splash: removing the whole splash (a column and its droplets at the pool's low-x
// end) leaves the pool beyond R_local bit-identical, and that is most of the pool.
TEST(Locality, RemovingASplashLeavesThePoolBeyondRLocalBitIdentical) {
  const test::SplashScene s = test::synthetic_splash();
  const std::size_t pool = s.particles.size() - s.splash_count;
  std::vector<std::size_t> splash;
  std::vector<Vec3f> at;
  for (std::size_t i = pool; i < s.particles.size(); ++i) splash.push_back(i), at.push_back(s.particles.positions[i]);
  for (Variant v : {Variant::standard, Variant::anisotropic, Variant::cubes}) {
    Params p = variant_params(v);
    p.spacing = s.d;
    const double reach = local_reach(resolve_params(s.particles, p));
    const test::FrameChange removed{"the splash removed", test::without_particles(s.particles, splash), at};
    const std::size_t region = test::expect_local(std::string("splash ") + name(v), s.particles, p, {removed}, reach);
    EXPECT_GT(region, 1000u) << name(v);
  }
}

// Order-free, end to end: 1, 2 and 4 threads give the same mesh, bit for bit (the batches of
// components: SmoothSchedule.BatchesOfWholeComponentsGiveTheWholeMeshsVertices).
TEST(Locality, ThreadsChangeNoBitOfTheMesh) {
  const test::SplashScene s = test::synthetic_splash();
  Params p;
  p.spacing = s.d;
  p.threads = 1;
  const Result one = reconstruct(s.particles, p);
  for (int threads : {2, 4}) {
    p.threads = threads;
    const Result r = reconstruct(s.particles, p);
    ASSERT_EQ(r.mesh.vertices.size(), one.mesh.vertices.size());
    EXPECT_TRUE(r.mesh.triangles == one.mesh.triangles) << threads << " threads";
    for (std::size_t i = 0; i < r.mesh.vertices.size(); ++i)
      for (int a = 0; a < 3; ++a)
        ASSERT_TRUE(test::same_bits(r.mesh.vertices[i][a], one.mesh.vertices[i][a])) << threads << " threads, vertex " << i;
  }
}

}  // namespace
}  // namespace meniscus
