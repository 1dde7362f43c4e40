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
#include <map>
#include <string>

#include "meniscus/io.hpp"
#include "meniscus/quality.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

// A sphere of radius r about c: an icosahedron subdivided `levels` times, its vertices on the sphere.
TriangleMesh sphere(Vec3f c, float r, int levels = 5) {
  const float t = (1 + std::sqrt(5.0f)) / 2;
  std::vector<Vec3f> v{{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                       {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<Triangle> f{{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                          {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                          {3, 8, 9},  {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> middle;
    const auto mid = [&](uint32_t a, uint32_t b) {
      const auto key = std::minmax(a, b);
      auto [it, made] = middle.try_emplace({key.first, key.second}, uint32_t(v.size()));
      if (made) v.push_back((v[a] + v[b]) * 0.5f);
      return it->second;
    };
    std::vector<Triangle> next;
    for (const Triangle& x : f) {
      const uint32_t ab = mid(x[0], x[1]), bc = mid(x[1], x[2]), ca = mid(x[2], x[0]);
      next.insert(next.end(), {Triangle{x[0], ab, ca}, Triangle{x[1], bc, ab}, Triangle{x[2], ca, bc}, Triangle{ab, bc, ca}});
    }
    f = std::move(next);
  }
  TriangleMesh m;
  for (const Vec3f& p : v) m.vertices.push_back(c + normalized(p) * r);
  m.triangles = f;
  return m;
}

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
