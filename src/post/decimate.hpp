// meniscus — simplification of the finished mesh under a bound on the geometric error: flat water
// loses most of its triangles, splashes and droplets keep theirs. The edge collapses are
// meshoptimizer's (meshopt_simplify: Garland & Heckbert's quadric error metric, "Surface
// Simplification Using Quadric Error Metrics", SIGGRAPH 1997, with its topology checks); what
// this stage adds is the contract — every result is measured against the full mesh and a
// component that would break it keeps its full triangles.
#pragma once

#include <cstddef>

#include "meniscus/mesh.hpp"

namespace meniscus {

struct DecimateOutcome {
  std::size_t triangles_before = 0;
  std::size_t triangles_after = 0;
  /// The largest distance measured between the two surfaces: of each vertex the simplification
  /// removed (and the centroid of each full triangle it removed) to the simplified surface, and of
  /// points on each simplified triangle, a grid at the full mesh's mean edge length, to the full
  /// surface (≤ 0.8 max_error, so that the surfaces between the points stay within max_error).
  double max_error = 0;
  /// The most simplifications one patch needed: the first, and one more each time the triangles
  /// around the vertices where the contract broke were set aside.
  int rounds = 0;
  /// Components kept whole because the contract still broke after the last round.
  std::size_t kept_whole = 0;
};

/// Simplifies `mesh` (closed, or open along borders such as a clip's cut, which stay as they are)
/// in place: edges are collapsed while meshoptimizer's error stays under a share of max_error (a
/// world distance); the vertices no triangle uses are then dropped, and the normals and
/// attributes of the others follow unchanged (no vertex moves). The result is then checked: every
/// edge shared by exactly two triangles in opposite directions (or a border edge of the input),
/// every component keeping triangles, and the distances of DecimateOutcome::max_error. Where it
/// breaks, the input triangles around the offending vertices are kept and the rest simplified
/// again, up to 8 rounds. All of this runs per patch (a grid cell of about 40,000 triangles, seams
/// locked), in parallel, in passes over shifted grids, each simplifying the last one's result with
/// meshopt's error raised from 0.4 to 0.8 of the bound, until a pass gains less than 2 %; a final
/// check of the whole result against the full mesh restores any component that fails it.
/// max_error ≤ 0 leaves the mesh as it is.
DecimateOutcome decimate(TriangleMesh& mesh, double max_error);

/// Null where this build can decimate; otherwise why not (meshoptimizer, an optional dependency, was
/// not found): then decimate throws InvalidParameter with it, and reconstruct() refuses decimate first.
const char* decimate_unavailable();

}  // namespace meniscus
