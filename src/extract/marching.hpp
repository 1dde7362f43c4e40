// meniscus — the three marching stages (Williams 2008 Marching Tiles; Lorensen & Cline 1987
// Marching Cubes; Doi & Koide 1991 Marching Tetrahedra). Each returns the triangles of the level
// set {φ = iso} as edge keys (edge_key.hpp), 3 per triangle, counter-clockwise seen from larger φ,
// in a deterministic order (block, cell, tetrahedron); weld.hpp turns them into a mesh.
// Preconditions (checked by extract_surface): the lattice kind fits the extractor and the
// background is > iso. Throw ResourceError when a block lies outside the edge-key range.
#pragma once

#include <cstdint>
#include <cstring>
#include <memory>
#include <span>
#include <vector>

#include "extract/edge_key.hpp"
#include "extract/tile_table.hpp"
#include "field/sparse_field.hpp"

namespace meniscus {

/// A block's edges as 16-bit codes: the edge's base cell relative to the block's first cell − 2
/// (span = block_cells + 4 cells on each axis: a block's edges have base cells within 2 cells of
/// its own) and its type, ((z · span + y) · span + x) << type_bits | type. The A15 block (4 cells,
/// 54 edge types) needs 9 + 6 bits, the cubic one (8 cells, 7 types) 11 + 3.
struct BlockEdgeCodes {
  int span = 0;
  int type_bits = 0;
  static constexpr BlockEdgeCodes of(int block_cells, bool a15) { return {block_cells + 4, a15 ? 6 : 3}; }
  static BlockEdgeCodes of(const SampleLattice& lattice) {
    return of(lattice.block_cells(), lattice.kind == SampleLattice::Kind::a15);
  }
  /// Number of distinct codes (every code is below it); ≤ 2^16 for both lattices.
  constexpr std::size_t count() const { return (std::size_t(span) * std::size_t(span) * std::size_t(span)) << type_bits; }
  constexpr uint16_t encode(Vec3i local, int type) const {
    return uint16_t((((local.z * span + local.y) * span + local.x) << type_bits) | type);
  }
  /// What the code of an edge based at cell + (dx, dy, dz), of type `type`, adds to cell's code
  /// encode(cell, 0), mod 2^16 (codes are linear in the base cell; the offset may be negative).
  constexpr uint16_t delta(int dx, int dy, int dz, int type) const {
    return uint16_t(((dz * span + dy) * span + dx) * (1 << type_bits) + type);
  }
  /// The edge key of `code` in the block whose first cell is `origin`.
  uint64_t key(Vec3i origin, uint16_t code) const {
    const int cell = code >> type_bits;
    const Vec3i local{cell % span, cell / span % span, cell / span / span};
    return edge_key(origin - Vec3i{2, 2, 2} + local, code & ((1 << type_bits) - 1));
  }
};

/// The marching stages' output, already welded within each block: block b has
/// triangle_offsets[b + 1] − triangle_offsets[b] triangles (block order is the triangle order of
/// the mesh) and edge_offsets[b + 1] − edge_offsets[b] distinct edges. block_edges[b] holds those
/// edges' codes (BlockEdgeCodes) in the order the block's corners first use them, block_corners[b]
/// the index of each corner's edge among them, 3 per triangle (corner c's key is
/// edge_key(b, block_edges[b][block_corners[b][c]])): both in pages each thread filled as it
/// marched (one pass, no count pass, no copy; the corners' keys themselves never leave the
/// thread's cache). Two bytes an edge and two a corner instead of 8 and 4: the pages are alive at
/// the extraction's peak, beside the weld's copies of them, so their size counts in the run's.
struct MarchedCorners {
  std::vector<std::unique_ptr<uint16_t[]>> edge_pages;
  std::vector<std::unique_ptr<uint16_t[]>> corner_pages;
  std::vector<const uint16_t*> block_edges;    ///< #blocks (null for a block without triangles)
  std::vector<const uint16_t*> block_corners;  ///< #blocks (null for a block without triangles)
  std::vector<uint64_t> triangle_offsets;      ///< #blocks + 1
  std::vector<uint64_t> edge_offsets;          ///< #blocks + 1
  std::vector<Vec3i> origins;                  ///< first cell of each marched block
  int block_cells = 0;
  BlockEdgeCodes codes;
  /// The lattice's edge types (kA15EdgeTable.types or kKuhnEdgeTable.types) and which of them the
  /// extractor's cells use (Marching Cubes: the 3 axes of the 7 cubic ones).
  const LatticeEdge* edge_types = nullptr;
  uint64_t used_types = 0;
  /// The crossing edges based in each block's own cells, the weld's vertices: block_cells³ masks
  /// in cell order (z, y, x), bit t of cell c's set when the edge of type t based at c has one end
  /// inside and one outside. 8-byte masks on the A15 lattice (54 types), 1-byte on the cubic one
  /// (7), so 512 bytes a block either way; null for a block none of whose own edges cross. A
  /// crossing edge is a corner of every tetrahedron or cube around it, so these are exactly the
  /// distinct edges of all the corners, counted without sorting them.
  std::vector<std::unique_ptr<uint8_t[]>> crossing_pages;
  std::vector<const uint8_t*> block_crossings;  ///< #blocks
  int crossing_bytes = 8;                       ///< bytes per cell mask: 8 (A15) or 1 (cubic)

  /// Cell `cell`'s crossing mask in block b (whose block_crossings[b] is not null).
  uint64_t crossings(std::size_t b, std::size_t cell) const {
    const uint8_t* m = block_crossings[b];
    if (crossing_bytes == 1) return m[cell];
    uint64_t bits;
    std::memcpy(&bits, m + 8 * cell, 8);
    return bits;
  }

  std::size_t corner_count() const { return triangle_offsets.empty() ? 0 : 3 * std::size_t(triangle_offsets.back()); }
  /// Block b's distinct edges, as codes.
  std::span<const uint16_t> edges(std::size_t b) const {
    return {block_edges[b], std::size_t(edge_offsets[b + 1] - edge_offsets[b])};
  }
  std::span<const uint16_t> corners(std::size_t b) const {
    return {block_corners[b], 3 * std::size_t(triangle_offsets[b + 1] - triangle_offsets[b])};
  }
  /// The key of one of block b's edge codes.
  uint64_t edge_key(std::size_t b, uint16_t code) const { return codes.key(origins[b], code); }
  /// Every corner's edge key in block order, in one array (the unwelded form).
  std::vector<uint64_t> flatten() const;
};

/// Marching Tiles on an A15 field: the 46 acute tetrahedra of every cell.
MarchedCorners march_tiles(const SparseField& field, float iso);
/// Marching Cubes on a cubic field: the cube of every cell (the cell is its lowest corner).
MarchedCorners march_cubes(const SparseField& field, float iso);
/// Marching Tetrahedra on a cubic field: the 6 Kuhn tetrahedra of every cell's cube.
MarchedCorners march_tetrahedra(const SparseField& field, float iso);

}  // namespace meniscus
