// meniscus — cutting the finished surface by a box (the tank's walls and floor go, the water's
// top stays), and optionally closing the cut with the box's faces so the mesh stays watertight.
// The cut runs after the smoothing: every vertex inside the box is where it is without the box.
#pragma once

#include <array>
#include <cstddef>

#include "meniscus/mesh.hpp"
#include "quality/triangle_bvh.hpp"

namespace meniscus {

/// A box's faces as the mesh's floats: xmin, ymin, zmin, xmax, ymax, zmax.
using ClipBox = std::array<float, 6>;

struct ClipOutcome {
  std::size_t removed_triangles = 0;  ///< wholly outside the box (or lying in one of its faces)
  std::size_t cut_triangles = 0;      ///< crossing a face: replaced by their part inside
  std::size_t cap_triangles = 0;      ///< added on the box's faces (clip_to_box's `cap`)
  /// Edges the cap left open (the cut's curves crossing or touching each other on a face, where
  /// the surface intersects itself): 0 for a watertight result.
  std::size_t cap_defects = 0;
};

/// Cuts `mesh` by the six planes of `box`, one after the other (Sutherland–Hodgman per
/// triangle): a triangle crossing a plane is replaced by its part inside, triangulated, with one
/// new vertex per crossed edge (shared by the edge's two triangles; position, normal and
/// attributes interpolated along the edge, the coordinate across the plane set to the plane's
/// exactly, integer attributes taken from the nearer end). Vertices on a plane count as inside; a
/// triangle with no vertex strictly inside goes. The vertices no triangle uses are dropped; the
/// others keep their positions, normals and attributes bit for bit. The mesh is left open along
/// the cut unless `cap`: then cap_box_faces() closes it.
ClipOutcome clip_to_box(TriangleMesh& mesh, const ClipBox& box, bool cap);

/// Closes a mesh that clip_to_box cut open: on each face of the box, the region inside the
/// uncut surface (`inside`, a BVH of the surface before the cut) is triangulated between the
/// cut's boundary vertices, the points where the cut meets the box's edges and the box's corners
/// (a constrained Delaunay triangulation, CGAL's), facing out of the box. The cut's vertices are
/// shared, so the result is closed; a corner used becomes a new vertex (its face's normal, the
/// attributes of a neighbour). Adds to outcome.cap_triangles and sets outcome.cap_defects.
void cap_box_faces(TriangleMesh& mesh, const ClipBox& box, const TriangleBvh& inside, ClipOutcome& outcome);

/// Null where this build can cap; otherwise why not (CGAL, an optional dependency, was not found):
/// then cap_box_faces throws InvalidParameter with it, and reconstruct() refuses clip_cap before any work.
const char* clip_cap_unavailable();

}  // namespace meniscus
