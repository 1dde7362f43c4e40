// meniscus — removal of small interior voids: closed components of the surface that face
// inwards (negative enclosed volume) and enclose less than a given volume. Such cavities are
// gaps in the particle sampling, not air bubbles; the smoothing would collapse them to a point.
#pragma once

#include <cstddef>
#include <span>

#include "grid/hash_grid.hpp"
#include "meniscus/mesh.hpp"

namespace meniscus {

/// The volume under which a closed component counts as small (a void or a blob): (2d)³ for
/// particle spacing d.
inline double small_component_volume(double spacing) { return 8 * spacing * spacing * spacing; }
/// A particle's inner ball, 4/3·π·r_inner³ (remove_unsupported_blobs' min_volume).
inline double inner_ball_volume(double r_inner) {
  return 4.0 / 3.0 * 3.14159265358979323846 * r_inner * r_inner * r_inner;
}

/// Removes every connected component (by shared edges) whose signed volume is in
/// (−max_volume, 0], then drops the vertices no triangle uses (order otherwise preserved).
/// Returns the number of components removed.
std::size_t remove_small_voids(TriangleMesh& mesh, double max_volume);

/// Kernel fields only: removes the small outward components the constrained smoothing cannot
/// hold. (1) Components with volume in (0, max_volume] that enclose none of the points of
/// `particles` (ray parity): the blobs a kernel field grows in the gap between particles (Zhu &
/// Bridson's averaged centre lies there), which the smoothing crushes onto the particles' shells.
/// (2) Components with volume in (0, min_volume] (min_volume: a particle's inner ball): a blob
/// smaller than the inner shell of the particle it holds slides off that shell under the shrink
/// sweeps and collapses to a point. Either way the result would be zero-area triangles. The
/// distance field makes neither (each of its components is a union of r_outer balls).
/// Returns the number of components removed.
std::size_t remove_unsupported_blobs(TriangleMesh& mesh, const HashGrid& particles, double max_volume,
                                     double min_volume);

}  // namespace meniscus
