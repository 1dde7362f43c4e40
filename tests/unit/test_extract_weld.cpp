// meniscus tests — the edge weld (Williams 2008; Edespong 2010 §4.3) and its parallel LSD radix sort.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <random>
#include <set>
#include <vector>

#include "extract/block_marching.hpp"
#include "extract/edge_key.hpp"
#include "extract/extract.hpp"
#include "extract/marching.hpp"
#include "extract/marching_impl.hpp"
#include "common/radix_sort.hpp"
#include "extract/weld.hpp"
#include "meniscus/quality.hpp"

namespace meniscus {
namespace {

TEST(ExtractRadixSort, MatchesStdSortForAnyBitWidth) {
  std::mt19937_64 rng(5);
  for (int bits : {1, 7, 11, 12, 22, 33, 63, 64}) {
    for (std::size_t n : {std::size_t(0), std::size_t(1), std::size_t(1000), std::size_t(300000)}) {
      std::vector<uint64_t> keys(n);
      const uint64_t mask = bits == 64 ? ~uint64_t(0) : (uint64_t(1) << bits) - 1;
      for (uint64_t& k : keys) k = rng() & mask;
      std::vector<uint64_t> expected = keys;
      std::sort(expected.begin(), expected.end());
      radix_sort(keys, 0, bits);
      EXPECT_EQ(keys, expected) << bits << " bits, " << n << " keys";
    }
  }
}

TEST(ExtractRadixSort, SortsOnlyTheKeyBitsAndKeepsThePayloadStable) {
  // Key in bits [20, 40), payload (the input position) in bits [0, 20), junk above bit 40 that
  // must not take part.
  std::mt19937_64 rng(9);
  const std::size_t n = 200000;
  std::vector<uint64_t> packed(n);
  for (std::size_t i = 0; i < n; ++i) packed[i] = ((rng() % 5000) << 20) | i | ((rng() % 7) << 40);
  std::vector<uint64_t> expected = packed;
  auto key = [](uint64_t p) { return (p >> 20) & ((uint64_t(1) << 20) - 1); };
  std::stable_sort(expected.begin(), expected.end(), [&](uint64_t a, uint64_t b) { return key(a) < key(b); });
  radix_sort(packed, 20, 40);
  EXPECT_EQ(packed, expected);
}

TEST(ExtractRadixSort, SortsItemsByTheirKeyStably) {
  // Items sorted by a key computed from them (as the triangles by their smallest corner), with
  // many ties: the order must be std::stable_sort's, over several chunks of the sort.
  struct Item {
    uint32_t a, b, position;
  };
  std::mt19937_64 rng(11);
  for (std::size_t n : {std::size_t(2), std::size_t(5000), std::size_t(400000)}) {
    std::vector<Item> items(n);
    for (std::size_t i = 0; i < n; ++i) items[i] = {uint32_t(rng() % 70000), uint32_t(rng() % 70000), uint32_t(i)};
    auto key = [](const Item& t) { return std::min(t.a, t.b); };
    std::vector<Item> expected = items;
    std::stable_sort(expected.begin(), expected.end(), [&](const Item& x, const Item& y) { return key(x) < key(y); });
    radix_sort_by(items, key, 0, 17);
    ASSERT_EQ(items.size(), n);
    for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(items[i].position, expected[i].position) << n << " items, at " << i;
  }
}

TEST(ExtractWeld, CornersOnTheSameEdgeShareOneVertexInKeyOrder) {
  SampleLattice lattice;  // cubic, h = 1
  std::vector<uint64_t> blocks = {pack_coords(0, 0, 0)};
  SparseField field(lattice, blocks, 1.0f);
  // φ = -1 at sample (1,1,1), 1 elsewhere: the crossing on every edge from it is at t = 0.5.
  field.block_values(0)[field.local_index({1, 1, 1}, 0)] = -1;
  const uint64_t x = edge_key({1, 1, 1}, 0), y = edge_key({1, 1, 1}, 1), z = edge_key({1, 1, 1}, 3),
                 mx = edge_key({0, 1, 1}, 0);
  const std::vector<uint64_t> corners = {z, y, x, x, mx, y, y, y, z};  // the last one repeats a vertex
  const ExtractResult r = weld_edge_keys(corners, field, 0);
  ASSERT_EQ(r.mesh.triangles.size(), 2u);
  EXPECT_EQ(r.dropped_triangles, 1u);
  // Vertices in key order: mx < x < y < z.
  ASSERT_EQ(r.mesh.vertices.size(), 4u);
  EXPECT_EQ(r.mesh.vertices[0], (Vec3f{0.5f, 1, 1}));
  EXPECT_EQ(r.mesh.vertices[1], (Vec3f{1.5f, 1, 1}));
  EXPECT_EQ(r.mesh.vertices[2], (Vec3f{1, 1.5f, 1}));
  EXPECT_EQ(r.mesh.vertices[3], (Vec3f{1, 1, 1.5f}));
  EXPECT_EQ(r.mesh.triangles[0], (Triangle{3, 2, 1}));
  EXPECT_EQ(r.mesh.triangles[1], (Triangle{1, 0, 2}));
}

/// Two small balls in opposite corners of the key range: the dense keys then need more bits than
/// fit beside a corner index, so the weld takes its search path. The result must be the same
/// mesh as welding each ball alone (vertices are in key order, so ball A's come first).
TEST(ExtractWeld, FarApartComponentsWeldLikeSeparateOnes) {
  SampleLattice lattice;
  lattice.kind = SampleLattice::Kind::cubic;
  const int far = (1 << 17) / 8;  // block coordinate: cells around ±2^17
  auto make = [&](std::vector<Vec3i> centres_in_blocks) {
    std::vector<uint64_t> keys;
    for (Vec3i b : centres_in_blocks) keys.push_back(pack_coords(b.x, b.y, b.z));
    std::sort(keys.begin(), keys.end());
    SparseField field(lattice, keys, 10.0f);
    for (std::size_t b = 0; b < field.block_count(); ++b) {
      for (int z = 0; z < 8; ++z)
        for (int y = 0; y < 8; ++y)
          for (int x = 0; x < 8; ++x) {
            const float dx = float(x) - 3.6f, dy = float(y) - 3.3f, dz = float(z) - 3.9f;
            field.block_values(b)[field.local_index({x, y, z}, 0)] = std::sqrt(dx * dx + dy * dy + dz * dz) - 2.5f;
          }
    }
    return field;
  };
  const Vec3i a{-far, -far, -far}, b{far, far, far};
  const ExtractResult both = extract_surface(make({a, b}), 0, Extractor::cubes);
  const ExtractResult only_a = extract_surface(make({a}), 0, Extractor::cubes);
  const ExtractResult only_b = extract_surface(make({b}), 0, Extractor::cubes);
  const TopologyReport topo = analyze_topology(both.mesh);
  EXPECT_TRUE(topo.watertight());
  EXPECT_EQ(topo.components, 2u);
  ASSERT_EQ(both.mesh.vertices.size(), only_a.mesh.vertices.size() + only_b.mesh.vertices.size());
  ASSERT_EQ(both.mesh.triangles.size(), only_a.mesh.triangles.size() + only_b.mesh.triangles.size());
  const uint32_t shift = uint32_t(only_a.mesh.vertices.size());
  for (std::size_t v = 0; v < only_a.mesh.vertices.size(); ++v)
    EXPECT_EQ(both.mesh.vertices[v], only_a.mesh.vertices[v]);
  for (std::size_t v = 0; v < only_b.mesh.vertices.size(); ++v)
    EXPECT_EQ(both.mesh.vertices[shift + v], only_b.mesh.vertices[v]);
  for (std::size_t t = 0; t < only_a.mesh.triangles.size(); ++t)
    EXPECT_EQ(both.mesh.triangles[t], only_a.mesh.triangles[t]);
  for (std::size_t t = 0; t < only_b.mesh.triangles.size(); ++t) {
    const Triangle& tb = only_b.mesh.triangles[t];
    EXPECT_EQ(both.mesh.triangles[only_a.mesh.triangles.size() + t],
              (Triangle{tb[0] + shift, tb[1] + shift, tb[2] + shift}));
  }
}

/// The marching stages' block-structured output welds (block-local merge, then vertices numbered
/// from the blocks' crossing edges, no sort) into exactly the mesh of the plain weld that sorts
/// every corner: a noisy field over 3 × 3 × 3 blocks with inside samples on the allocated
/// boundary (so ghost blocks are marched too), for all three extractors.
TEST(ExtractWeld, BlockWeldKeepsEveryCornerAndGivesTheSameMeshAsTheGlobalSort) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> noise(-0.4f, 0.4f);
  for (Extractor e : {Extractor::tiles, Extractor::cubes, Extractor::tetrahedra}) {
    SampleLattice lattice;
    lattice.kind = e == Extractor::tiles ? SampleLattice::Kind::a15 : SampleLattice::Kind::cubic;
    lattice.cell_size = 0.1f;
    std::vector<uint64_t> keys;
    for (int z = -1; z <= 1; ++z)
      for (int y = -1; y <= 1; ++y)
        for (int x = -1; x <= 1; ++x) keys.push_back(pack_coords(x, y, z));
    std::sort(keys.begin(), keys.end());
    SparseField field(lattice, keys, 1.0f);
    const int n = lattice.block_cells(), spc = lattice.samples_per_cell();
    for (std::size_t b = 0; b < field.block_count(); ++b) {
      const Vec3i origin = field.block_origin(b);
      for (int z = 0; z < n; ++z)
        for (int y = 0; y < n; ++y)
          for (int x = 0; x < n; ++x)
            for (int s = 0; s < spc; ++s) {
              const Vec3f p = lattice.sample_position(origin + Vec3i{x, y, z}, s);
              field.block_values(b)[field.local_index({x, y, z}, s)] =
                  std::sin(7 * p.x) * std::sin(5.3f * p.y) * std::sin(6.1f * p.z) + noise(rng);
            }
    }
    MarchedCorners marched = e == Extractor::tiles   ? march_tiles(field, 0)
                             : e == Extractor::cubes ? march_cubes(field, 0)
                                                     : march_tetrahedra(field, 0);
    ASSERT_GT(marched.origins.size(), field.block_count()) << "ghost blocks should be marched";
    ASSERT_GT(marched.corner_count(), 3000u);
    // Each block's own weld: distinct edges, every one used, and each corner's key that of the
    // cell kernels run here on the same padded masks (cell order z, y, x, then the kernel's).
    const std::vector<uint8_t> cell_masks = cell_inside_masks(field, 0);
    const std::vector<Vec3i> marched_blocks = blocks_to_march(field, cell_masks, e == Extractor::tiles);
    ASSERT_EQ(marched_blocks.size(), marched.origins.size());
    const std::vector<uint64_t> flat = marched.flatten();
    std::size_t checked = 0;
    for (std::size_t b = 0; b < marched_blocks.size(); ++b) {
      PaddedMasks masks;
      std::vector<uint64_t> expected;
      if (gather_inside_masks(field, cell_masks, marched_blocks[b], masks)) {
        const int sy = masks.padded, sz = masks.padded * masks.padded;
        const TileVertexLookup lookup = make_tile_vertex_lookup(sy, sz);
        for (int z = 0; z < n; ++z)
          for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x) {
              uint64_t out[3 * 2 * kA15TetCount];
              const uint64_t cell_key = edge_key(masks.origin + Vec3i{x, y, z}, 0);
              const uint8_t* m = masks.at(x, y, z);
              const uint32_t t = e == Extractor::tiles   ? march_tile_cell(m, lookup, cell_key, out)
                                 : e == Extractor::cubes ? march_cube_cell(m, sy, sz, cell_key, out)
                                                         : march_kuhn_cell(m, sy, sz, cell_key, out);
              expected.insert(expected.end(), out, out + 3 * t);
            }
      }
      const std::size_t first = 3 * marched.triangle_offsets[b], corners = 3 * marched.triangle_offsets[b + 1] - first;
      ASSERT_EQ(corners, expected.size()) << to_string(e) << " block " << b;
      EXPECT_TRUE(std::equal(expected.begin(), expected.end(), flat.begin() + std::ptrdiff_t(first)))
          << to_string(e) << " block " << b;
      if (corners == 0) continue;
      const std::span<const uint16_t> edges = marched.edges(b);
      std::set<uint64_t> edge_keys;
      for (const uint16_t code : edges) edge_keys.insert(marched.edge_key(b, code));
      EXPECT_EQ(edge_keys.size(), edges.size()) << "repeated edge, block " << b;
      std::vector<bool> used(edges.size(), false);
      for (const uint16_t c : marched.corners(b)) {
        ASSERT_LT(c, edges.size());
        used[c] = true;
      }
      EXPECT_TRUE(std::all_of(used.begin(), used.end(), [](bool u) { return u; })) << "unused edge, block " << b;
      ++checked;
    }
    EXPECT_GT(checked, field.block_count() / 2) << to_string(e);
    const ExtractResult plain = weld_edge_keys(marched.flatten(), field, 0);
    const ExtractResult blocks = weld_edge_keys(std::move(marched), field, 0);
    EXPECT_EQ(blocks.mesh.vertices, plain.mesh.vertices) << to_string(e);
    EXPECT_EQ(blocks.mesh.triangles, plain.mesh.triangles) << to_string(e);
    EXPECT_TRUE(analyze_topology(blocks.mesh).watertight()) << to_string(e);
  }
}

/// The vertex numbering without a sort (weld_numbered) on the fields hardest for it: independent
/// random signs at every sample, so most edges cross and every block boundary, ghost block and
/// slab boundary carries vertices; and allocated blocks scattered with gaps along each axis, so
/// blocks of one z-slab and one row have holes between them. Vertices are exactly the crossing
/// edges (as many as the crossing masks' bits, each corner's), in key order, at the plain weld's
/// positions, for all three extractors.
TEST(ExtractWeld, NumberedVerticesEqualTheSortedWeldOnRandomSignsAndScatteredBlocks) {
  for (Extractor e : {Extractor::tiles, Extractor::cubes, Extractor::tetrahedra}) {
    for (const int seed : {1, 2, 3}) {
      std::mt19937 rng{uint32_t(seed)};
      std::uniform_real_distribution<float> value(-1.0f, 1.0f);
      SampleLattice lattice;
      lattice.kind = e == Extractor::tiles ? SampleLattice::Kind::a15 : SampleLattice::Kind::cubic;
      lattice.cell_size = 0.1f;
      std::vector<uint64_t> keys;
      std::bernoulli_distribution allocated(seed == 1 ? 1.0 : 0.5);
      for (int z = -2; z <= 1; ++z)
        for (int y = -1; y <= 2; ++y)
          for (int x = -2; x <= 2; ++x)
            if (allocated(rng)) keys.push_back(pack_coords(x, y, z));
      std::sort(keys.begin(), keys.end());
      SparseField field(lattice, keys, 1.0f);
      // Mostly outside in the scattered fields (a third inside), half and half in the dense one.
      const float bias = seed == 1 ? 0.0f : 0.33f;
      for (std::size_t b = 0; b < field.block_count(); ++b)
        for (float& v : field.block_values(b)) v = value(rng) + bias;
      MarchedCorners marched = e == Extractor::tiles   ? march_tiles(field, 0)
                               : e == Extractor::cubes ? march_cubes(field, 0)
                                                       : march_tetrahedra(field, 0);
      ASSERT_GT(marched.corner_count(), 3000u) << to_string(e);
      std::size_t crossing = 0;
      const std::size_t cells = std::size_t(marched.block_cells) * marched.block_cells * marched.block_cells;
      for (std::size_t b = 0; b < marched.origins.size(); ++b)
        if (marched.block_crossings[b] != nullptr)
          for (std::size_t c = 0; c < cells; ++c) {
            const uint64_t bits = marched.crossings(b, c);
            EXPECT_EQ(bits & ~marched.used_types, 0u) << "a crossing of a type the extractor does not use";
            crossing += std::size_t(std::popcount(bits));
          }
      const ExtractResult plain = weld_edge_keys(marched.flatten(), field, 0);
      const ExtractResult numbered = weld_edge_keys(std::move(marched), field, 0);
      EXPECT_EQ(numbered.mesh.vertices.size(), crossing) << to_string(e) << " seed " << seed;
      EXPECT_EQ(numbered.mesh.vertices, plain.mesh.vertices) << to_string(e) << " seed " << seed;
      EXPECT_EQ(numbered.mesh.triangles, plain.mesh.triangles) << to_string(e) << " seed " << seed;
      EXPECT_EQ(numbered.dropped_triangles, 0u);
      EXPECT_TRUE(analyze_topology(numbered.mesh).watertight()) << to_string(e) << " seed " << seed;
    }
  }
}

}  // namespace
}  // namespace meniscus
