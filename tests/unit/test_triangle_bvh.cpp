// Tests of the BVH queries (quality/triangle_bvh.hpp) and of the point-to-surface distance built on
// them: exact answers against brute force, and the work of a query bounded where a search
// without a cap is not (far points, unrelated surfaces, a droplet at the centre of a hollow shell).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "meniscus/quality.hpp"
#include "mesh/closest_point_impl.hpp"
#include "quality/triangle_bvh.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

using test::icosphere;


float brute_force_distance(Vec3f p, const TriangleMesh& m) {
  float best = INFINITY;
  for (const Triangle& t : m.triangles)
    best = std::min(best, length2(closest_point_on_triangle(p, m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]]) - p));
  return std::sqrt(best);
}

TEST(TriangleBvh, ClosestPointsEqualBruteForceNearAndFar) {
  const TriangleMesh m = icosphere(4, 1.0f, {0.3f, -0.2f, 0.1f});  // 5120 triangles
  const TriangleBvh bvh(m.vertices, m.triangles);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1, 1);
  for (int i = 0; i < 2000; ++i) {
    // Near the sphere, inside it, and up to 100 radii away.
    const float scale = i < 1000 ? 1.5f : (i < 1500 ? 0.5f : 100.0f);
    const Vec3f p = Vec3f{u(rng), u(rng), u(rng)} * scale;
    const float expected = brute_force_distance(p, m);
    const TriangleBvh::Closest c = bvh.closest(p);
    ASSERT_EQ(c.distance, expected) << "point " << i;
    ASSERT_LT(c.triangle, m.triangles.size());
    const Triangle& t = m.triangles[c.triangle];
    EXPECT_EQ(length(closest_point_on_triangle(p, m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]]) - p), expected);
    // With a cap the answer is the same when the surface lies within it, none otherwise.
    const TriangleBvh::Closest capped = bvh.closest(p, 0.25f);
    if (expected < 0.25f) {
      EXPECT_EQ(capped.distance, expected) << i;
    } else if (expected > 0.25f) {
      EXPECT_EQ(capped.triangle, UINT32_MAX) << i;
    }
  }
}

TEST(TriangleBvh, InsideByRayParityOnNestedShellsAndLatticePoints) {
  // A hollow ball: the outer sphere faces out, the inner one in (its triangles reversed).
  TriangleMesh m = icosphere(3, 1.0f);
  const TriangleMesh inner = icosphere(3, 0.5f);
  const uint32_t base = uint32_t(m.vertices.size());
  m.vertices.insert(m.vertices.end(), inner.vertices.begin(), inner.vertices.end());
  for (const Triangle& t : inner.triangles) m.triangles.push_back({base + t[0], base + t[2], base + t[1]});
  const TriangleBvh bvh(m.vertices, m.triangles);
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(-1.3f, 1.3f);
  int checked = 0;
  for (int i = 0; i < 5000; ++i) {
    const Vec3f p{u(rng), u(rng), u(rng)};
    const float r = length(p);
    if (std::abs(r - 1) < 0.02f || std::abs(r - 0.5f) < 0.02f) continue;  // the polyhedra are inside the spheres
    EXPECT_EQ(bvh.inside(p), r < 1 && r > 0.5f) << p.x << " " << p.y << " " << p.z;
    ++checked;
  }
  EXPECT_GT(checked, 4000);
  // Rays through the vertices' own coordinates (shared edges, shared vertices) are nudged off.
  std::size_t inside = 0;
  for (uint32_t k = 0; k < base; ++k) inside += bvh.inside(m.vertices[k] * 0.75f);
  EXPECT_EQ(inside, base);
  EXPECT_FALSE(bvh.inside({0, 0, 0}));
  EXPECT_FALSE(bvh.inside({5, 0, 0}));
}

TEST(SurfaceDistance, CapCountsFarPointsAtItAndMatchesBruteForceWithin) {
  const TriangleMesh m = icosphere(4, 1.0f);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-2, 2);
  std::vector<Vec3f> pts(3000);
  for (Vec3f& p : pts) p = {u(rng), u(rng), u(rng)};
  const double cap = 0.3;
  std::size_t beyond = 0;
  double sum = 0, worst = 0;
  for (const Vec3f& p : pts) {
    const double d = brute_force_distance(p, m);
    beyond += d >= cap;
    sum += std::min(d, cap);
    worst = std::max(worst, std::min(d, cap));
  }
  const SurfaceDistanceReport r = distance_to_surface(pts, m, cap);
  EXPECT_EQ(r.count, pts.size());
  EXPECT_EQ(r.beyond_cap, beyond);
  EXPECT_GT(beyond, 1000u);  // the test means something
  EXPECT_NEAR(r.mean, sum / double(pts.size()), 1e-6);
  EXPECT_NEAR(r.max, worst, 1e-6);
  EXPECT_EQ(r.cap, cap);
  // Without a cap every distance is exact.
  const SurfaceDistanceReport all = distance_to_surface(pts, m);
  EXPECT_EQ(all.beyond_cap, 0u);
  EXPECT_GT(all.max, 2.0);
}

// The work of the flicker measure, counted in point–triangle tests (deterministic, unlike time), on
// the cases where a search without a cap would take minutes. The bound: each point tests only
// triangles within the cap of it, so points far from the surface cost nothing and the rest cost the
// triangles near them.
TEST(SurfaceDistance, WorkIsBoundedOnUnrelatedFarAndNestedSurfaces) {
  const TriangleMesh big = icosphere(5, 1.0f);  // 20480 triangles, edge ≈ 0.03
  const double cap = 0.12;                      // four "spacings" of ≈ 4 edges

  // The same surface slightly moved: the common case, a handful of tests per vertex.
  std::vector<Vec3f> moved = big.vertices;
  for (Vec3f& v : moved) v += Vec3f{0.004f, 0, 0};
  const SurfaceDistanceReport near = distance_to_surface(moved, big, cap);
  EXPECT_EQ(near.beyond_cap, 0u);
  EXPECT_LE(near.max, 0.0041);
  EXPECT_LT(double(near.triangle_tests) / double(near.count), 16);

  // A surface far away: no tests at all.
  std::vector<Vec3f> far = big.vertices;
  for (Vec3f& v : far) v += Vec3f{1000, 0, 0};
  const SurfaceDistanceReport gone = distance_to_surface(far, big, cap);
  EXPECT_EQ(gone.beyond_cap, far.size());
  EXPECT_EQ(gone.triangle_tests, 0u);

  // A droplet at the centre of the hollow shell: every shell triangle is equally far, the worst
  // case of a closest-point search; the cap makes it free.
  const TriangleMesh droplet = icosphere(2, 0.02f);
  const SurfaceDistanceReport centre = distance_to_surface(droplet.vertices, big, cap);
  EXPECT_EQ(centre.beyond_cap, droplet.vertices.size());
  EXPECT_EQ(centre.triangle_tests, 0u);
  // Uncapped it is exact, and costs the whole shell per vertex: why the flicker has a cap.
  const SurfaceDistanceReport uncapped = distance_to_surface(droplet.vertices, big);
  EXPECT_NEAR(uncapped.mean, 0.98, 0.005);
  EXPECT_GT(double(uncapped.triangle_tests) / double(uncapped.count), 1000);

  // A full frame after a droplet, and a droplet after a full frame (the droplet near the shell).
  const TriangleMesh drop = icosphere(2, 0.02f, {0.0f, 0.0f, 1.03f});
  const SurfaceDistanceReport after_drop = distance_to_surface(big.vertices, drop, cap);
  EXPECT_LT(double(after_drop.triangle_tests) / double(after_drop.count), 1);
  const SurfaceDistanceReport drop_after = distance_to_surface(drop.vertices, big, cap);
  const auto per = [](const SurfaceDistanceReport& r) { return double(r.triangle_tests) / double(r.count); };
  std::printf("triangle tests per point: moved %.2f, far %.2f, droplet at the centre %.2f (uncapped %.0f), "
              "full after a droplet %.3f, droplet after full %.1f\n",
              per(near), per(gone), per(centre), per(uncapped), per(after_drop), per(drop_after));
  EXPECT_EQ(drop_after.beyond_cap, 0u);
  EXPECT_LT(double(drop_after.triangle_tests) / double(drop_after.count), 20);
}

TEST(SurfaceDistance, RefusesTrianglesPastTheVertices) {
  TriangleMesh m = icosphere(1, 1.0f);
  m.triangles.push_back({0, 1, uint32_t(m.vertices.size())});
  const std::vector<Vec3f> pts = {{0, 0, 0}};
  EXPECT_THROW(distance_to_surface(pts, m, 1.0), std::invalid_argument);
  EXPECT_THROW(distance_to_surface(pts, m), std::invalid_argument);
}

TEST(Quality, MeanEdgeLength) {
  TriangleMesh m;
  m.vertices = {{0, 0, 0}, {3, 0, 0}, {0, 4, 0}};
  m.triangles = {{0, 1, 2}};
  EXPECT_DOUBLE_EQ(mean_edge_length(m), 4.0);
  EXPECT_EQ(mean_edge_length(TriangleMesh{}), 0.0);
}

}  // namespace
}  // namespace meniscus
