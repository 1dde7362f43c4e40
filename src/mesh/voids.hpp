// meniscus — removal of small interior voids: closed components of the surface that face
// inwards (negative enclosed volume) and enclose less than a given volume. Such cavities are
// gaps in the particle sampling, not air bubbles; the smoothing would collapse them to a point.
#pragma once

#include <cstddef>

#include "meniscus/mesh.hpp"

namespace meniscus {

/// Removes every connected component (by shared edges) whose signed volume is in
/// (−max_volume, 0], then drops the vertices no triangle uses (order otherwise preserved).
/// Returns the number of components removed.
std::size_t remove_small_voids(TriangleMesh& mesh, double max_volume);

}  // namespace meniscus
