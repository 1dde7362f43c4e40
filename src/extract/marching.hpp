// meniscus — the three marching stages (Williams 2008 Marching Tiles; Lorensen & Cline 1987
// Marching Cubes; Doi & Koide 1991 Marching Tetrahedra). Each returns the triangles of the level
// set {φ = iso} as edge keys (edge_key.hpp), 3 per triangle, counter-clockwise seen from larger φ,
// in a deterministic order (block, cell, tetrahedron); weld.hpp turns them into a mesh.
// Preconditions (checked by extract_surface): the lattice kind fits the extractor and the
// background is > iso. Throw ResourceError when a block lies outside the edge-key range.
#pragma once

#include <cstdint>
#include <vector>

#include "field/sparse_field.hpp"

namespace meniscus {

/// The marching stages' output: 3 edge keys per triangle, in block order, with the block structure
/// the weld uses. Block b's triangles are [triangle_offsets[b], triangle_offsets[b + 1]); their
/// edges have base cells within 2 cells of the block's cells [origins[b], origins[b] + block_cells)
/// on each axis (a tetrahedron reaches one cell beyond its own, an edge key's base cell one more).
struct MarchedCorners {
  std::vector<uint64_t> keys;
  std::vector<uint64_t> triangle_offsets;  ///< #blocks + 1
  std::vector<Vec3i> origins;              ///< first cell of each marched block
  int block_cells = 0;
};

/// Marching Tiles on an A15 field: the 46 acute tetrahedra of every cell.
MarchedCorners march_tiles(const SparseField& field, float iso);
/// Marching Cubes on a cubic field: the cube of every cell (the cell is its lowest corner).
MarchedCorners march_cubes(const SparseField& field, float iso);
/// Marching Tetrahedra on a cubic field: the 6 Kuhn tetrahedra of every cell's cube.
MarchedCorners march_tetrahedra(const SparseField& field, float iso);

}  // namespace meniscus
