// meniscus — per-triangle cotangent weights and area terms (Pinkall & Polthier 1993; with
// Williams' 2008 clamps), shared by the CPU and CUDA backends.
#pragma once

#include "meniscus/vec.hpp"

namespace meniscus {

/// Lower bound of the sine of a triangle angle used in cotangents and areas: Williams clamps
/// each triangle's area term to ≥ 0.05·|e_ij|·|e_ik| so slivers cannot blow the weights up.
inline constexpr float kMinSine = 0.05f;
/// Cotangents are clamped to ≥ this (negative cotangents of obtuse angles would make the
/// operator indefinite and the B-steps diverge).
inline constexpr float kMinCotangent = 0.01f;

/// Clamped cotangent of the angle at `apex` between the edges to a and b.
MENISCUS_HD inline float clamped_cotangent(Vec3f apex, Vec3f a, Vec3f b) {
  const Vec3f u = a - apex, v = b - apex;
  const float c = dot(u, v);
  const float s = length(cross(u, v));
  const float floor_s = kMinSine * std::sqrt(length2(u) * length2(v));
  const float cot = c / (s > floor_s ? s : floor_s);
  return cot > kMinCotangent ? cot : kMinCotangent;
}

/// Clamped area of triangle (a, b, c), never below kMinSine/2 · |ab|·|ac|.
MENISCUS_HD inline float clamped_area(Vec3f a, Vec3f b, Vec3f c) {
  const Vec3f u = b - a, v = c - a;
  const float s = length(cross(u, v));
  const float floor_s = kMinSine * std::sqrt(length2(u) * length2(v));
  return 0.5f * (s > floor_s ? s : floor_s);
}

}  // namespace meniscus
