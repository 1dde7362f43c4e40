// Tests of the voids and blobs written once over the backend tag (mesh/voids_backend.hpp: hooking
// union-find, atomic volume sums; what the device runs) against the CPU's (mesh/voids.cpp).
#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

#include "common/primitives.hpp"
#include "extract/extract.hpp"
#include "field/distance_field.hpp"
#include "meniscus/io.hpp"
#include "meniscus/reconstruct.hpp"
#include "mesh/voids.hpp"
#include "mesh/voids_backend.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

MeshBuffers<Host> buffers_of(const TriangleMesh& m) {
  MeshBuffers<Host> b;
  b.vertices.upload(m.vertices.data(), m.vertices.size());
  b.triangles.upload(m.triangles.data()->data(), 3 * m.triangles.size());
  b.vertex_count = m.vertices.size();
  b.triangle_count = m.triangles.size();
  return b;
}

void expect_same_mesh(const MeshBuffers<Host>& shared, const TriangleMesh& cpu) {
  ASSERT_EQ(shared.vertex_count, cpu.vertices.size());
  ASSERT_EQ(shared.triangle_count, cpu.triangles.size());
  EXPECT_EQ(std::memcmp(shared.vertices.data(), cpu.vertices.data(), sizeof(Vec3f) * shared.vertex_count), 0);
  EXPECT_EQ(std::memcmp(shared.triangles.data(), cpu.triangles.data(), sizeof(Triangle) * shared.triangle_count), 0);
}

// On the raw meshes of real frames (the distance field's extraction: voids in the sampling gaps,
// droplets), with small and large thresholds: the shared version run with Host{} removes as many
// components as the CPU's and leaves the same vertices and triangles, in the same order.
TEST(VoidsBackend, SharedVersionOnTheHostRemovesWhatTheCpuRemoves) {
  std::size_t removed_voids = 0, removed_blobs = 0;
  for (const char* frame : {"dam_break_frame_23_24389_particles.ply", "sphysics_dam_break_IPART_29814_particles.ply"}) {
    SCOPED_TRACE(frame);
    const ParticleSet ps = read_particles(test::data_file(std::string("ply/") + frame));
    const float d = float(estimate_spacing(ps)), r_outer = d;
    const HashGrid grid(ps.positions, r_outer);
    const SampleLattice lattice{SampleLattice::Kind::a15, d};
    const float band = r_outer + d;
    const TriangleMesh raw =
        extract_surface(distance_field(grid, lattice, band, band_blocks(grid, lattice, band)), r_outer, Extractor::tiles)
            .mesh;
    ASSERT_GT(raw.triangles.size(), 10000u);

    GridBuffers<Host> points;
    points.sorted.upload(grid.points(), grid.size());
    points.keys.upload(grid.cell_keys().data(), grid.cell_keys().size());
    points.starts.upload(grid.cell_starts().data(), grid.cell_starts().size());
    points.cells = uint32_t(grid.cell_keys().size());
    points.count = uint32_t(grid.size());
    points.cell_size = grid.cell_size();
    points.lo = grid.cell_min();
    points.hi = grid.cell_max();

    for (double scale : {1.0, 1000.0}) {
      const double max_volume = scale * small_component_volume(d);
      {
        TriangleMesh cpu = raw;
        MeshBuffers<Host> shared = buffers_of(raw);
        const std::size_t removed = remove_small_voids(cpu, max_volume);
        EXPECT_EQ(remove_small_voids(Host{}, shared, max_volume), removed) << scale;
        expect_same_mesh(shared, cpu);
        removed_voids += removed;
      }
      {
        TriangleMesh cpu = raw;
        MeshBuffers<Host> shared = buffers_of(raw);
        const double min_volume = max_volume / 4;
        const std::size_t removed = remove_unsupported_blobs(cpu, grid, max_volume, min_volume);
        EXPECT_EQ(remove_unsupported_blobs(Host{}, shared, points, max_volume, min_volume), removed) << scale;
        expect_same_mesh(shared, cpu);
        removed_blobs += removed;
      }
    }
  }
  EXPECT_GT(removed_voids, 0u);
  EXPECT_GT(removed_blobs, 0u);
}

}  // namespace
}  // namespace meniscus
