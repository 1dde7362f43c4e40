// meniscus — per-vertex constraint projection (Williams 2008 §4.2), shared by the CPU and CUDA
// backends: a vertex must lie between r_inner and r_outer from its nearest particle.
#pragma once

#include "field/eigen_sym3_impl.hpp"
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

namespace meniscus {

/// Distance of x from an ellipsoid's centre c in the ellipsoid's metric, |A(x − c)|.
MENISCUS_HD inline float metric_distance(const SymMat3& a, Vec3f x, Vec3f c) { return length(a * (x - c)); }

/// Moves x along the line from the ellipsoid's centre c (the metric's radial direction, the
/// ellipsoid analogue of Williams' radial projection) onto the shell r_inner ≤ |A(x − c)| ≤
/// r_outer. Not the closest point of the ellipsoid shell, but exact in the metric (the projected
/// point measures r_inner or r_outer up to rounding) and without iteration. A vertex exactly at
/// the centre is pushed along +z.
MENISCUS_HD inline Vec3f project_to_ellipsoid_shell(Vec3f x, Vec3f c, const SymMat3& a, float r_inner, float r_outer) {
  Vec3f d = x - c;
  float m = length(a * d);
  if (m >= r_inner && m <= r_outer) return x;
  const float target = m < r_inner ? r_inner : r_outer;
  if (m == 0.0f) {
    d = Vec3f{0, 0, 1};
    m = length(a * d);
  }
  return c + d * (target / m);
}

}  // namespace meniscus
