// meniscus — the per-element arithmetic of the sparse distance field (Williams 2008 §3;
// Edespong 2010 §3.2), shared by the CPU (distance_field.cpp: each block scatters its particles)
// and the CUDA backend (each sample gathers them): the same float expressions decide which
// samples a particle reaches and what distance they get, so both fields are bit-identical.
#pragma once

#include <cmath>
#include <cstdint>

#include "meniscus/vec.hpp"

namespace meniscus {

/// Block coordinates [*lo, *hi] on one axis of the blocks (edge `block_size`) that the box of hash
/// cell `cell` (edge `cell_size`), widened by `band`, touches.
MENISCUS_HD inline void band_block_range(int32_t cell, float cell_size, float band, float block_size, int32_t* lo,
                                         int32_t* hi) {
  *lo = int32_t(std::floor((float(cell) * cell_size - band) / block_size));
  *hi = int32_t(std::floor((float(cell + 1) * cell_size + band) / block_size));
}

/// floor(x) and ceil(x) as integers, for |x| < 2³¹ (lattice coordinates are checked far below).
/// Without SSE4.1 the compiler emulates std::floor in about ten instructions; truncation and one
/// correction give the same integer (the distance field's scatter takes six of each per particle
/// and lattice offset).
MENISCUS_HD inline int32_t floor_to_int(float x) {
#ifdef __CUDA_ARCH__
  return int32_t(floorf(x));
#else
  const int32_t i = int32_t(x);
  return i - int32_t(float(i) > x);
#endif
}
MENISCUS_HD inline int32_t ceil_to_int(float x) {
#ifdef __CUDA_ARCH__
  return int32_t(ceilf(x));
#else
  const int32_t i = int32_t(x);
  return i + int32_t(float(i) < x);
#endif
}

/// Cells [*lo, *hi] on one axis whose sample (offset `offset`, in cells) lies within `band` of
/// the particle coordinate `p` (lattice spacing 1 / inv_a), unclipped.
MENISCUS_HD inline void particle_cell_range(float p, float band, float inv_a, float offset, int32_t* lo, int32_t* hi) {
  *lo = ceil_to_int((p - band) * inv_a - offset);
  *hi = floor_to_int((p + band) * inv_a - offset);
}

/// Whether sample `s` of lattice cell `cell` (offsets `off`, in cells) is among the samples the
/// scatter of a particle at p with reach `radius` visits (its clipped box, particle_cell_range):
/// the gathers test this so they sum exactly the terms the scatters add.
MENISCUS_HD inline bool sample_in_reach(Vec3f p, float radius, float inv_a, const float (&off)[3], Vec3i cell) {
  bool inside = true;
  for (int ax = 0; ax < 3; ++ax) {
    int32_t lo, hi;
    particle_cell_range(p[ax], radius, inv_a, off[ax], &lo, &hi);
    inside = inside && lo <= cell[ax] && cell[ax] <= hi;
  }
  return inside;
}

/// One coordinate of the difference between a sample and a particle.
MENISCUS_HD inline float sample_delta(int32_t cell, float offset, float a, float p) { return (float(cell) + offset) * a - p; }

/// Squared distance, summed as the CPU's loops do: x last onto the (y, z) part.
MENISCUS_HD inline float sample_dist2(float dx, float dy, float dz) { return dx * dx + (dy * dy + dz * dz); }

}  // namespace meniscus
