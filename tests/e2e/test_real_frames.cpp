// The whole pipeline on real simulator frames (tests/data/ply, converted from the files in
// tests/data by tools/convert_frames.py): closed, manifold, oriented meshes without degenerate
// triangles, valence ≥ 5 with Marching Tiles, and every vertex inside its constraint shell.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "meniscus/io.hpp"
#include "meniscus/quality.hpp"
#include "meniscus/reconstruct.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

class RealFrame : public ::testing::TestWithParam<std::string> {};

TEST_P(RealFrame, TilesGiveAWatertightMeshInsideTheConstraints) {
  const ParticleSet ps = read_particles(test::data_file("ply/" + GetParam()));
  Params p;
  p.steps_free = 0;  // so that every vertex must satisfy the constraint exactly
  const Result r = reconstruct(ps, p);
  const TopologyReport t = analyze_topology(r.mesh);
  EXPECT_GT(t.triangles, 1000u);
  EXPECT_TRUE(t.closed()) << t.boundary_edges << " boundary edges";
  EXPECT_TRUE(t.edge_manifold()) << t.nonmanifold_edges << " non-manifold edges";
  EXPECT_TRUE(t.oriented()) << t.misoriented_edges << " misoriented edges";
  EXPECT_EQ(t.nonmanifold_vertices, 0u);
  EXPECT_EQ(t.degenerate_triangles, 0u);
  EXPECT_EQ(t.unreferenced_vertices, 0u);
  const ValenceReport v = valence(r.mesh);
  EXPECT_GE(v.min, 5);
  const ConstraintReport c = constraint_residual(r.mesh.vertices, ps.positions, r.params.r_inner, r.params.r_outer);
  // Exact up to the rounding of float positions: at a coordinate of magnitude m, a projected
  // vertex lands up to FLT_EPSILON·m off its shell (0.2 % of r_inner on the free-particles frame).
  float magnitude = 0;
  for (const Vec3f& x : r.mesh.vertices) magnitude = std::max({magnitude, std::abs(x.x), std::abs(x.y), std::abs(x.z)});
  EXPECT_LE(c.max_violation, 1e-5 * r.params.r_outer + 2 * std::numeric_limits<float>::epsilon() * magnitude)
      << "vertex distances " << c.min_distance << " .. " << c.max_distance << " vs [" << r.params.r_inner << ", "
      << r.params.r_outer << "]";
  EXPECT_GT(signed_volume(r.mesh), 0);
}

TEST_P(RealFrame, MarchingCubesIsWatertightButHasLowValence) {
  const ParticleSet ps = read_particles(test::data_file("ply/" + GetParam()));
  Params p;
  p.extract = Extractor::cubes;
  p.steps_a = p.steps_b = p.steps_free = 0;
  const Result r = reconstruct(ps, p);
  const TopologyReport t = analyze_topology(r.mesh);
  EXPECT_TRUE(t.watertight()) << t.boundary_edges << " boundary, " << t.nonmanifold_edges << " non-manifold, "
                              << t.misoriented_edges << " misoriented edges";
  EXPECT_EQ(t.degenerate_triangles, 0u);
  const ValenceReport v = valence(r.mesh);
  EXPECT_LT(v.min, 5);
  EXPECT_GT(double(v.below_5) / double(r.mesh.vertices.size()), 0.02);
}

INSTANTIATE_TEST_SUITE_P(Data, RealFrame, ::testing::ValuesIn(test::real_frames()), [](const auto& test_info) {
  std::string name = test_info.param.substr(0, test_info.param.find('.'));
  for (char& ch : name)
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  return name;
});

}  // namespace
}  // namespace meniscus
