// Tests of the mesh quality metrics on meshes built by hand.
#include <gtest/gtest.h>

#include <numbers>
#include <random>

#include "meniscus/quality.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

using test::grid_mesh;
using test::icosphere;

// Unit cube, 12 triangles, outward facing.
TriangleMesh cube() {
  TriangleMesh m;
  for (int i = 0; i < 8; ++i) m.vertices.push_back({float(i & 1), float((i >> 1) & 1), float((i >> 2) & 1)});
  m.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                 {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  return m;
}

TEST(Quality, ClosedCubeIsWatertightGenusZero) {
  const TriangleMesh m = cube();
  const TopologyReport t = analyze_topology(m);
  EXPECT_TRUE(t.watertight());
  EXPECT_EQ(t.edges, 18u);
  EXPECT_EQ(t.euler, 2);
  EXPECT_EQ(t.components, 1u);
  EXPECT_EQ(t.degenerate_triangles, 0u);
  EXPECT_NEAR(signed_volume(m), 1.0, 1e-6);
  const ValenceReport v = valence(m);
  EXPECT_EQ(v.min, 3);  // corners 0 and 7 get no face diagonal
  EXPECT_EQ(v.max, 5);
  EXPECT_EQ(v.below_5, 2u);
}

TEST(Quality, DetectsHolesFlipsAndNonManifoldEdges) {
  TriangleMesh open = cube();
  open.triangles.pop_back();
  TopologyReport t = analyze_topology(open);
  EXPECT_EQ(t.boundary_edges, 3u);
  EXPECT_FALSE(t.closed());

  TriangleMesh flipped = cube();
  std::swap(flipped.triangles[0][1], flipped.triangles[0][2]);
  t = analyze_topology(flipped);
  EXPECT_EQ(t.misoriented_edges, 3u);
  EXPECT_FALSE(t.oriented());

  TriangleMesh fin = cube();
  fin.vertices.push_back({0.5f, 0.5f, 2});
  fin.triangles.push_back({0, 1, 8});  // a third triangle on edge (0,1)
  t = analyze_topology(fin);
  EXPECT_EQ(t.nonmanifold_edges, 1u);

  // Two cubes sharing only vertex 7 ↔ a bow-tie vertex.
  TriangleMesh two = cube();
  const TriangleMesh c2 = cube();
  for (const Vec3f& v : c2.vertices) two.vertices.push_back(v + Vec3f{1, 1, 1});
  for (Triangle tr : c2.triangles) {
    for (auto& i : tr) i = i == 0 ? 7 : i + 8;
    two.triangles.push_back(tr);
  }
  t = analyze_topology(two);
  EXPECT_EQ(t.nonmanifold_vertices, 1u);
  EXPECT_EQ(t.components, 2u);
  EXPECT_EQ(t.boundary_edges, 0u);
}

TEST(Quality, DegenerateTrianglesAreCounted) {
  TriangleMesh m = cube();
  m.triangles.push_back({0, 0, 1});
  m.vertices.push_back({2, 0, 0});
  m.triangles.push_back({0, 1, 8});  // collinear: zero area
  EXPECT_EQ(analyze_topology(m).degenerate_triangles, 2u);
}

TEST(Quality, PlaneFitRecoversATiltedPlane) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1, 1);
  std::normal_distribution<float> noise(0, 0.01f);
  const Vec3f n = normalized(Vec3f{0.2f, -0.3f, 1.0f});
  const Vec3f e1 = normalized(cross(n, Vec3f{1, 0, 0})), e2 = cross(n, e1);
  std::vector<Vec3f> pts;
  for (int i = 0; i < 20000; ++i) pts.push_back(Vec3f{5, 1, 2} + e1 * u(rng) + e2 * u(rng) + n * noise(rng));
  const PlaneFit fit = fit_plane(pts);
  EXPECT_NEAR(std::abs(dot(fit.normal, n)), 1.0f, 1e-4f);
  EXPECT_NEAR(fit.rms, 0.01, 0.0005);
  EXPECT_NEAR(fit.centroid.x, 5.0f, 0.02f);
}

TEST(Quality, ConstraintResidualMatchesBruteForce) {
  const std::vector<Vec3f> particles{{0, 0, 0}, {3, 0, 0}};
  const std::vector<Vec3f> x{{0.7f, 0, 0}, {0.2f, 0, 0}, {4.5f, 0, 0}};
  const ConstraintReport r = constraint_residual(x, particles, 0.5, 1.0);
  EXPECT_NEAR(r.min_distance, 0.2, 1e-6);
  EXPECT_NEAR(r.max_distance, 1.5, 1e-6);
  EXPECT_NEAR(r.max_violation, 0.5, 1e-6);
}

TEST(Quality, AnglesOfARightTriangle) {
  TriangleMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.triangles = {{0, 1, 2}};
  const AngleReport a = triangle_angles(m);
  EXPECT_NEAR(a.min_degrees, 45, 1e-4);
  EXPECT_NEAR(a.max_degrees, 90, 1e-4);
  EXPECT_EQ(a.share_below_10, 0);
}

}  // namespace
}  // namespace meniscus

namespace meniscus {
namespace {

TEST(Quality, PointsOutsideByRayParity) {
  // The cube of test Quality.ClosedCube…, scaled: points inside, outside, and on the lattice of
  // its vertices' coordinates (the ray must not double-count at shared edges).
  TriangleMesh m;
  for (int i = 0; i < 8; ++i) m.vertices.push_back({float(i & 1) * 2, float((i >> 1) & 1) * 2, float((i >> 2) & 1) * 2});
  m.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                 {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  std::mt19937 rng(8);
  std::uniform_real_distribution<float> u(-1, 3);
  std::vector<Vec3f> pts;
  std::size_t expected_outside = 0;
  for (int i = 0; i < 5000; ++i) {
    const Vec3f p{u(rng), u(rng), u(rng)};
    pts.push_back(p);
    expected_outside += !(p.x > 0 && p.x < 2 && p.y > 0 && p.y < 2 && p.z > 0 && p.z < 2);
  }
  pts.push_back({1, 1, 1});  // on the face diagonals' plane projection: inside
  pts.push_back({0.5f, 1, 1});
  EXPECT_EQ(points_outside(m, pts), expected_outside);
}

// On a sphere of radius R, K = 1/R² everywhere: ∫ √K dA = 4πR, so 4πR / (3√3·bound) triangles.
TEST(Quality, LeastTrianglesOnASphereFollowItsCurvature) {
  for (float radius : {1.0f, 3.0f}) {
    const TriangleMesh sphere = icosphere(6, radius);
    for (double bound : {1e-3, 4e-3}) {
      const double expected = 4 * std::numbers::pi * radius / (3 * std::sqrt(3.0) * bound);
      EXPECT_NEAR(least_triangles_within(sphere, bound), expected, 0.01 * expected) << radius << " " << bound;
    }
  }
  EXPECT_EQ(least_triangles_within(icosphere(6), 0), 0);
}

// A real mesh within the bound has at least as many triangles as the estimate, which is near it
// for a good one: the icosphere of 320 triangles, grown until it lies as far outside the unit
// sphere at its corners as inside it at its faces' centres, is within that distance of the
// sphere both ways.
TEST(Quality, LeastTrianglesIsALowerBoundAndNearlyMet) {
  const TriangleMesh coarse = icosphere(2);
  double nearest = 1;  // the faces' planes' least distance from the centre
  for (const Triangle& t : coarse.triangles) {
    const Vec3f a = coarse.vertices[t[0]], b = coarse.vertices[t[1]], c = coarse.vertices[t[2]];
    nearest = std::min(nearest, double(std::fabs(dot(normalized(cross(b - a, c - a)), a))));
  }
  const double bound = 2 / (1 + nearest) - 1;  // grown by 1 + bound: corners and centres both off by it
  const double least = least_triangles_within(icosphere(6), bound);
  EXPECT_LE(least, double(coarse.triangles.size()));
  EXPECT_GE(least, 0.8 * double(coarse.triangles.size()));
}

// Flat parts and borders add nothing; a saddle neither.
TEST(Quality, LeastTrianglesIgnoresFlatSaddleAndBorder) {
  EXPECT_EQ(least_triangles_within(grid_mesh(40, 40, [](uint32_t, uint32_t) { return 0.0f; }), 0.01), 0);
  const TriangleMesh saddle = grid_mesh(40, 40, [](uint32_t x, uint32_t y) {
    const float u = (float(x) - 19.5f) / 20, v = (float(y) - 19.5f) / 20;
    return 4 * (u * u - v * v);
  });
  EXPECT_LT(least_triangles_within(saddle, 0.01), 1.0);
  // A closed surface: each of the sphere's halves holds half of it.
  const double whole = least_triangles_within(icosphere(5), 0.01);
  TriangleMesh half = icosphere(5);
  std::erase_if(half.triangles, [&](const Triangle& t) { return half.vertices[t[0]].z < 0; });
  EXPECT_NEAR(least_triangles_within(half, 0.01), 0.5 * whole, 0.05 * whole);
}

}  // namespace
}  // namespace meniscus
