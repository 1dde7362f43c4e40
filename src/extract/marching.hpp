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

/// The marching stages' output: 3 edge keys per triangle, block by block, with the block
/// structure the weld uses. Block b has triangle_offsets[b + 1] − triangle_offsets[b] triangles
/// (block order is the triangle order of the mesh); its 3 keys per triangle start at
/// block_keys[b], in pages each thread filled as it marched (one pass, no count pass, no copy).
/// Its edges have base cells within 2 cells of the block's cells [origins[b], origins[b] +
/// block_cells) on each axis (a tetrahedron reaches one cell beyond its own, an edge key's base
/// cell one more).
struct MarchedCorners {
  std::vector<std::unique_ptr<uint64_t[]>> pages;
  std::vector<uint64_t*> block_keys;       ///< #blocks (null for a block without triangles)
  std::vector<uint64_t> triangle_offsets;  ///< #blocks + 1
  std::vector<Vec3i> origins;              ///< first cell of each marched block
  int block_cells = 0;

  std::size_t corner_count() const { return triangle_offsets.empty() ? 0 : 3 * std::size_t(triangle_offsets.back()); }
  std::span<uint64_t> block(std::size_t b) const {
    return {block_keys[b], 3 * std::size_t(triangle_offsets[b + 1] - triangle_offsets[b])};
  }
  /// All keys in block order, in one array.
  std::vector<uint64_t> flatten() const;
};

/// Marching Tiles on an A15 field: the 46 acute tetrahedra of every cell.
MarchedCorners march_tiles(const SparseField& field, float iso);
/// Marching Cubes on a cubic field: the cube of every cell (the cell is its lowest corner).
MarchedCorners march_cubes(const SparseField& field, float iso);
/// Marching Tetrahedra on a cubic field: the 6 Kuhn tetrahedra of every cell's cube.
MarchedCorners march_tetrahedra(const SparseField& field, float iso);

}  // namespace meniscus
