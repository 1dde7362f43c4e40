// meniscus — carrying particle attributes onto mesh vertices (docs/method.md).
#pragma once

#include <span>

#include "grid/hash_grid.hpp"
#include "meniscus/particles.hpp"

namespace meniscus {

/// Vertex values of a particle attribute: a weighted mean over the particles within `radius`
/// of the vertex, weights w = (1 − (r/radius)²)³; the nearest particle's value where none is
/// inside. `grid` holds the particles; `attribute` is indexed by the original particle order
/// (grid.order() maps sorted → original).
Attribute transfer_attribute(const AttributeView& attribute, const HashGrid& grid, std::span<const Vec3f> vertices,
                             float radius);

}  // namespace meniscus
