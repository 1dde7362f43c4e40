// meniscus — the per-vertex Z-order key of reorder_vertices_spatially, shared by the CPU and CUDA
// backends so both number the vertices identically (Morton 1966).
#pragma once

#include <cmath>
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

/// The 30-bit Z-order code of p on the grid of cell `cell` anchored at the origin (1/cell given),
/// each cell coordinate taken modulo 1024. A function of p alone — not of a bounding box — so two
/// vertices keep their relative order whatever else is in the frame, and the sweeps, whose sums
/// follow the numbering, stay local; a frame wider than 1024 cells interleaves its far-apart parts
/// (in memory only: the order stays a function of the positions).
MENISCUS_HD inline uint32_t morton_key(Vec3f p, float inv_cell) {
  auto cell = [inv_cell](float v) {
    float t = floorf(v * inv_cell);
    t = t < -1e9f ? -1e9f : (t > 1e9f ? 1e9f : t);
    return uint32_t(int32_t(t)) & 0x3FFu;
  };
  return morton_spread10(cell(p.x)) | morton_spread10(cell(p.y)) << 1 | morton_spread10(cell(p.z)) << 2;
}

}  // namespace meniscus
