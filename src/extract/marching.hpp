// meniscus — the three marching stages (Williams 2008 Marching Tiles; Lorensen & Cline 1987
// Marching Cubes; Doi & Koide 1991 Marching Tetrahedra). Each returns the triangles of the level
// set {φ = iso} as edge keys (edge_key.hpp), 3 per triangle, counter-clockwise seen from larger φ,
// in a deterministic order (block, cell, tetrahedron); weld.hpp turns them into a mesh.
// Preconditions (checked by extract_surface): the lattice kind fits the extractor and the
// background is > iso. Throw ResourceError when a block lies outside the edge-key range.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "field/sparse_field.hpp"

namespace meniscus {

/// The marching stages' output, already welded within each block: block b has
/// triangle_offsets[b + 1] − triangle_offsets[b] triangles (block order is the triangle order of
/// the mesh) and edge_offsets[b + 1] − edge_offsets[b] distinct edges. block_edges[b] holds those
/// edges' keys in the order the block's corners first use them, block_corners[b] the index of each
/// corner's edge among them, 3 per triangle (corner c's key is block_edges[b][block_corners[b][c]]):
/// both in pages each thread filled as it marched (one pass, no count pass, no copy; the corners'
/// keys themselves never leave the thread's cache, which the weld's first pass used to read back
/// from 8 bytes a corner of pages). A block's edges have base cells within 2 cells of its cells
/// [origins[b], origins[b] + block_cells) on each axis (a tetrahedron reaches one cell beyond its
/// own, an edge key's base cell one more).
struct MarchedCorners {
  std::vector<std::unique_ptr<uint64_t[]>> edge_pages;
  std::vector<std::unique_ptr<uint32_t[]>> corner_pages;
  std::vector<const uint64_t*> block_edges;    ///< #blocks (null for a block without triangles)
  std::vector<const uint32_t*> block_corners;  ///< #blocks (null for a block without triangles)
  std::vector<uint64_t> triangle_offsets;      ///< #blocks + 1
  std::vector<uint64_t> edge_offsets;          ///< #blocks + 1
  std::vector<Vec3i> origins;                  ///< first cell of each marched block
  int block_cells = 0;

  std::size_t corner_count() const { return triangle_offsets.empty() ? 0 : 3 * std::size_t(triangle_offsets.back()); }
  std::size_t edge_count() const { return edge_offsets.empty() ? 0 : std::size_t(edge_offsets.back()); }
  std::span<const uint64_t> edges(std::size_t b) const {
    return {block_edges[b], std::size_t(edge_offsets[b + 1] - edge_offsets[b])};
  }
  std::span<const uint32_t> corners(std::size_t b) const {
    return {block_corners[b], 3 * std::size_t(triangle_offsets[b + 1] - triangle_offsets[b])};
  }
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
