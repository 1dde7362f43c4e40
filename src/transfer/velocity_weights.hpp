// meniscus — the velocity weighting's per-vertex factors (--velocity-weighted) over a backend's
// arrays, written once for either backend (velocity_weight_impl.hpp has the arithmetic). The
// backend is a tag (Host or cuda::Device) whose for_each_index is found by argument-dependent
// lookup.
#pragma once

#include <cstddef>
#include <cstdint>

#include "common/buffer.hpp"
#include "transfer/velocity_weight_impl.hpp"

namespace meniscus {

namespace velocity_pass {

/// w[i]: velocity_weight of vertex i's velocity (3 floats a vertex).
struct Weights {
  const float* v;
  float reference, min_weight;
  float* w;
  MENISCUS_HD void operator()(uint64_t i) const {
    w[i] = velocity_weight(Vec3f{v[3 * i], v[3 * i + 1], v[3 * i + 2]}, reference, min_weight);
  }
};

}  // namespace velocity_pass

/// velocity_weight() of each of `vertices` vertices from its transferred velocity (3 floats a
/// vertex, on backend B).
template <class B>
BufferOf<B, float> velocity_weights(B b, const float* velocity, std::size_t vertices, float reference,
                                    float min_weight) {
  BufferOf<B, float> w(vertices);
  for_each_index(b, vertices, velocity_pass::Weights{velocity, reference, min_weight, w.data()});
  return w;
}

}  // namespace meniscus
