// meniscus — the per-vertex Z-order key of reorder_vertices_spatially, shared by the CPU and CUDA
// backends so both number the vertices identically (Morton 1966).
#pragma once

#include <cstdint>

#include "meniscus/vec.hpp"

namespace meniscus {

/// Spreads the low 10 bits of v so that there are two zero bits between each.
MENISCUS_HD inline uint32_t morton_spread10(uint32_t v) {
  uint32_t x = v & 0x3FFu;
  x = (x | (x << 16)) & 0x030000FFu;
  x = (x | (x << 8)) & 0x0300F00Fu;
  x = (x | (x << 4)) & 0x030C30C3u;
  x = (x | (x << 2)) & 0x09249249u;
  return x;
}

/// The 30-bit Z-order code of p on a 1024³ grid from `lo` with `scale` = 1023 / (largest extent).
MENISCUS_HD inline uint32_t morton_key(Vec3f p, Vec3f lo, float scale) {
  auto cell = [scale](float v, float l) {
    float t = (v - l) * scale;
    t = t < 0.0f ? 0.0f : (t > 1023.0f ? 1023.0f : t);
    return uint32_t(t);
  };
  return morton_spread10(cell(p.x, lo.x)) | morton_spread10(cell(p.y, lo.y)) << 1 |
         morton_spread10(cell(p.z, lo.z)) << 2;
}

/// 1023 / the largest extent of the box [lo, hi] (0 for a point).
MENISCUS_HD inline float morton_scale(Vec3f lo, Vec3f hi) {
  float e = hi.x - lo.x;
  e = hi.y - lo.y > e ? hi.y - lo.y : e;
  e = hi.z - lo.z > e ? hi.z - lo.z : e;
  return e > 0 ? 1023.0f / e : 0.0f;
}

}  // namespace meniscus
