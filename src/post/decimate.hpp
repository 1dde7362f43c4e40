// meniscus — simplification of the finished mesh that keeps its triangles good: edge collapses
// ordered by the area-weighted squared distance the collapse moves the removed vertex's triangles'
// planes (Garland & Heckbert's quadric, "Surface Simplification Using Quadric Error Metrics",
// SIGGRAPH 1997, of the current surface: memoryless, as in Lindstrom & Turk's "Fast and Memory
// Efficient Polygonal Simplification", 1998, so no vertex carries one), interleaved with
// valence-balancing edge flips (as in Botsch & Kobbelt's isotropic remeshing, "A Remeshing
// Approach to Multiresolution Modeling", SGP 2004). A collapse first removes u into its neighbour
// v where v is (the surface's own vertex, its normal and attributes unchanged); where the surface
// bends too much for that within the bound, v moves to meet u, for its cheapest neighbour, taking
// the mean of the two's normals and non-integer attributes: to the point nearest the planes of
// both fans (Garland & Heckbert's placement over the current surface, from the two's midpoint),
// which on a curved surface sits on its outer side, so the new triangles straddle the surface
// rather than cut under it, and which must lie within 0.55 of the bound of the input surface.
// Moving so keeps fewer triangles at the same bound than never moving v or moving it to the
// midpoint, for some more time (bench/RESULTS.md#lean-meshes---decimate).
// Every operation is refused unless, after it:
//   - every point of the input surface that keeps the bound (its vertices, edge midpoints and
//     triangle centroids) lies within 0.55 of the bound of the triangle that holds it: an
//     operation hands the points of the triangles it changes to the new ones, checked exactly
//     point to triangle, or is refused (the margin: the surfaces can part farther between the
//     points; measured independently both ways on every bundled frame, they stay within the bound);
//   - the mesh stays closed and manifold (the link condition; no edge twice);
//   - no vertex falls under valence 5 (or under its valence in the input) nor climbs over 9;
//   - no new triangle has an angle under 15° (unless the one it replaces had a smaller one), and
//     none turns more than 45° from the triangle it replaces or 60° from the input's normals at
//     its corners (so no fold).
// Not meshoptimizer: it has no control of valence or angles, and its collapses must be checked
// against the bound by sampling, which is much slower (bench/RESULTS.md#lean-meshes---decimate).
// The mesh is cut into patches, the cells of a grid anchored at the origin (8 d wide in the
// pipeline up to E = 0.02, about 2,000 triangles of flat water, wider above: stage_plan.hpp), simplified in parallel
// with their seams kept (a vertex changes only where all its triangles are in the patch); up to 3 passes over grids
// shifted by the golden ratio's fraction of a cell let the seams go too. A vertex none of whose
// collapses passes is tried again only once its triangles change. The result does not depend on the number
// of threads.
#pragma once

#include <cstddef>

#include "meniscus/mesh.hpp"

namespace meniscus {

struct DecimateOutcome {
  std::size_t triangles_before = 0;
  std::size_t triangles_after = 0;
  std::size_t collapses = 0, flips = 0;
  /// The largest distance of one of the input's points (vertices, edge midpoints, triangle
  /// centroids) from the simplified triangle that holds it: at most 0.55 of the bound (a little
  /// more on the near-degenerate triangles of a clip's cap, where float arithmetic blurs it).
  double max_error = 0;
  int rounds = 0;  ///< the passes over shifted patch grids
};

/// Simplifies `mesh` in place within `bound` (a world distance; ≤ 0 leaves it as it is) as the
/// file's comment says, in patches that are the cells of side `cell` (a world distance) of a grid
/// anchored at the origin, then drops the vertices no triangle uses. Borders (a clip's cut) and
/// vertices where the input is not manifold stay as they are. A triangle of the result depends
/// only on the input within decimate_reach(cell) of it.
DecimateOutcome decimate(TriangleMesh& mesh, double bound, double cell);

/// The passes over shifted grids.
inline constexpr int kDecimatePasses = 3;

/// How far a change of the input reaches in the result of decimate(…, cell): each pass reads the
/// patch around a triangle (a cell's diagonal), one more diagonal for the triangles that straddle
/// the cells. Every triangle whose corners all lie farther than this from every vertex that
/// changed comes out the same, bit for bit (tests/e2e/test_decimate.cpp).
inline double decimate_reach(double cell) { return (kDecimatePasses + 1) * 1.7320508075688772 * cell; }

}  // namespace meniscus
