// meniscus — iso-surface extraction written once over the backend tag (Williams 2008 Marching
// Tiles; Lorensen & Cline 1987; Doi & Koide 1991; Edespong 2010 §4.3): inside masks per cell, the
// blocks to march (allocated + ghost blocks), per-cell triangle counts, an exclusive scan over
// (block, cell) — the CPU's triangle order — and the write pass with the kernels of
// marching_impl.hpp; then the weld: a stable sort of the corners' edge keys, one vertex per
// distinct key (increasing key order, as on the CPU), positions from the field.
//
// The device runs it (extract_device.cu); the CPU runs its own block marching and numbered weld
// (extract_surface.cpp), which make the same mesh with far less time and memory, and a unit test
// holds the two equal with this one run on Host{}.
//
// The march reads each block's masks padded by one cell from its 26 neighbours: on the device one
// thread block per march block gathers them into shared memory (march_blocks in
// extract_device.cu), on the CPU one task per block into a local array (march_blocks(Host, …)
// below); both call the same three steps of MarchBlocks.
#pragma once

#include <cstddef>
#include <cstdint>

#include "common/atomic.hpp"
#include "common/buffer.hpp"
#include "extract/edge_key.hpp"
#include "extract/extract.hpp"
#include "extract/marching_impl.hpp"
#include "field/field_buffers.hpp"
#include "grid/grid_buffers.hpp"
#include "meniscus/errors.hpp"
#include "mesh/mesh_buffers.hpp"

namespace meniscus {

namespace extract_backend {

/// Largest padded block: (8 + 2)³ masks (the cubic lattice's block; the A15 one is (4 + 2)³).
inline constexpr int kMaxPadded = 10 * 10 * 10;

/// Flags (sets *bad) a block whose cells, with one block and 2 cells of margin, leave the range of
/// the edge keys.
struct KeyRangeCheck {
  const uint64_t* keys;
  int n;
  int* bad;
  MENISCUS_HD void operator()(uint64_t b) const {
    const Vec3i c = unpack_coords(keys[b]);
    for (int a = 0; a < 3; ++a) {
      const int64_t first = int64_t(c[a]) * n, last = first + n - 1;
      if (first - n - 2 < -kEdgeKeyMaxCoord || last + n + 2 > kEdgeKeyMaxCoord) atomic_exchange(bad, 1);
    }
  }
};

/// Each cell's inside mask: bit s set where sample s is below iso.
struct CellMasks {
  const float* values;
  int spc;
  float iso;
  uint8_t* masks;
  MENISCUS_HD void operator()(uint64_t c) const {
    unsigned bits = 0;
    for (int s = 0; s < spc; ++s) bits |= unsigned(values[c * spc + s] < iso) << s;
    masks[c] = uint8_t(bits);
  }
};

/// Ghost blocks: the unallocated neighbours (on the stencil's side: all 26 for the tiles, the 7
/// below for cubes and tetrahedra) of blocks with an inside sample. Counts them per block
/// (`counts`), or writes each block's key and its ghosts' keys (`out`: the block's key at out[b],
/// its ghosts from out[blocks + offsets[b]]).
struct GhostBlocks {
  const uint64_t* keys;
  uint32_t blocks;
  const uint8_t* masks;
  int cells;
  bool full;
  const uint32_t* offsets;
  uint64_t* out;
  uint32_t* counts;
  MENISCUS_HD void operator()(uint64_t b) const {
    uint32_t n = 0;
    bool inside = false;
    for (int c = 0; c < cells && !inside; ++c) inside = masks[b * cells + c] != 0;
    if (inside) {
      const Vec3i c = unpack_coords(keys[b]);
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            if (dx == 0 && dy == 0 && dz == 0) continue;
            if (!full && (dx > 0 || dy > 0 || dz > 0)) continue;
            const uint64_t k = pack_coords(c.x + dx, c.y + dy, c.z + dz);
            if (find_sorted(keys, blocks, k) != kNotFound) continue;
            if (out != nullptr) out[blocks + offsets[b] + n] = k;
            ++n;
          }
    }
    if (out != nullptr) out[b] = keys[b];
    if (counts != nullptr) counts[b] = n;
  }
};

/// The march over one block, in three steps that a backend runs for every index of each step with
/// the block's scratch (`neighbour`: 27 words, `padded`: (n + 2)³ masks) between them: the
/// neighbours' indices among the field's blocks, the padded masks, then each cell's triangle count
/// (counts) or triangles (corners at 3·offsets[slot], where slot = block · n³ + cell).
struct MarchBlocks {
  const uint64_t* march_keys;
  const uint64_t* field_keys;
  uint32_t field_blocks;
  const uint8_t* cell_masks;
  int n;
  Extractor extractor;
  const MarchingTables* tables;
  const TileVertexLookup* tile_lookup;
  uint64_t* counts;
  const uint64_t* offsets;
  uint64_t* corners;

  MENISCUS_HD int padded_size() const { return (n + 2) * (n + 2) * (n + 2); }

  MENISCUS_HD uint32_t neighbour(uint64_t b, unsigned k) const {
    const Vec3i bc = unpack_coords(march_keys[b]);
    const int dx = int(k % 3) - 1, dy = int(k / 3 % 3) - 1, dz = int(k / 9) - 1;
    return find_sorted(field_keys, field_blocks, pack_coords(bc.x + dx, bc.y + dy, bc.z + dz));
  }

  MENISCUS_HD uint8_t padded_mask(int i, const uint32_t* neighbours) const {
    const int p = n + 2, cells = n * n * n;
    const int x = i % p - 1, y = i / p % p - 1, z = i / (p * p) - 1;
    const int dx = x < 0 ? -1 : (x >= n ? 1 : 0), dy = y < 0 ? -1 : (y >= n ? 1 : 0), dz = z < 0 ? -1 : (z >= n ? 1 : 0);
    const uint32_t nb = neighbours[(dz + 1) * 9 + (dy + 1) * 3 + (dx + 1)];
    const int lx = x - dx * n, ly = y - dy * n, lz = z - dz * n;
    return nb == kNotFound ? uint8_t(0) : cell_masks[uint64_t(nb) * cells + uint64_t((lz * n + ly) * n + lx)];
  }

  MENISCUS_HD void cell(uint64_t b, int c, const uint8_t* padded) const {
    const int p = n + 2, cells = n * n * n;
    const Vec3i bc = unpack_coords(march_keys[b]);
    const int x = c % n, y = c / n % n, z = c / (n * n);
    const uint8_t* m = padded + ((z + 1) * p + (y + 1)) * p + (x + 1);
    const uint64_t slot = b * uint64_t(cells) + uint64_t(c);
    uint64_t* out = corners != nullptr ? corners + 3 * offsets[slot] : nullptr;
    if (out == nullptr && counts == nullptr) return;
    uint32_t count = 0;
    const uint64_t cell_key = edge_key(Vec3i{bc.x * n + x, bc.y * n + y, bc.z * n + z}, 0);
    if (extractor == Extractor::tiles) {
      if (tile_cell_may_cross(m, p, p * p))
        count = march_tile_cell(m, *tile_lookup, tables->tet_cases, tables->a15_edges, cell_key, out);
    } else if (extractor == Extractor::cubes) {
      count = march_cube_cell(m, p, p * p, *tables, cell_key, out);
    } else {
      count = march_kuhn_cell(m, p, p * p, *tables, cell_key, out);
    }
    if (counts != nullptr) counts[slot] = count;
  }
};

/// The three steps of MarchBlocks for one block, in turn, with the scratch on the stack: the CPU
/// backend's march (one task per block).
struct MarchBlockSerial {
  MarchBlocks m;
  void operator()(uint64_t b) const {
    uint32_t neighbours[27];
    uint8_t padded[kMaxPadded];
    for (unsigned k = 0; k < 27; ++k) neighbours[k] = m.neighbour(b, k);
    for (int i = 0, p = m.padded_size(); i < p; ++i) padded[i] = m.padded_mask(i, neighbours);
    for (int c = 0, cells = m.n * m.n * m.n; c < cells; ++c) m.cell(b, c, padded);
  }
};

struct Iota {
  uint32_t* v;
  MENISCUS_HD void operator()(uint64_t i) const { v[i] = uint32_t(i); }
};

/// heads[i] = 1 where the sorted keys start a run (a new vertex).
struct RunHeads {
  const uint64_t* keys;
  uint32_t* heads;
  MENISCUS_HD void operator()(uint64_t i) const { heads[i] = (i == 0 || keys[i] != keys[i - 1]) ? 1u : 0u; }
};

/// Each sorted corner's vertex into its triangle slot, and each run's key as its vertex's key.
struct WeldScatter {
  const uint64_t* keys;
  const uint32_t* corner;
  const uint32_t* heads;
  const uint32_t* vertex_of;  ///< exclusive scan of heads: the run of i is vertex (scan + head − 1)
  uint32_t* triangles;
  uint64_t* vertex_keys;
  MENISCUS_HD void operator()(uint64_t i) const {
    const uint32_t v = vertex_of[i] + heads[i] - 1;
    if (heads[i]) vertex_keys[v] = keys[i];
    triangles[corner[i]] = v;
  }
};

/// Each vertex at the clamped crossing on its edge (edge_vertex), as the CPU's weld places it.
struct VertexPositions {
  const uint64_t* vertex_keys;
  FieldView field;
  const MarchingTables* tables;
  bool a15;
  float cell_size, iso;
  SampleOffsets offsets;
  Vec3f* vertices;
  MENISCUS_HD void operator()(uint64_t v) const {
    Vec3i c0, c1;
    int s0 = 0, s1 = 0;
    edge_key_samples(vertex_keys[v], a15 ? tables->a15_edges.types : tables->kuhn_edges.types, &c0, &s0, &c1, &s1);
    const Vec3f o0{offsets.o[s0][0], offsets.o[s0][1], offsets.o[s0][2]};
    const Vec3f o1{offsets.o[s1][0], offsets.o[s1][1], offsets.o[s1][2]};
    vertices[v] = edge_vertex(lattice_point(c0, o0, cell_size), lattice_point(c1, o1, cell_size), field.value(c0, s0),
                              field.value(c1, s1), iso, kEdgeClamp);
  }
};

/// Counts the triangles with a repeated vertex.
struct RepeatedCorners {
  const uint32_t* tris;
  unsigned long long* count;
  MENISCUS_HD void operator()(uint64_t t) const {
    const uint32_t a = tris[3 * t], b = tris[3 * t + 1], c = tris[3 * t + 2];
    if (a == b || b == c || a == c) atomic_add(count, 1ull);
  }
};

}  // namespace extract_backend

/// The CPU backend's march: one task per block, its steps in turn (MarchBlockSerial).
inline void march_blocks(Host, std::size_t blocks, const extract_backend::MarchBlocks& m) {
  for_each_index(blocks, 1, extract_backend::MarchBlockSerial{m});
}
/// The marching tables where the CPU backend's kernels read them.
inline const MarchingTables* marching_tables(Host) { return &cpu_marching_tables(); }
inline const TileVertexLookup* tile_vertex_lookup(Host) {
  static constexpr TileVertexLookup lookup = make_tile_vertex_lookup(6, 36);
  return &lookup;
}

/// extract_surface() over the field's arrays on backend B: the same vertices (edge-key order) and
/// triangles (block, cell, tetrahedron order) as the CPU's extraction. Throws InvalidParameter
/// (lattice/extractor mismatch, background ≤ iso) and ResourceError (a block outside the edge
/// keys' range, 2^32 or more corners, a triangle with a repeated vertex — never made by the
/// marching stages; the CPU's weld drops such triangles, this one leaves the job to the caller).
template <class B>
MeshBuffers<B> extract_surface(B b, const FieldBuffers<B>& field, float iso, Extractor extractor) {
  using namespace extract_backend;
  const bool a15 = field.lattice.kind == SampleLattice::Kind::a15;
  if (a15 != (extractor == Extractor::tiles))
    throw InvalidParameter("extract_surface: the field's lattice does not fit the extractor");
  if (!(field.background > iso)) throw InvalidParameter("extract_surface: the background must be > the iso value");
  const MarchingTables* tables = marching_tables(b);
  const TileVertexLookup* lookup = tile_vertex_lookup(b);
  MeshBuffers<B> mesh;
  const uint32_t blocks = field.blocks;
  if (blocks == 0) return mesh;
  const int n = field.lattice.block_cells(), spc = field.lattice.samples_per_cell(), cells = n * n * n;
  {
    BufferOf<B, int> bad(1);
    bad.zero();
    for_each_index(b, blocks, KeyRangeCheck{field.keys.data(), n, bad.data()});
    if (bad.get(0) != 0)
      throw ResourceError("extract_surface: a field block lies outside the range of the 64-bit edge keys; use a "
                          "larger voxel size or move the particles closer to the origin");
  }
  BufferOf<B, uint8_t> masks(std::size_t(blocks) * cells);
  for_each_index(b, std::size_t(blocks) * cells, CellMasks{field.values.data(), spc, iso, masks.data()});

  // Blocks to march: the allocated ones plus the ghosts, sorted, unique.
  const bool full = extractor == Extractor::tiles;
  BufferOf<B, uint32_t> ghost_counts(blocks), ghost_offsets(std::size_t(blocks) + 1);
  for_each_index(b, blocks,
                 GhostBlocks{field.keys.data(), blocks, masks.data(), cells, full, nullptr, nullptr, ghost_counts.data()});
  exclusive_sum(b, ghost_counts.data(), ghost_offsets.data(), blocks);
  const uint32_t ghosts = ghost_offsets.get(blocks);
  BufferOf<B, uint64_t> march_keys(std::size_t(blocks) + ghosts);
  for_each_index(b, blocks,
                 GhostBlocks{field.keys.data(), blocks, masks.data(), cells, full, ghost_offsets.data(), march_keys.data(),
                             nullptr});
  ghost_counts = {};
  ghost_offsets = {};
  sort_keys(b, march_keys.data(), std::size_t(blocks) + ghosts);
  const std::size_t march_count = unique_sorted(b, march_keys.data(), std::size_t(blocks) + ghosts);

  // Count, scan, write.
  const std::size_t slots = march_count * std::size_t(cells);
  BufferOf<B, uint64_t> counts(slots), offsets(slots + 1);
  MarchBlocks march{march_keys.data(), field.keys.data(), blocks, masks.data(), n, extractor, tables, lookup,
                    counts.data(),     nullptr,           nullptr};
  march_blocks(b, march_count, march);
  exclusive_sum(b, counts.data(), offsets.data(), slots);
  const uint64_t triangles = offsets.get(slots);
  const uint64_t corners_n = 3 * triangles;
  if (corners_n >= uint64_t(kNotFound))
    throw ResourceError("extract_surface: the mesh would need 2^32 or more triangle corners");
  BufferOf<B, uint64_t> corners(corners_n);
  march.counts = nullptr;
  march.offsets = offsets.data();
  march.corners = corners.data();
  march_blocks(b, march_count, march);
  counts = {};
  offsets = {};
  masks = {};
  march_keys = {};

  // Weld: stable sort of (edge key, corner index); run heads become vertices in key order.
  BufferOf<B, uint32_t> corner_index(corners_n);
  for_each_index(b, corners_n, Iota{corner_index.data()});
  sort_pairs(b, corners.data(), corner_index.data(), corners_n, 0, 63);
  BufferOf<B, uint32_t> heads(corners_n), vertex_of(corners_n + 1);
  for_each_index(b, corners_n, RunHeads{corners.data(), heads.data()});
  exclusive_sum(b, heads.data(), vertex_of.data(), corners_n);
  const uint32_t nv = corners_n == 0 ? 0 : vertex_of.get(corners_n);
  BufferOf<B, uint64_t> vertex_keys(nv);
  mesh.triangles.resize(corners_n);
  for_each_index(b, corners_n,
                 WeldScatter{corners.data(), corner_index.data(), heads.data(), vertex_of.data(), mesh.triangles.data(),
                             vertex_keys.data()});
  corners = {};
  corner_index = {};
  heads = {};
  vertex_of = {};
  mesh.vertices.resize(nv);
  for_each_index(b, nv,
                 VertexPositions{vertex_keys.data(), field.view(), tables, a15,
                                 field.lattice.cell_size, iso, SampleOffsets(field.lattice), mesh.vertices.data()});
  mesh.vertex_count = nv;
  mesh.triangle_count = triangles;
  BufferOf<B, unsigned long long> repeated(1);
  repeated.zero();
  for_each_index(b, triangles, RepeatedCorners{mesh.triangles.data(), repeated.data()});
  if (repeated.get(0) != 0) throw ResourceError("extract_surface: the weld produced triangles with a repeated vertex");
  return mesh;
}

}  // namespace meniscus
