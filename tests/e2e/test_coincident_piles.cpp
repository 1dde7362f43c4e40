// Piles of coincident particles (duplicated exports, particles stuck in a sink or a corner): a
// real frame with 200,000 copies of one of its particles, or 200,000 particles within 1e-6 d of
// it, surfaces in about the time of the frame alone at the same spacing, with a closed mesh
// around the pile; copies change no mesh of the distance field at all. A query near a pile that
// scanned all of it made the spacing estimate and the anisotropic kernels' pass quadratic in the
// pile, and the constraints' projections linear in it per vertex and sweep. 100,000 particles on
// the 8 corners of a unit cube (what a boolean position array gives) surface at once, into the
// 8 corners' mesh.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <random>

#include "meniscus/io.hpp"
#include "meniscus/quality.hpp"
#include "meniscus/reconstruct.hpp"
#include "support/checksums.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

constexpr std::size_t kPile = 200000;
constexpr std::size_t kPileParticle = 3000;  // on the tank's floor, under the bottom surface

ParticleSet frame() { return read_particles(test::data_file("ply/dam_break_frame_9_6859_particles.ply")); }

/// `ps` with `count` more particles at `at(k)`, each with the attribute values of particle `of`.
template <class At>
ParticleSet with_pile(ParticleSet ps, std::size_t of, std::size_t count, At&& at) {
  for (std::size_t k = 0; k < count; ++k) ps.positions.push_back(at(k));
  for (Attribute& a : ps.attributes) {
    const std::size_t c = std::size_t(a.components);
    a.values.reserve(a.values.size() + count * c);
    for (std::size_t k = 0; k < count; ++k)
      for (std::size_t j = 0; j < c; ++j) a.values.push_back(a.values[of * c + j]);
  }
  return ps;
}

struct Timed {
  Result result;
  double seconds = 0;
};
Timed timed_reconstruct(const ParticleSet& ps, const Params& p) {
  const auto t0 = std::chrono::steady_clock::now();
  Timed t{reconstruct(ps, p), 0};
  t.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return t;
}

Params cpu_params(FieldMethod field = FieldMethod::distance) {
  Params p;
  p.backend = Backend::cpu;  // the device visits every copy (the same mesh, more work)
  p.field = field;
  return p;
}

/// Surfaces `piled` (the spacing estimated), then `plain` at the spacing that gave, twice (the
/// faster counts: a loaded machine slows one run, not its cost). The pile may cost a few times
/// the plain frame, not the tens of times of queries that scan it. Returns the two results.
std::pair<Result, Result> expect_time_of_the_plain_frame(const ParticleSet& piled, const ParticleSet& plain,
                                                          const char* what,
                                                          FieldMethod field = FieldMethod::distance) {
  Timed pile = timed_reconstruct(piled, cpu_params(field));
  Params at_its_spacing = cpu_params(field);
  at_its_spacing.spacing = pile.result.params.spacing;
  Timed alone = timed_reconstruct(plain, at_its_spacing);
  alone.seconds = std::min(alone.seconds, timed_reconstruct(plain, at_its_spacing).seconds);
  EXPECT_LT(pile.seconds, 4 * alone.seconds + 1.0)
      << what << ": " << pile.seconds << " s, the frame alone " << alone.seconds << " s at the same spacing";
  const TopologyReport t = analyze_topology(pile.result.mesh);
  EXPECT_TRUE(t.watertight()) << what << ": " << t.boundary_edges << " boundary edges, " << t.nonmanifold_edges
                              << " non-manifold";
  EXPECT_GT(pile.result.mesh.triangles.size(), 50000u) << what;
  return {std::move(pile.result), std::move(alone.result)};
}

TEST(CoincidentParticles, AFrameWithAPileOfCopiesCostsWhatTheFrameCostsAndGetsItsMesh) {
  const ParticleSet plain = frame();
  const Vec3f at = plain.positions[kPileParticle];
  const ParticleSet piled = with_pile(plain, kPileParticle, kPile, [&](std::size_t) { return at; });
  const auto [pile, alone] = expect_time_of_the_plain_frame(piled, plain, "200,000 copies");
  // The copies have no spacing of their own and are never samples: the estimate is the frame's,
  // the pile after the frame or before it (it was the median nearest-neighbour distance, 30 %
  // finer, when the pile made most of the samples).
  const double spacing = estimate_spacing(plain);
  EXPECT_NEAR(pile.params.spacing, spacing, 0.01 * spacing);
  ParticleSet pile_first;
  pile_first.positions.assign(kPile, at);
  pile_first.positions.insert(pile_first.positions.end(), plain.positions.begin(), plain.positions.end());
  EXPECT_NEAR(estimate_spacing(pile_first), spacing, 0.01 * spacing);
  EXPECT_EQ(points_outside(pile.mesh, std::span<const Vec3f>(&at, 1)), 0u);
  // A copy changes no distance to the nearest particle: the mesh is the frame's, bit for bit.
  EXPECT_EQ(test::mesh_checksum(pile.mesh), test::mesh_checksum(alone.mesh));
}

TEST(CoincidentParticles, AnisotropicKernelsOfAPileAreMadeOnce) {
  // Yu & Turk's ellipsoid and centre of each of k copies summed over all k (O(k²)).
  const ParticleSet plain = frame();
  const Vec3f at = plain.positions[kPileParticle];
  const ParticleSet piled = with_pile(plain, kPileParticle, 50000, [&](std::size_t) { return at; });
  const auto [pile, alone] =
      expect_time_of_the_plain_frame(piled, plain, "50,000 copies, anisotropic kernels", FieldMethod::anisotropic);
  EXPECT_EQ(points_outside(pile.mesh, std::span<const Vec3f>(&at, 1)), 0u);
}

TEST(CoincidentParticles, APileWithin1e6SpacingsOfAParticleCostsWhatTheFrameCosts) {
  // The frame moved so that the pile lies at the origin, where floats are dense: the 200,000
  // particles within 1e-6 d of it are all at different positions.
  ParticleSet plain = frame();
  const Vec3f shift = plain.positions[kPileParticle];
  for (Vec3f& x : plain.positions) x = x - shift;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> jitter(-0.02e-6f, 0.02e-6f);  // within 1e-6 d of it (d > 0.035)
  const ParticleSet piled = with_pile(plain, kPileParticle, kPile, [&](std::size_t) {
    return Vec3f{jitter(rng), jitter(rng), jitter(rng)};
  });
  std::vector<Vec3f> distinct(piled.positions.end() - std::ptrdiff_t(kPile), piled.positions.end());
  std::sort(distinct.begin(), distinct.end(), [](Vec3f a, Vec3f b) {
    return a.x != b.x ? a.x < b.x : (a.y != b.y ? a.y < b.y : a.z < b.z);
  });
  ASSERT_GT(std::unique(distinct.begin(), distinct.end()) - distinct.begin(), 190000);
  const auto [pile, alone] = expect_time_of_the_plain_frame(piled, plain, "200,000 within 1e-6 d");
  EXPECT_GT(pile.params.spacing, 0.03);
  EXPECT_LT(pile.params.spacing, 0.05);
  const std::vector<Vec3f> pile_particles(piled.positions.end() - std::ptrdiff_t(kPile), piled.positions.end());
  EXPECT_EQ(points_outside(pile.mesh, pile_particles), 0u);
  EXPECT_EQ(points_outside(pile.mesh, plain.positions), points_outside(alone.mesh, plain.positions));
}

TEST(CoincidentParticles, ParticlesOnTheEightCornersOfACubeSurfaceAtOnceAsTheCornersDo) {
  ParticleSet corners, many;
  for (int k = 0; k < 8; ++k) corners.positions.push_back(Vec3f{float(k & 1), float((k >> 1) & 1), float(k >> 2)});
  for (std::size_t i = 0; i < 100000; ++i) many.positions.push_back(corners.positions[i % 8]);
  const Timed t = timed_reconstruct(many, cpu_params());
  EXPECT_LT(t.seconds, 10.0) << "100,000 particles on 8 points";
  EXPECT_EQ(t.result.params.spacing, 1.0);
  const TopologyReport topology = analyze_topology(t.result.mesh);
  EXPECT_TRUE(topology.watertight());
  EXPECT_GT(t.result.mesh.triangles.size(), 0u);
  EXPECT_EQ(points_outside(t.result.mesh, corners.positions), 0u);
  // The copies change no nearest particle: the mesh of the 8 corners alone at that spacing (their
  // own estimate is larger: the copies count in the density spacing).
  Params spaced = cpu_params();
  spaced.spacing = 1.0;
  const Result eight = reconstruct(corners, spaced);
  EXPECT_EQ(test::mesh_checksum(t.result.mesh), test::mesh_checksum(eight.mesh));
}

}  // namespace
}  // namespace meniscus
