// End-to-end tests of the artist controls (docs/cli.md "Artist controls"): what smoothness, detail and
// the presets do to real meshes, with the numbers they were tuned on.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>

#include "meniscus/config.hpp"
#include "meniscus/io.hpp"
#include "meniscus/quality.hpp"
#include "meniscus/reconstruct.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

constexpr float kD = 0.1f;

/// RMS distance to the best plane of the top-face vertices of a 24 × 24 × 8 block of spacing kD,
/// at least 4 d inside its vertical edges.
double top_face_rms(const TriangleMesh& m) {
  std::vector<Vec3f> face;
  const float top = 7 * kD, inner_lo = 4 * kD, inner_hi = 23 * kD - 4 * kD;
  for (const Vec3f& v : m.vertices)
    if (v.z > top + 0.25f * kD && v.x > inner_lo && v.y > inner_lo && v.x < inner_hi && v.y < inner_hi) face.push_back(v);
  EXPECT_GT(face.size(), 300u);
  return fit_plane(face).rms;
}

Params with_spacing(Params p = {}) {
  p.spacing = kD;
  return p;
}

/// 25 particles on a 5 × 5 grid `gap` spacings apart: 25 lone droplets.
ParticleSet lone_particles(float gap) {
  ParticleSet ps;
  for (int i = 0; i < 25; ++i) ps.positions.push_back(Vec3f{float(i % 5), float(i / 5), 0} * (gap * kD));
  return ps;
}

TEST(ArtistControls, SmoothnessFlattensMonotonicallyAndZeroLeavesTheExtractedMesh) {
  const ParticleSet block = test::lattice_block(24, 24, 8, kD, 0.1f, 17);
  // Measured: 0.076, 0.031, 0.022, 0.017, 0.014, 0.012 d.
  double previous = INFINITY;
  for (const double s : {0.0, 0.1, 0.25, 0.5, 0.75, 1.0}) {
    Params p = with_spacing();
    apply_smoothness(p, s);
    const auto t0 = std::chrono::steady_clock::now();
    const double rms = top_face_rms(reconstruct(block, p).mesh) / kD;
    std::printf("smoothness %.2f (%d A, %d B, %d free): top-face RMS %.4f d, %.2f s\n", s, p.steps_a, p.steps_b,
                p.steps_free, rms, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    EXPECT_LE(rms, previous) << "smoothness " << s;
    if (s == 0.0) {
      EXPECT_GT(rms, 0.05);
    }
    if (s == 1.0) {
      EXPECT_LT(rms, 0.015);
    }
    previous = rms;
  }
  Params zero = with_spacing(), unsmoothed = with_spacing();
  apply_smoothness(zero, 0);
  unsmoothed.steps_a = unsmoothed.steps_b = unsmoothed.steps_free = 0;
  EXPECT_EQ(reconstruct(block, zero).mesh.vertices, reconstruct(block, unsmoothed).mesh.vertices);
}

TEST(ArtistControls, DetailTwoGivesAboutFourTimesTheTriangles) {
  const ParticleSet block = test::lattice_block(24, 24, 8, kD, 0.1f, 17);
  const auto triangles = [&](double detail) {
    Params p = with_spacing();
    apply_detail(p, detail);
    const Result r = reconstruct(block, p);
    EXPECT_TRUE(analyze_topology(r.mesh).watertight()) << "detail " << detail;
    return double(r.mesh.triangles.size());
  };
  const double one = triangles(1);
  EXPECT_NEAR(triangles(2) / one, 4.0, 0.5);    // measured 3.86 (real dam-break frame: 4.12)
  EXPECT_NEAR(triangles(0.5) / one, 0.25, 0.06);  // measured 0.24
}

TEST(ArtistControls, PreviewIsFasterWithFewerTrianglesAndKeepsLoneDroplets) {
  const ParticleSet frame = read_particles(test::data_file("ply/dam_break_frame_9_6859_particles.ply"));
  const auto run = [&](const char* preset, double* seconds) {
    Params p;
    apply_preset(p, preset);
    const auto t0 = std::chrono::steady_clock::now();
    Result r = reconstruct(frame, p);
    *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return r;
  };
  double preview_seconds = 0, production_seconds = 0;
  const Result preview = run("preview", &preview_seconds);
  const Result production = run("production", &production_seconds);
  EXPECT_TRUE(analyze_topology(preview.mesh).watertight());
  EXPECT_LT(double(preview.mesh.triangles.size()), 0.5 * double(production.mesh.triangles.size()));
  EXPECT_LT(preview_seconds, production_seconds);  // a coarser field and fewer sweeps

  // Lone droplets survive the coarser field (at detail 0.5 they would keep little of their volume).
  Params p = with_spacing();
  apply_preset(p, "preview");
  const TriangleMesh drops = reconstruct(lone_particles(5), p).mesh;
  EXPECT_EQ(analyze_topology(drops).components, 25u);
  EXPECT_GT(signed_volume(drops) / 25 / (kD * kD * kD), 0.4);  // measured 0.49 (production: 0.50)
}

TEST(ArtistControls, DropletsKeepsStretchedSheetsWholeAndDropletsAtTheirVolume) {
  // A single layer of particles 2.2 spacings apart: the union of spheres of radius d has gaps.
  const ParticleSet sheet = test::lattice_block(20, 20, 1, 2.2f * kD, 0.15f, 9);
  Params production = with_spacing(), droplets = with_spacing();
  apply_preset(droplets, "droplets");
  const std::size_t pieces = analyze_topology(reconstruct(sheet, production).mesh).components;
  EXPECT_GE(pieces, 10u);  // measured 28 pieces
  const Result whole = reconstruct(sheet, droplets);
  EXPECT_EQ(analyze_topology(whole.mesh).components, 1u);
  // No free sweeps: every vertex stays in its shell.
  const ConstraintReport c =
      constraint_residual(whole.mesh.vertices, sheet.positions, whole.params.r_inner, whole.params.r_outer);
  EXPECT_LT(c.max_violation, 1e-5 * kD);

  // Each lone particle is one droplet of about one particle's volume d³ (production: d³/2).
  const ParticleSet lone = lone_particles(5);
  const TriangleMesh drops = reconstruct(lone, droplets).mesh;
  EXPECT_EQ(analyze_topology(drops).components, 25u);
  EXPECT_NEAR(signed_volume(drops) / 25 / (kD * kD * kD), 1.0, 0.15);  // measured 1.003
  const TriangleMesh small = reconstruct(lone, production).mesh;
  EXPECT_EQ(analyze_topology(small).components, 25u);
  EXPECT_NEAR(signed_volume(small) / 25 / (kD * kD * kD), 0.5, 0.1);  // measured 0.501
  std::printf("stretched sheet: production %zu pieces, droplets %zu; lone droplet volume / d³: droplets %.3f, "
              "production %.3f\n", pieces, analyze_topology(whole.mesh).components,
              signed_volume(drops) / 25 / (kD * kD * kD), signed_volume(small) / 25 / (kD * kD * kD));

  // The bulk comes out fuller (r_outer 1.25 d) and about as flat.
  const ParticleSet block = test::lattice_block(24, 24, 8, kD, 0.1f, 17);
  const TriangleMesh bulk_d = reconstruct(block, droplets).mesh, bulk_p = reconstruct(block, production).mesh;
  const double nd3 = double(block.size()) * kD * kD * kD;
  EXPECT_GT(signed_volume(bulk_d), signed_volume(bulk_p));
  EXPECT_LT(top_face_rms(bulk_d) / kD, 0.03);
  std::printf("jittered block: volume / N d³ droplets %.3f, production %.3f; top-face RMS droplets %.4f d, "
              "production %.4f d\n", signed_volume(bulk_d) / nd3, signed_volume(bulk_p) / nd3, top_face_rms(bulk_d) / kD,
              top_face_rms(bulk_p) / kD);
}

}  // namespace
}  // namespace meniscus
