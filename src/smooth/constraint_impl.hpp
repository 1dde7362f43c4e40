// meniscus — per-vertex constraint projection (Williams 2008 §4.2), shared by the CPU and CUDA
// backends: a vertex must lie between r_inner and r_outer from its nearest particle.
#pragma once

#include "meniscus/vec.hpp"

namespace meniscus {

/// Moves x radially from the particle p onto the shell r_inner ≤ |x − p| ≤ r_outer.
/// A vertex exactly on the particle is pushed along +z (any direction satisfies the constraint).
MENISCUS_HD inline Vec3f project_to_shell(Vec3f x, Vec3f p, float r_inner, float r_outer) {
  const Vec3f d = x - p;
  const float l2 = length2(d);
  if (l2 < r_inner * r_inner) {
    if (l2 == 0.0f) return p + Vec3f{0, 0, r_inner};
    return p + d * (r_inner / std::sqrt(l2));
  }
  if (l2 > r_outer * r_outer) return p + d * (r_outer / std::sqrt(l2));
  return x;
}

}  // namespace meniscus
