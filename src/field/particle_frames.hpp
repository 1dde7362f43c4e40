// meniscus — the per-particle passes of the field methods (Yu & Turk 2010 §4–5), written once for
// either backend over its primitives: the Laplacian-smoothed centres and the ellipsoids of every
// particle (anisotropy_impl.hpp, as the CPU's anisotropy.cpp computes them over its HashGrid),
// their constraint shells and the largest axis the host needs to size the field's band. The
// backend is a tag (Host or cuda::Device) whose primitives are found by argument-dependent lookup;
// a file that instantiates these for the device includes cuda/primitives.hpp first.
#pragma once

#include <cstddef>
#include <cstdint>

#include "common/buffer.hpp"
#include "common/primitives.hpp"
#include "field/anisotropy_impl.hpp"
#include "field/kernel_impl.hpp"
#include "grid/grid_buffers.hpp"

namespace meniscus {

namespace frames_pass {

/// Sorted particle i of the raw grid: its ellipsoid and its centre, stored at its original index.
struct Frames {
  GridView g;
  const uint32_t* order;
  float pca_radius;
  AnisotropyConstants k;
  float smooth_radius, lambda, centre_reach;
  Vec3f* centres;
  Ellipsoid* ellipsoids;
  MENISCUS_HD void operator()(uint64_t i) const {
    const uint32_t o = order[i];
    if (ellipsoids != nullptr) ellipsoids[o] = particle_ellipsoid(g, uint32_t(i), pca_radius, k);
    if (centres != nullptr) {
      const Vec3f p = g.point(uint32_t(i));
      const Vec3f c = lambda > 0 ? smoothed_position(g, uint32_t(i), smooth_radius, lambda) : p;
      centres[o] = ellipsoids != nullptr && lambda > 0 ? centre_holding_particle(p, c, ellipsoids[o], centre_reach) : c;
    }
  }
};

struct Shells {
  const Ellipsoid* e;
  Ellipsoid* out;
  MENISCUS_HD void operator()(uint64_t i) const { out[i] = unit_volume_shell(e[i]); }
};

struct MaxAxisOf {
  const Ellipsoid* e;
  MENISCUS_HD float operator()(uint64_t i) const { return e[i].max_axis; }
};

struct Max {
  MENISCUS_HD float operator()(float a, float b) const { return b > a ? b : a; }
};

}  // namespace frames_pass

/// Yu & Turk over `raw`, a grid of the original particles: per particle, in the original order,
/// the ellipsoid (when `ellipsoids` is non-null; neighbours within pca_radius) and the
/// Laplacian-smoothed centre (when lambda > 0, else the particle; neighbours within
/// smooth_radius), with both: held within `centre_reach` of the particle in its shell's metric
/// (centre_holding_particle; 0: as smoothed).
template <class B>
void particle_frames(B b, const GridBuffers<B>& raw, float pca_radius, const AnisotropyConstants& k,
                     float smooth_radius, float lambda, BufferOf<B, Vec3f>* centres,
                     BufferOf<B, Ellipsoid>* ellipsoids, float centre_reach = 0) {
  if (centres != nullptr) centres->resize(raw.count);
  if (ellipsoids != nullptr) ellipsoids->resize(raw.count);
  for_each_index(b, raw.count,
                 frames_pass::Frames{raw.view(), raw.order.data(), pca_radius, k, smooth_radius, lambda, centre_reach,
                                       centres != nullptr ? centres->data() : nullptr,
                                       ellipsoids != nullptr ? ellipsoids->data() : nullptr});
}

/// unit_volume_shell() of every ellipsoid (the constraint shells of the field and the smoothing).
template <class B>
BufferOf<B, Ellipsoid> unit_volume_shells(B b, const BufferOf<B, Ellipsoid>& ellipsoids) {
  BufferOf<B, Ellipsoid> out(ellipsoids.size());
  for_each_index(b, ellipsoids.size(), frames_pass::Shells{ellipsoids.data(), out.data()});
  return out;
}

/// The largest max_axis of the first `count` ellipsoids (≥ 0; exact, whatever the order).
template <class B>
float max_ellipsoid_axis(B b, const Ellipsoid* ellipsoids, std::size_t count) {
  return reduce_index(b, count, 0.0f, frames_pass::MaxAxisOf{ellipsoids}, frames_pass::Max{});
}

}  // namespace meniscus
