// The jitter of a sequence (quality.hpp surface_jitter; inspect --flicker, the surface summary): the
// flicker without the motion. A surface moving at a constant velocity has none to first order
// however fast it moves; one that swells by e in its middle frame has e; the CLI reports it per
// frame, in d.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <array>
#include <cstdio>
#include <cmath>
#include <filesystem>
#include <string>

#include "meniscus/io.hpp"
#include "meniscus/quality.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

// A sphere of radius r about c (test::icosphere: an icosahedron subdivided five times).
TriangleMesh sphere(Vec3f c, float r) { return test::icosphere(5, r, c); }

TEST(Jitter, ASurfaceMovingSteadilyHasNoneAndOneThatSwellsHasTheSwell) {
  const Vec3f step{0.05f, 0.02f, 0};
  const TriangleMesh a = sphere({0, 0, 0}, 1), b = sphere(step, 1), c = sphere(step * 2, 1);
  // The flicker sees the motion; the jitter does not.
  EXPECT_GT(distance_to_surface(b.vertices, a, 1.0).mean, 0.01);
  // What is left is of second order: on a sphere of radius R moved by δ, s₋ + s₊ = |δ|²/R less
  // its normal part (0.0029 here at most, so at most 0.00145 after halving).
  const JitterReport steady = surface_jitter(a, b, c, kJitterPoints, 1, 1.0);
  std::printf("[ measured ] steady: jitter median %.5f, p90 %.5f\n", steady.median, steady.p90);
  EXPECT_EQ(steady.points, kJitterPoints);
  EXPECT_LT(steady.median, 0.00145);
  EXPECT_LT(steady.p90, 0.00145);
  // The middle frame 0.01 larger: 0.01, plus that second-order part.
  const JitterReport swell = surface_jitter(a, sphere(step, 1.01f), c, kJitterPoints, 1, 1.0);
  std::printf("[ measured ] swell 0.01: jitter median %.5f, p90 %.5f\n", swell.median, swell.p90);
  EXPECT_GT(swell.median, 0.0098);
  EXPECT_LT(swell.median, 0.0115);
  // A surface beyond the cap is left out (a droplet that appears is topology, not jitter).
  TriangleMesh with_drop = b;
  const TriangleMesh drop = sphere({5, 0, 0}, 0.5f);
  for (const Triangle& t : drop.triangles)
    with_drop.triangles.push_back({t[0] + uint32_t(b.vertices.size()), t[1] + uint32_t(b.vertices.size()),
                                   t[2] + uint32_t(b.vertices.size())});
  with_drop.vertices.insert(with_drop.vertices.end(), drop.vertices.begin(), drop.vertices.end());
  const JitterReport dropped = surface_jitter(a, with_drop, c, kJitterPoints, 1, 1.0);
  EXPECT_GT(dropped.beyond_cap, 0u);
  EXPECT_EQ(dropped.points + dropped.beyond_cap, kJitterPoints);
  EXPECT_LT(dropped.median, 0.00145);
}

// inspect --flicker reports each inner frame's jitter, in d with --spacing, and the sequence's.
TEST(Jitter, InspectReportsItPerFrameAndForTheSequence) {
  test::TempDir tmp;
  const float swell[4] = {1.0f, 1.02f, 1.0f, 1.0f};  // frame 2 swells by 0.02 = 0.2 d at d = 0.1
  for (int f = 0; f < 4; ++f)
    write_mesh(tmp.file("s_000" + std::to_string(f + 1) + ".ply"), sphere(Vec3f{0.03f, 0, 0} * float(f), swell[f]));
  std::string out;
  ASSERT_EQ(test::run_command(test::cli() + " inspect '" + tmp.file("s_####.ply") + "' --flicker --spacing 0.1 --json", &out),
            0)
      << out;
  const auto j = nlohmann::json::parse(out);
  ASSERT_EQ(j["frames"].size(), 4u);
  EXPECT_FALSE(j["frames"][0].contains("jitter"));
  EXPECT_FALSE(j["frames"][3].contains("jitter"));
  EXPECT_EQ(j["frames"][1]["jitter"]["unit"], "d");
  EXPECT_NEAR(j["frames"][1]["jitter"]["median"].get<double>(), 0.2, 0.01);
  // Frame 3 sits between the swollen frame and a steady one: half the swell.
  EXPECT_NEAR(j["frames"][2]["jitter"]["median"].get<double>(), 0.1, 0.01);
  EXPECT_EQ(j["summary"]["jitter"]["frames"], 2);
  EXPECT_NEAR(j["summary"]["jitter"]["max"].get<double>(), 0.2, 0.01);
  ASSERT_EQ(test::run_command(test::cli() + " inspect '" + tmp.file("s_####.ply") + "' --flicker --spacing 0.1", &out), 0)
      << out;
  EXPECT_NE(out.find("jitter median 0.2"), std::string::npos) << out;
  EXPECT_NE(out.find("jitter (the flicker without the motion) median"), std::string::npos) << out;
}

}  // namespace
}  // namespace meniscus
