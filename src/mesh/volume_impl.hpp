// meniscus — a triangle's share of a closed mesh's volume, shared by the CPU (quality metrics,
// void and blob removal) and the CUDA backend (void removal), so both sum the same terms.
#pragma once

#include "meniscus/vec.hpp"

namespace meniscus {

/// Six times the signed volume of the tetrahedron (origin, a, b, c), in double: summed over a
/// closed, outward-oriented mesh's triangles it is six times the enclosed volume.
MENISCUS_HD inline double signed_volume6(Vec3f a, Vec3f b, Vec3f c) {
  return double(a.x) * (double(b.y) * c.z - double(b.z) * c.y) - double(a.y) * (double(b.x) * c.z - double(b.z) * c.x) +
         double(a.z) * (double(b.x) * c.y - double(b.y) * c.x);
}

}  // namespace meniscus
