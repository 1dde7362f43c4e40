// Small handles round air cut and capped (mesh/handles.hpp, Params::close_handles): a sheet one
// particle thick with pinholes comes out whole; necks of water, real holes, droplets and particles
// stay as they were; real frames lose most of their small handles and nothing else; the result
// depends neither on the threads nor on particles beyond R_local.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>

#include "meniscus/distributed.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "meniscus/quality.hpp"
#include "meniscus/reconstruct.hpp"
#include "support/io_helpers.hpp"
#include "support/locality.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

constexpr float kD = 0.1f;

ParticleSet thin_sheet(int n, float gap, uint32_t seed = 7) { return test::thin_sheet(n, gap, kD, seed); }

Params params(bool close) {
  Params p;
  p.spacing = kD;
  p.close_handles = close;
  return p;
}

double share_under_10_degrees(const TriangleMesh& m) { return triangle_angles(m).share_below_10; }

double stage_seconds(const Stats& s, const std::string& name) {
  for (const StageTime& t : s.stages)
    if (t.name == name) return t.seconds;
  return 0;
}

TEST(Handles, AThinSheetWithPinholesComesOutWholeWithEveryParticleInside) {
  const ParticleSet sheet = thin_sheet(24, 1.5f * kD);
  const Result plain = reconstruct(sheet, params(false));
  const Result closed = reconstruct(sheet, params(true));
  const TopologyReport before = analyze_topology(plain.mesh), after = analyze_topology(closed.mesh);
  std::printf("[ measured ] sheet with 1.5 d lanes: genus %lld, %zu handles closed: genus %lld\n", before.genus(),
              closed.stats.closed_handles, after.genus());
  ASSERT_GT(before.genus(), 0) << "the sheet has no pinholes to close: the test shows nothing";
  ASSERT_TRUE(after.watertight());
  EXPECT_EQ(after.genus(), 0);
  EXPECT_EQ(closed.stats.genus, 0);
  EXPECT_EQ(closed.stats.closed_handles, std::size_t(before.genus()));
  EXPECT_EQ(after.components, 1u);
  EXPECT_EQ(points_outside(closed.mesh, sheet.positions), 0u);
  EXPECT_GE(valence(closed.mesh).min, 5);
  // The caps add the holes' volume and nothing else.
  EXPECT_GE(signed_volume(closed.mesh), signed_volume(plain.mesh));
  EXPECT_LT(signed_volume(closed.mesh), 1.02 * signed_volume(plain.mesh));
}

// Four particles 1.9 d apart in a square: four necks of water round a small hole of air. The hole
// may be closed; a neck (whose loop does not separate the ring either) never is: the middle of
// every neck stays inside the surface.
TEST(Handles, ANeckOfWaterIsNeverCutAndAWideHoleStays) {
  ParticleSet square;
  const float s = 1.9f * kD;
  for (const auto& [x, y] : {std::pair{0.0f, 0.0f}, {s, 0.0f}, {s, s}, {0.0f, s}}) square.positions.push_back({x, y, 0});
  const Result plain = reconstruct(square, params(false));
  ASSERT_EQ(analyze_topology(plain.mesh).genus(), 1) << "the square is not a ring: the test shows nothing";
  const Result closed = reconstruct(square, params(true));
  const TopologyReport t = analyze_topology(closed.mesh);
  ASSERT_TRUE(t.watertight());
  EXPECT_EQ(t.components, 1u);
  const std::vector<Vec3f> necks{{s / 2, 0, 0}, {s, s / 2, 0}, {s / 2, s, 0}, {0, s / 2, 0}};
  EXPECT_EQ(points_outside(closed.mesh, necks), 0u);
  EXPECT_EQ(points_outside(closed.mesh, square.positions), 0u);
  // A ring of touching particles round a hole 2 d wide: a hole of the water, whose loop no three
  // rings of triangles wrap.
  ParticleSet ring;
  const int n = int(std::ceil(2 * std::numbers::pi * 2.0 / 0.9));
  for (int k = 0; k < n; ++k) {
    const double a = 2 * std::numbers::pi * k / n;
    ring.positions.push_back({float(2 * kD * std::cos(a)), float(2 * kD * std::sin(a)), 0});
  }
  EXPECT_EQ(reconstruct(ring, params(false)).stats.genus, 1);
  const Result ring_closed = reconstruct(ring, params(true));
  EXPECT_EQ(ring_closed.stats.genus, 1);
  EXPECT_EQ(ring_closed.stats.closed_handles, 0u);
}

// Real frames: most small handles closed; the same components; every particle inside; valence
// ≥ 5; no more thin angles; the volume a fraction of a percent more (the holes' air).
TEST(Handles, RealFramesLoseMostSmallHandlesAndNothingElse) {
  for (const char* file : {"ply/double_dam_break_frame_26_4732_particles.ply", "ply/dam_break_frame_9_6859_particles.ply",
                           "ply/dam_break_frame_23_24389_particles.ply"}) {
    if (test::kSanitized && std::string(file).find("24389") != std::string::npos) continue;  // the Release run has it
    const ParticleSet ps = read_particles(test::data_file(file));
    Params p;
    const Result plain = reconstruct(ps, p);
    p.close_handles = true;
    const Result closed = reconstruct(ps, p);
    const TopologyReport before = analyze_topology(plain.mesh), after = analyze_topology(closed.mesh);
    std::printf("[ measured ] %s: genus %lld -> %lld (%zu closed), components %zu, volume x%.4f, %.3f s of %.3f s\n", file,
                before.genus(), after.genus(), closed.stats.closed_handles, after.components,
                signed_volume(closed.mesh) / signed_volume(plain.mesh), stage_seconds(closed.stats, "handles"),
                closed.stats.total_seconds());
    ASSERT_TRUE(after.watertight()) << file;
    EXPECT_GT(before.genus(), 0) << file;
    EXPECT_LE(2 * after.genus(), before.genus()) << file;  // at least half of them closed
    EXPECT_EQ(before.genus() - after.genus(), (long long)closed.stats.closed_handles) << file;
    EXPECT_EQ(after.components, before.components) << file;
    EXPECT_EQ(points_outside(closed.mesh, ps.positions), 0u) << file;
    EXPECT_GE(valence(closed.mesh).min, 5) << file;
    EXPECT_LE(share_under_10_degrees(closed.mesh), share_under_10_degrees(plain.mesh) + 1e-4) << file;
    EXPECT_GE(signed_volume(closed.mesh), 0.999 * signed_volume(plain.mesh)) << file;
    EXPECT_LE(signed_volume(closed.mesh), 1.005 * signed_volume(plain.mesh)) << file;
    const Params& r = closed.params;
    const ConstraintReport c = constraint_residual(closed.mesh.vertices, ps.positions, r.r_inner, r.r_outer);
    EXPECT_LE(c.max_distance, 1.25 * r.spacing) << file;  // every vertex near its particle
  }
}

// Two frames of a real sequence's thin water (tests/data/sph_dambreak/, the genus of OpenVDB + 4
// passes there: 42 and 11, bench/RESULTS.md): half of the handles or more closed, every component
// and every particle kept.
TEST(Handles, SequenceFramesLoseHalfTheirHandlesAndKeepEveryComponent) {
  if (test::kSanitized) GTEST_SKIP() << "32,768 particles a frame: the Release run has them";
  for (const char* file : {"sph_dambreak/ParticleData_Fluid_0020.bgeo", "sph_dambreak/ParticleData_Fluid_0030.bgeo"}) {
    const ParticleSet ps = read_particles(test::data_file(file));
    Params p;
    const Result plain = reconstruct(ps, p);
    p.close_handles = true;
    const Result closed = reconstruct(ps, p);
    std::printf("[ measured ] %s: genus %lld -> %lld, components %zu -> %zu\n", file, plain.stats.genus,
                closed.stats.genus, plain.stats.components, closed.stats.components);
    EXPECT_LE(2 * closed.stats.genus, plain.stats.genus) << file;
    EXPECT_EQ(closed.stats.components, plain.stats.components) << file;
    EXPECT_EQ(points_outside(closed.mesh, ps.positions), 0u) << file;
    EXPECT_GE(valence(closed.mesh).min, 5) << file;
  }
}

TEST(Handles, TheSameMeshOnAnyThreadCount) {
  const ParticleSet ps = read_particles(test::data_file("ply/dam_break_frame_9_6859_particles.ply"));
  Params p;
  p.close_handles = true;
  p.threads = 1;
  const Result one = reconstruct(ps, p);
  EXPECT_GT(one.stats.closed_handles, 0u);
  p.threads = 3;
  const Result three = reconstruct(ps, p);
  ASSERT_EQ(three.mesh.vertices.size(), one.mesh.vertices.size());
  EXPECT_TRUE(three.mesh.triangles == one.mesh.triangles);
  for (std::size_t i = 0; i < one.mesh.vertices.size(); ++i)
    for (int a = 0; a < 3; ++a) ASSERT_TRUE(test::same_bits(three.mesh.vertices[i][a], one.mesh.vertices[i][a])) << i;
}

// R_local with close_handles (pipeline/resolve.cpp): changes beyond it move no vertex.
TEST(Handles, ChangesFartherThanRLocalMoveNoVertex) {
  for (const char* file : {"double_dam_break_frame_26_4732_particles.ply", "dam_break_frame_9_6859_particles.ply"}) {
    const ParticleSet base = read_particles(test::data_file(std::string("ply/") + file));
    Params q;
    q.close_handles = true;
    const Params p = resolve_frame_estimates(base, q);
    const double reach = local_reach(resolve_params(base, p));
    Params without = p;
    without.close_handles = false;
    EXPECT_GT(reach, local_reach(resolve_params(base, without)));
    const auto changes = test::frame_changes(base, p.spacing, reach);
    EXPECT_GT(test::expect_local(std::string(file) + " close_handles", base, p, changes, reach), 0u);
  }
}

TEST(Handles, TheCudaBackendAndTheRanksOfAJobRefuseThem) {
  const ParticleSet sheet = thin_sheet(8, kD);
  Params p = params(true);
  p.backend = Backend::cuda;
  EXPECT_THROW(reconstruct(sheet, p), InvalidParameter);
  p.backend = Backend::cpu;
  std::vector<VertexOrderKey> keys;
  EXPECT_THROW(reconstruct_ordered(sheet, p, keys, {0, 0, 0}), InvalidParameter);
}

}  // namespace
}  // namespace meniscus
