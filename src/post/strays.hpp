// meniscus — strays (--min-particles): the finished surface's small closed pieces that enclose
// too few particles to be fluid — particles stuck in a wall, lone strays of the solver.
#pragma once

#include <cstddef>
#include <span>

#include "meniscus/mesh.hpp"

namespace meniscus {

/// Removes the outward closed components (positive volume) that enclose fewer than
/// `min_particles` of `particles`, with their vertices, normals and attributes: a particle counts
/// for the component of its nearest vertex within `reach` when it lies on that vertex's inner side
/// (its normal, or the mesh's vertex normals computed here). Returns the number removed.
std::size_t remove_components_enclosing_few(TriangleMesh& mesh, std::span<const Vec3f> particles, float reach,
                                            std::size_t min_particles);

}  // namespace meniscus
