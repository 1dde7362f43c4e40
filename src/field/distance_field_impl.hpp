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

/// Cells [*lo, *hi] on one axis whose sample (offset `offset`, in cells) lies within `band` of
/// the particle coordinate `p` (lattice spacing 1 / inv_a), unclipped.
MENISCUS_HD inline void particle_cell_range(float p, float band, float inv_a, float offset, int32_t* lo, int32_t* hi) {
  *lo = int32_t(std::ceil((p - band) * inv_a - offset));
  *hi = int32_t(std::floor((p + band) * inv_a - offset));
}

/// One coordinate of the difference between a sample and a particle.
MENISCUS_HD inline float sample_delta(int32_t cell, float offset, float a, float p) { return (float(cell) + offset) * a - p; }

/// Squared distance, summed as the CPU's loops do: x last onto the (y, z) part.
MENISCUS_HD inline float sample_dist2(float dx, float dy, float dz) { return dx * dx + (dy * dy + dz * dz); }

}  // namespace meniscus
