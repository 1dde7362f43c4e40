// meniscus — iso-surface extraction from the sparse field: Marching Tiles (Williams 2008,
// the A15 acute tetrahedral tile), Marching Cubes (Lorensen & Cline 1987) and Marching
// Tetrahedra (Doi & Koide 1991, Kuhn 6-tetrahedra split). One pass over the field's blocks
// (the CUDA backend counts, scans and writes); vertices are the lattice edges that cross the
// surface, numbered in edge-key order from per-row counts (weld.hpp), so the mesh is watertight
// wherever the band is closed.
#pragma once

#include <cstddef>

#include "field/sparse_field.hpp"
#include "meniscus/mesh.hpp"
#include "meniscus/params.hpp"

namespace meniscus {

struct ExtractResult {
  TriangleMesh mesh;                  ///< vertices + triangles (no normals/attributes)
  std::size_t dropped_triangles = 0;  ///< triangles removed because two corners welded together
  /// Each vertex's edge key (edge_key.hpp), ascending, when asked for: the vertex's identity on the
  /// lattice, the same in any extraction whose field agrees on its edge (a slab of a frame and the
  /// whole frame), which orders one process's mesh for the MPI gather (meniscus/distributed.hpp).
  std::vector<uint64_t> vertex_keys;
};

/// Triangulates the level set {φ = iso} of `field`. Triangles are counter-clockwise seen from
/// the side of larger φ (so for a distance field, normals point out of the fluid). The field's
/// lattice must match the extractor: Extractor::tiles needs SampleLattice::Kind::a15, cubes and
/// tetrahedra need Kind::cubic (InvalidParameter otherwise). The field's background must be
/// > iso (unallocated space is outside). The interpolation parameter along an edge is clamped to
/// [kEdgeClamp, 1 − kEdgeClamp] so no triangle degenerates.
///
/// The mesh is closed, edge- and vertex-manifold and consistently oriented for any field, also
/// where inside samples touch the edge of the allocated blocks (the unallocated neighbours of
/// such blocks are marched too). Vertices are ordered by edge key, triangles by block, cell and
/// tetrahedron: the result does not depend on the thread count. Parallel over blocks (oneTBB).
/// Throws InvalidParameter (lattice/extractor mismatch, iso not finite, background ≤ iso) and
/// ResourceError when an allocated block, with one block and 2 cells of margin, lies outside the
/// range of the 64-bit edge keys (|cell| ≤ 2^18 − 1 on each axis, edge_key.hpp) or the mesh would
/// need 2^32 or more vertices. With `vertex_keys`, also each vertex's edge key (8 bytes a vertex).
ExtractResult extract_surface(const SparseField& field, float iso, Extractor extractor, bool vertex_keys = false);

inline constexpr float kEdgeClamp = 1e-3f;

}  // namespace meniscus
