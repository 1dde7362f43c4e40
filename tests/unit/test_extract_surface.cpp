// meniscus tests — extract_surface on analytic fields: Marching Tiles (Williams 2008), Marching
// Cubes (Lorensen & Cline 1987) and Marching Tetrahedra (Doi & Koide 1991): topology, volume,
// accuracy, valence, determinism, clamping and the key range.
#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <numbers>
#include <string>
#include <vector>

#include "common/primitives.hpp"
#include "extract/extract.hpp"
#include "extract/extract_backend.hpp"
#include "extract/tile_table.hpp"
#include "field/distance_field.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "meniscus/quality.hpp"
#include "meniscus/reconstruct.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

constexpr float kBackground = 1e6f;

const char* name(Extractor e) {
  return e == Extractor::tiles ? "tiles" : e == Extractor::cubes ? "cubes" : "tetrahedra";
}

/// The lattice an extractor marches, at the sample density of a cubic grid of spacing h
/// (the A15 cell holds 8 samples, so a = 2h).
SampleLattice lattice_for(Extractor e, float h) {
  SampleLattice lattice;
  lattice.kind = e == Extractor::tiles ? SampleLattice::Kind::a15 : SampleLattice::Kind::cubic;
  lattice.cell_size = e == Extractor::tiles ? 2 * h : h;
  return lattice;
}

/// Longest lattice edge a vertex can lie on, in world units.
float longest_edge(const SampleLattice& lattice, Extractor e) {
  if (e == Extractor::cubes) return lattice.cell_size;
  if (e == Extractor::tetrahedra) return std::sqrt(3.0f) * lattice.cell_size;
  float longest = 0;
  for (int t = 0; t < kA15EdgeTypeCount; ++t) {
    const LatticeEdge& edge = kA15EdgeTable.types[t];
    const Vec3f d =
        lattice.sample_position({edge.dx, edge.dy, edge.dz}, edge.s1) - lattice.sample_position({}, edge.s0);
    longest = std::max(longest, length(d));
  }
  return longest;
}

/// A field holding phi(sample position) in every block that meets the box [lo, hi].
SparseField make_field(const SampleLattice& lattice, Vec3f lo, Vec3f hi, const std::function<float(Vec3f)>& phi,
                       float background = kBackground) {
  const int n = lattice.block_cells();
  const float extent = float(n) * lattice.cell_size;
  auto block_of = [&](float v) { return int(std::floor(v / extent)); };
  std::vector<uint64_t> keys;
  for (int z = block_of(lo.z); z <= block_of(hi.z); ++z)
    for (int y = block_of(lo.y); y <= block_of(hi.y); ++y)
      for (int x = block_of(lo.x); x <= block_of(hi.x); ++x) keys.push_back(pack_coords(x, y, z));
  std::sort(keys.begin(), keys.end());
  SparseField field(lattice, keys, background);
  for (std::size_t b = 0; b < field.block_count(); ++b) {
    const Vec3i o = field.block_origin(b);
    for (int z = 0; z < n; ++z)
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x)
          for (int s = 0; s < lattice.samples_per_cell(); ++s)
            field.block_values(b)[field.local_index({x, y, z}, s)] =
                phi(lattice.sample_position(o + Vec3i{x, y, z}, s));
  }
  return field;
}

struct Ball {
  Vec3f center;
  float radius;
};

/// φ = distance to the nearest ball's surface (negative inside); the union's surface is φ = 0.
float union_phi(const std::vector<Ball>& balls, Vec3f x) {
  float phi = kBackground;
  for (const Ball& b : balls) phi = std::min(phi, length(x - b.center) - b.radius);
  return phi;
}

void expect_watertight(const TopologyReport& r, const std::string& what) {
  EXPECT_GT(r.triangles, 0u) << what;
  EXPECT_TRUE(r.closed()) << what << ": " << r.boundary_edges << " boundary edges";
  EXPECT_TRUE(r.edge_manifold()) << what << ": " << r.nonmanifold_edges << " non-manifold edges";
  EXPECT_TRUE(r.oriented()) << what << ": " << r.misoriented_edges << " misoriented edges";
  EXPECT_EQ(r.nonmanifold_vertices, 0u) << what;
  EXPECT_EQ(r.degenerate_triangles, 0u) << what;
  EXPECT_EQ(r.unreferenced_vertices, 0u) << what;
}

class ExtractSurface : public ::testing::TestWithParam<Extractor> {};

// A sphere of radius R = 1 as the level set R of |x − c| at h = R/10, centre off the lattice.
TEST_P(ExtractSurface, SphereIsClosedManifoldOrientedAndAccurate) {
  const Extractor e = GetParam();
  const float R = 1, h = 0.1f;
  const Vec3f c{0.13f, -0.07f, 0.21f};
  const SampleLattice lattice = lattice_for(e, h);
  const Vec3f margin{R + 2 * h, R + 2 * h, R + 2 * h};
  const SparseField field = make_field(lattice, c - margin, c + margin, [&](Vec3f x) { return length(x - c); });
  const ExtractResult r = extract_surface(field, R, e);
  const TopologyReport topo = analyze_topology(r.mesh);
  expect_watertight(topo, name(e));
  EXPECT_EQ(topo.components, 1u);
  EXPECT_EQ(topo.euler, 2);
  EXPECT_EQ(r.dropped_triangles, 0u);

  const double exact = 4.0 / 3.0 * std::numbers::pi * R * R * R;
  const double volume = signed_volume(r.mesh);
  const double error = (volume - exact) / exact;
  EXPECT_GT(volume, 0);
  EXPECT_LT(std::abs(error), 0.03) << name(e) << " volume " << volume << " vs " << exact;

  const float edge = longest_edge(lattice, e);
  float worst = 0;
  for (const Vec3f& v : r.mesh.vertices) worst = std::max(worst, std::abs(length(v - c) - R));
  EXPECT_LT(worst, edge) << name(e) << ": a vertex is " << worst << " off the sphere";
  std::printf("[ measured ] %s sphere R/h=10: %zu vertices, %zu triangles, volume error %+.3f %%, max |r-R| = %.4f h\n",
              name(e), r.mesh.vertices.size(), r.mesh.triangles.size(), 100 * error, worst / h);
}

// Five balls: three merge into one component (two pairs overlap by a thin neck), two stand apart.
TEST_P(ExtractSurface, UnionOfBallsHasOneSphereTopologyPerComponent) {
  const Extractor e = GetParam();
  const float h = 0.1f;
  const std::vector<Ball> balls = {{{0, 0, 0}, 0.8f},
                                   {{1.3f, 0, 0}, 0.6f},
                                   {{0.3f, 0.2f, 1.1f}, 0.5f},
                                   {{0, 2.2f, 0}, 0.5f},
                                   {{1.5f, 2.0f, 0.3f}, 0.45f}};
  const SampleLattice lattice = lattice_for(e, h);
  const Vec3f lo{-1.0f, -1.0f, -1.0f}, hi{2.2f, 2.9f, 1.8f};
  const SparseField field = make_field(lattice, lo, hi, [&](Vec3f x) { return union_phi(balls, x); });
  const ExtractResult r = extract_surface(field, 0, e);
  const TopologyReport topo = analyze_topology(r.mesh);
  expect_watertight(topo, name(e));
  EXPECT_EQ(topo.components, 3u) << name(e);
  EXPECT_EQ(topo.euler, 2 * static_cast<long long>(topo.components)) << name(e);

  // Reference volume by midpoint voxel counting at h/5.
  const double step = h / 5;
  long long inside = 0;
  for (double z = lo.z + step / 2; z < hi.z; z += step)
    for (double y = lo.y + step / 2; y < hi.y; y += step)
      for (double x = lo.x + step / 2; x < hi.x; x += step)
        inside += union_phi(balls, {float(x), float(y), float(z)}) < 0;
  const double reference = double(inside) * step * step * step;
  const double volume = signed_volume(r.mesh);
  EXPECT_LT(std::abs(volume - reference) / reference, 0.03) << name(e) << " volume " << volume << " vs " << reference;
  std::printf("[ measured ] %s union of 5 balls: %zu components, euler %lld, volume error %+.3f %%\n", name(e),
              topo.components, topo.euler, 100 * (volume - reference) / reference);
}

// The thread count must not change the mesh: same vertices, same triangles, same order. The
// parallel runs oversubscribe (8 threads, whatever the machine) so that blocks really finish out of
// order, and repeat.
TEST_P(ExtractSurface, IsDeterministicAcrossThreadCounts) {
  const Extractor e = GetParam();
  const std::vector<Ball> balls = {{{0, 0, 0}, 0.8f}, {{1.3f, 0, 0}, 0.6f}, {{0, 2.2f, 0}, 0.5f}};
  const SparseField field =
      make_field(lattice_for(e, 0.05f), {-1, -1, -1}, {2.2f, 2.9f, 1.1f}, [&](Vec3f x) { return union_phi(balls, x); });
  ExtractResult serial;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    serial = extract_surface(field, 0, e);
  }
  ASSERT_GT(serial.mesh.triangles.size(), 1000u);
  tbb::global_control many(tbb::global_control::max_allowed_parallelism, 8);
  tbb::task_arena arena(8);
  for (int run = 0; run < 3; ++run) {
    const ExtractResult parallel = arena.execute([&] { return extract_surface(field, 0, e); });
    EXPECT_TRUE(serial.mesh.vertices == parallel.mesh.vertices) << name(e) << " run " << run;
    EXPECT_TRUE(serial.mesh.triangles == parallel.mesh.triangles) << name(e) << " run " << run;
  }
}

// Samples exactly at the iso value (and edges whose crossing rounds onto a sample) must still give
// distinct vertices and no zero-area triangle: the clamp keeps every vertex off the samples.
TEST_P(ExtractSurface, SamplesAtTheIsoValueGiveNoDegenerateTriangles) {
  const Extractor e = GetParam();
  const float R = 1, h = 0.1f;
  const SampleLattice lattice = lattice_for(e, h);
  int snapped = 0;
  const SparseField field = make_field(lattice, {-1.3f, -1.3f, -1.3f}, {1.3f, 1.3f, 1.3f}, [&](Vec3f x) {
    const float phi = length(x);
    if (std::abs(phi - R) < 0.1f * h) {
      ++snapped;
      return R;
    }
    return phi;
  });
  ASSERT_GT(snapped, 20);
  const ExtractResult r = extract_surface(field, R, e);
  expect_watertight(analyze_topology(r.mesh), name(e));
  double min_area = 1e30;
  for (const Triangle& t : r.mesh.triangles) {
    const Vec3f a = r.mesh.vertices[t[0]], b = r.mesh.vertices[t[1]], c = r.mesh.vertices[t[2]];
    min_area = std::min(min_area, 0.5 * double(length(cross(b - a, c - a))));
  }
  EXPECT_GT(min_area, 0) << name(e);
  std::vector<Vec3f> sorted = r.mesh.vertices;
  std::sort(sorted.begin(), sorted.end(), [](Vec3f a, Vec3f b) {
    return a.x != b.x ? a.x < b.x : a.y != b.y ? a.y < b.y : a.z < b.z;
  });
  EXPECT_EQ(std::adjacent_find(sorted.begin(), sorted.end()), sorted.end()) << name(e) << ": two vertices coincide";
  std::printf("[ measured ] %s with %d samples at the iso value: min triangle area %.3g h^2\n", name(e), snapped,
              min_area / (h * h));
}

// Inside samples on the band's outer layer: the surface closes through the unallocated (ghost)
// neighbour blocks, on every side.
TEST_P(ExtractSurface, ClosesWhereInsideSamplesTouchTheBandEdge) {
  const Extractor e = GetParam();
  const SampleLattice lattice = lattice_for(e, 1);
  const float extent = float(lattice.block_cells()) * lattice.cell_size;
  const SparseField field = make_field(
      lattice, {0, 0, 0}, {extent / 2, extent / 2, extent * 1.5f}, [](Vec3f) { return -1.0f; }, 1.0f);
  ASSERT_EQ(field.block_count(), 2u);
  const ExtractResult r = extract_surface(field, 0, e);
  const TopologyReport topo = analyze_topology(r.mesh);
  expect_watertight(topo, name(e));
  EXPECT_EQ(topo.components, 1u);
  EXPECT_EQ(topo.euler, 2);
  // Each sample owns about one sample volume; the box around the 2 blocks' samples.
  const double volume = signed_volume(r.mesh);
  EXPECT_NEAR(volume, 2.0 * extent * extent * extent, 0.2 * 2.0 * extent * extent * extent) << name(e);
}

TEST_P(ExtractSurface, EmptyAndAllOutsideFieldsGiveEmptyMeshes) {
  const Extractor e = GetParam();
  const SampleLattice lattice = lattice_for(e, 1);
  const ExtractResult none = extract_surface(SparseField(lattice, {}, 1.0f), 0, e);
  EXPECT_TRUE(none.mesh.vertices.empty());
  EXPECT_TRUE(none.mesh.triangles.empty());
  const ExtractResult outside = extract_surface(make_field(
                                                    lattice, {0, 0, 0}, {9, 9, 9}, [](Vec3f) { return 0.5f; }, 1.0f),
                                                0, e);
  EXPECT_TRUE(outside.mesh.triangles.empty());
}

INSTANTIATE_TEST_SUITE_P(Extractors, ExtractSurface,
                         ::testing::Values(Extractor::tiles, Extractor::cubes, Extractor::tetrahedra),
                         [](const ::testing::TestParamInfo<Extractor>& param) {
                           return std::string(name(param.param));
                         });

// Marching Tiles guarantees valence ≥ 5 (every tiling edge has ≥ 5 tetrahedra); Marching Cubes on
// the same sphere does not — the reason the tile exists (docs/method.md "extract").
TEST(ExtractSurfaceValence, TilesHaveValenceAtLeastFiveAndCubesDoNot) {
  const float R = 1, h = 0.1f;
  const Vec3f c{0.13f, -0.07f, 0.21f}, margin{R + 2 * h, R + 2 * h, R + 2 * h};
  auto sphere = [&](Extractor e) {
    return extract_surface(
               make_field(lattice_for(e, h), c - margin, c + margin, [&](Vec3f x) { return length(x - c); }), R, e)
        .mesh;
  };
  const TriangleMesh tile_mesh = sphere(Extractor::tiles), cube_mesh = sphere(Extractor::cubes),
                     tet_mesh = sphere(Extractor::tetrahedra);
  const ValenceReport tiles = valence(tile_mesh), cubes = valence(cube_mesh), tets = valence(tet_mesh);
  const std::size_t tile_vertices = tile_mesh.vertices.size(), cube_vertices = cube_mesh.vertices.size(),
                    tet_vertices = tet_mesh.vertices.size();
  const double cube_share = double(cubes.below_5) / double(cube_vertices);
  const double tet_share = double(tets.below_5) / double(tet_vertices);
  EXPECT_GE(tiles.min, 5) << "tiles: min valence " << tiles.min << ", " << tiles.below_5 << " of " << tile_vertices
                          << " vertices below 5";
  EXPECT_EQ(tiles.below_5, 0u);
  EXPECT_GT(cube_share, 0.05) << "cubes: min valence " << cubes.min << ", share below 5 = " << cube_share;
  std::printf(
      "[ measured ] valence on the R/h=10 sphere: tiles min %d max %d mean %.2f below-5 %.2f %%; "
      "cubes min %d mean %.2f below-5 %.2f %%; tetrahedra min %d mean %.2f below-5 %.2f %%\n",
      tiles.min, tiles.max, tiles.mean, 100.0 * double(tiles.below_5) / double(tile_vertices), cubes.min, cubes.mean,
      100 * cube_share, tets.min, tets.mean, 100 * tet_share);
}

TEST(ExtractSurfaceErrors, WrongLatticeOrBackgroundIsRejected) {
  const SparseField a15(lattice_for(Extractor::tiles, 1), {}, 1.0f);
  const SparseField cubic(lattice_for(Extractor::cubes, 1), {}, 1.0f);
  EXPECT_THROW(extract_surface(cubic, 0, Extractor::tiles), InvalidParameter);
  EXPECT_THROW(extract_surface(a15, 0, Extractor::cubes), InvalidParameter);
  EXPECT_THROW(extract_surface(a15, 0, Extractor::tetrahedra), InvalidParameter);
  EXPECT_THROW(extract_surface(a15, 1.0f, Extractor::tiles), InvalidParameter);  // background not > iso
  EXPECT_THROW(extract_surface(a15, std::nanf(""), Extractor::tiles), InvalidParameter);
}

/// A ball of radius 1.5 cells in the middle of the A15 block with x block coordinate `bx`.
SparseField ball_in_block(int bx) {
  SampleLattice lattice = lattice_for(Extractor::tiles, 0.5f);  // a = 1: cells are world units
  const float n = float(lattice.block_cells());
  const Vec3f c{float(bx) * n + n / 2, n / 2, n / 2};
  SparseField field(lattice, {pack_coords(bx, 0, 0)}, 10.0f);
  for (int z = 0; z < 4; ++z)
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 4; ++x)
        for (int s = 0; s < 8; ++s)
          field.block_values(0)[field.local_index({x, y, z}, s)] =
              length(lattice.sample_position(field.block_origin(0) + Vec3i{x, y, z}, s) - c) - 1.5f;
  return field;
}

// Edge keys hold base cells with |coord| ≤ 2^18 − 1; a block (with its ghost neighbours, halo and
// edge ends: one block and 2 cells of margin) must fit. The last block that fits still meshes.
TEST(ExtractSurfaceErrors, BlocksOutsideTheEdgeKeyRangeThrowResourceError) {
  const int n = 4;
  const int last_ok = (kEdgeKeyMaxCoord - 1 - 2 * n) / n;  // largest B with (B + 2)·n + 1 ≤ max
  const int first_ok = -((kEdgeKeyMaxCoord - 2 - n) / n);  // smallest B with (B − 1)·n − 2 ≥ −max
  for (int bx : {last_ok, first_ok}) {
    const ExtractResult r = extract_surface(ball_in_block(bx), 0, Extractor::tiles);
    const TopologyReport topo = analyze_topology(r.mesh);
    EXPECT_TRUE(topo.closed() && topo.edge_manifold() && topo.oriented()) << "block " << bx;
    EXPECT_EQ(topo.euler, 2) << "block " << bx;
  }
  for (int bx : {last_ok + 1, first_ok - 1, 1 << 17, -(1 << 19)}) {
    try {
      extract_surface(ball_in_block(bx), 0, Extractor::tiles);
      ADD_FAILURE() << "block " << bx << " did not throw";
    } catch (const ResourceError& error) {
      EXPECT_NE(std::string(error.what()).find("edge keys"), std::string::npos) << error.what();
    }
  }
}

// The extraction written once over the backend tag (extract_backend.hpp: sorted weld over 64-bit
// edge keys; what the device runs) and the CPU's (block marching, numbered weld): on real frames,
// every extractor, run with Host{} it gives the CPU's mesh bit for bit — the same vertices in the
// same order and the same triangles.
TEST(ExtractSurfaceBackend, SharedVersionOnTheHostGivesTheCpuMeshBitForBit) {
  for (const char* frame : {"dam_break_frame_23_24389_particles.ply", "sphysics_dam_break_IPART_29814_particles.ply"}) {
    const ParticleSet ps = read_particles(test::data_file(std::string("ply/") + frame));
    const float d = float(estimate_spacing(ps)), r_outer = d;
    const HashGrid grid(ps.positions, r_outer);
    for (Extractor e : {Extractor::tiles, Extractor::cubes, Extractor::tetrahedra}) {
      SCOPED_TRACE(std::string(frame) + " " + name(e));
      const SampleLattice lattice = lattice_for(e, d / 2);
      const float band = r_outer + d;
      const SparseField field = distance_field(grid, lattice, band, band_blocks(grid, lattice, band));
      const ExtractResult cpu = extract_surface(field, r_outer, e);
      ASSERT_EQ(cpu.dropped_triangles, 0u);

      FieldBuffers<Host> buffers;
      buffers.lattice = field.lattice();
      buffers.blocks = uint32_t(field.block_count());
      buffers.background = field.background();
      buffers.keys.upload(field.block_keys().data(), field.block_count());
      buffers.values.upload(field.block_values(0).data(), field.block_count() * kBlockSamples);
      const MeshBuffers<Host> shared = extract_surface(Host{}, buffers, r_outer, e);

      ASSERT_GT(cpu.mesh.triangles.size(), 10000u);
      ASSERT_EQ(shared.vertex_count, cpu.mesh.vertices.size());
      ASSERT_EQ(shared.triangle_count, cpu.mesh.triangles.size());
      EXPECT_EQ(std::memcmp(shared.vertices.data(), cpu.mesh.vertices.data(), sizeof(Vec3f) * shared.vertex_count), 0);
      EXPECT_EQ(std::memcmp(shared.triangles.data(), cpu.mesh.triangles.data(), sizeof(Triangle) * shared.triangle_count),
                0);
    }
  }
}

}  // namespace
}  // namespace meniscus
