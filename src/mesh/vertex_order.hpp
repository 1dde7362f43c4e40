// meniscus — spatial (Morton / Z-order) renumbering of a mesh's vertices and triangles, so that
// the smoothing sweeps, whose cost is dominated by memory latency, read neighbouring vertices,
// their particle lists and their matrix rows from nearby addresses (the same reason the hash grid
// sorts particles by cell).
#pragma once

#include "meniscus/mesh.hpp"

namespace meniscus {

/// Renumbers the vertices in the Z-order of their positions on the grid of cell `cell` anchored at
/// the origin (morton_key: ties keep the old order), and sorts the triangles by their smallest new
/// vertex index (ties keep their order). The relative order of two vertices, or of two triangles,
/// depends on their own positions and old order alone, never on the rest of the frame. Geometry,
/// orientation and connectivity are unchanged; normals and attributes, when present, move with
/// their vertices. Deterministic and independent of the thread count.
void reorder_vertices_spatially(TriangleMesh& mesh, float cell);

}  // namespace meniscus
