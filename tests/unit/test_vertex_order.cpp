// Tests of the spatial renumbering the smoothing runs on (mesh/vertex_order.cpp, and the version
// shared with the device, mesh/vertex_order_backend.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <map>
#include <tuple>

#include "extract/extract.hpp"
#include "field/distance_field.hpp"
#include "common/primitives.hpp"
#include "meniscus/io.hpp"
#include "meniscus/reconstruct.hpp"
#include "mesh/vertex_order.hpp"
#include "mesh/vertex_order_backend.hpp"
#include "mesh/vertex_order_impl.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

TriangleMesh raw_extraction() {
  const float d = 0.1f, h = d / 2, r_outer = d;
  const ParticleSet particles = test::lattice_block(16, 9, 5, d, 0.2f, 7);
  const HashGrid grid(particles.positions, r_outer);
  const SampleLattice lattice{SampleLattice::Kind::a15, 2 * h};
  const float band = r_outer + 2 * h;
  return extract_surface(distance_field(grid, lattice, band, band_blocks(grid, lattice, band)), r_outer,
                         Extractor::tiles)
      .mesh;
}

// The vertices come in Z order (ties in their old order), each triangle is the same corners in the
// same rotation, and the triangles are sorted by their smallest new corner, ties in their old
// order — checked against an independent renumbering built from the positions.
TEST(VertexOrder, ZOrderedVerticesAndTrianglesByTheirSmallestCornerStably) {
  TriangleMesh before = raw_extraction();
  for (std::size_t i = 0; i < before.vertices.size(); ++i) before.normals.push_back({float(i), 0, 0});
  ASSERT_GT(before.triangles.size(), 20000u);
  TriangleMesh after = before;
  const float cell = 0.1f;
  reorder_vertices_spatially(after, cell);
  ASSERT_EQ(after.vertices.size(), before.vertices.size());
  ASSERT_EQ(after.triangles.size(), before.triangles.size());

  // The expected order: (Morton key, old index), by a comparison sort.
  std::vector<uint32_t> old_of_new(before.vertices.size());
  for (uint32_t i = 0; i < old_of_new.size(); ++i) old_of_new[i] = i;
  std::stable_sort(old_of_new.begin(), old_of_new.end(), [&](uint32_t a, uint32_t b) {
    return morton_key(before.vertices[a], 1.0f / cell) < morton_key(before.vertices[b], 1.0f / cell);
  });
  std::vector<uint32_t> new_of_old(old_of_new.size());
  for (uint32_t i = 0; i < old_of_new.size(); ++i) {
    new_of_old[old_of_new[i]] = i;
    ASSERT_EQ(after.vertices[i], before.vertices[old_of_new[i]]) << "vertex " << i;
    ASSERT_EQ(after.normals[i].x, float(old_of_new[i])) << "the normals move with their vertices";
  }
  std::vector<Triangle> expected = before.triangles;
  for (Triangle& t : expected)
    for (uint32_t& v : t) v = new_of_old[v];
  std::stable_sort(expected.begin(), expected.end(), [](const Triangle& a, const Triangle& b) {
    return std::min({a[0], a[1], a[2]}) < std::min({b[0], b[1], b[2]});
  });
  EXPECT_TRUE(after.triangles == expected);
}

// The CPU's renumbering (packed keys, no permutation array, the triangles sorted in place) is a
// fast path of the shared version the device runs: on a real frame's extraction, run with Host{},
// the two give the same vertices and triangles bit for bit.
TEST(VertexOrder, TheSharedVersionOnTheHostGivesTheCpusMeshOnARealFrame) {
  const ParticleSet particles = read_particles(test::data_file("ply/dam_break_frame_23_24389_particles.ply"));
  const float d = float(estimate_spacing(particles)), h = d / 2, r_outer = d;
  const HashGrid grid(particles.positions, r_outer);
  const SampleLattice lattice{SampleLattice::Kind::a15, 2 * h};
  const float band = r_outer + 2 * h;
  TriangleMesh cpu =
      extract_surface(distance_field(grid, lattice, band, band_blocks(grid, lattice, band)), r_outer, Extractor::tiles)
          .mesh;
  ASSERT_GT(cpu.vertices.size(), 50000u);
  MeshBuffers<Host> shared;
  shared.vertex_count = cpu.vertices.size();
  shared.triangle_count = cpu.triangles.size();
  shared.vertices.upload(cpu.vertices.data(), cpu.vertices.size());
  shared.triangles.upload(cpu.triangles.data()->data(), 3 * cpu.triangles.size());
  const float cell = lattice.cell_size;
  reorder_vertices_spatially(cpu, cell);
  reorder_vertices_spatially(Host{}, shared, cell);
  ASSERT_EQ(shared.vertex_count, cpu.vertices.size());
  ASSERT_EQ(shared.triangle_count, cpu.triangles.size());
  EXPECT_EQ(std::memcmp(shared.vertices.data(), cpu.vertices.data(), cpu.vertices.size() * sizeof(Vec3f)), 0);
  EXPECT_EQ(std::memcmp(shared.triangles.data(), cpu.triangles.data(), cpu.triangles.size() * sizeof(Triangle)), 0);
}

}  // namespace
}  // namespace meniscus

namespace meniscus {
namespace {

// The order is a function of each vertex's own position: the relative order of a frame's vertices
// is the same when the frame grows (a far particle, a bigger box) — what keeps the sweeps, whose
// sums follow the numbering, local. Cells are anchored at the origin and wrap every 1024 cells.
TEST(VertexOrder, TheKeyIsAFunctionOfThePositionAlone) {
  const float inv_cell = 1.0f / 0.05f;
  EXPECT_EQ(morton_key({0.01f, 0.01f, 0.01f}, inv_cell), 0u);
  EXPECT_EQ(morton_key({0.06f, 0, 0}, inv_cell), 1u);                    // x cell 1
  EXPECT_EQ(morton_key({0, 0.06f, 0}, inv_cell), 2u);                    // y cell 1
  EXPECT_EQ(morton_key({0, 0, 0.06f}, inv_cell), 4u);                    // z cell 1
  EXPECT_EQ(morton_key({-0.01f, 0, 0}, inv_cell), morton_key({1023 * 0.05f + 0.01f, 0, 0}, inv_cell));  // cell −1 ≡ 1023
  EXPECT_EQ(morton_key({0.06f, 0, 0}, inv_cell), morton_key({1024 * 0.05f + 0.06f, 0, 0}, inv_cell));  // wraps
  TriangleMesh small = raw_extraction();
  TriangleMesh grown = small;
  // A far-away triangle (a tiny droplet) appended: the frame's box is ten times larger.
  const uint32_t n = uint32_t(grown.vertices.size());
  grown.vertices.insert(grown.vertices.end(), {{40, 30, 20}, {40.01f, 30, 20}, {40, 30.01f, 20}});
  grown.triangles.push_back({n, n + 1, n + 2});
  reorder_vertices_spatially(small, 0.1f);
  reorder_vertices_spatially(grown, 0.1f);
  std::vector<Vec3f> kept;
  for (const Vec3f& v : grown.vertices)
    if (v.x < 30) kept.push_back(v);
  EXPECT_TRUE(kept == small.vertices) << "the frame's vertices keep their relative order";
}

}  // namespace
}  // namespace meniscus
