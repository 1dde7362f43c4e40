// meniscus — the velocity weighting's per-vertex factor (--velocity-weighted), shared by the CPU
// and CUDA backends.
#pragma once

#include "meniscus/vec.hpp"

namespace meniscus {

/// The damping factor of a vertex whose transferred velocity is v: clamp(1 − |v|/v_ref, w_min, 1)
/// (calm water is smoothed fully, fast water less).
MENISCUS_HD inline float velocity_weight(Vec3f v, float reference, float min_weight) {
  const float w = 1.0f - length(v) / reference;
  return w < min_weight ? min_weight : (w > 1.0f ? 1.0f : w);
}

}  // namespace meniscus
