// meniscus — attribute transfer per vertex (Zhu & Bridson 2005 weights), written once for the CPU
// (transfer/attribute_transfer.cpp) and the device (transfer_backend.hpp, run by transfer_device.cu): a vertex takes the
// kernel-weighted mean of the particles' values within the radius, or the nearest particle's
// value where none is within it.
#pragma once

#include <cstdint>

#include "grid/hash_grid_impl.hpp"
#include "meniscus/vec.hpp"

namespace meniscus {

/// One attribute's transfer onto the vertices: `values` per particle (`components` each, the
/// particles in input order, `order` mapping the grid's sorted index to it), `out` per vertex.
struct TransferData {
  const float* values;
  int components;
  const uint32_t* order;
  const Vec3f* x;
  float radius;
  float* out;
};

/// Components summed per walk of the grid: a walk per 4 components (most attributes have at most
/// 4), each component summed in double in the particles' walk order on both backends.
inline constexpr int kTransferGroup = 4;

/// Vertex v's values.
template <class Grid>
MENISCUS_HD void transfer_vertex(const Grid& grid, const TransferData& d, uint64_t v) {
  const int nc = d.components;
  const float inv_r2 = 1.0f / (d.radius * d.radius);
  float* dst = d.out + v * uint64_t(nc);
  bool any = false;
  for (int c0 = 0; c0 < nc; c0 += kTransferGroup) {
    const int m = nc - c0 < kTransferGroup ? nc - c0 : kTransferGroup;
    double acc[kTransferGroup] = {0, 0, 0, 0};
    double wsum = 0;
    grid_for_each_within(grid, d.x[v], d.radius, [&](uint32_t i, float d2) {
      const double q = 1.0 - double(d2 * inv_r2);
      const double w = q * q * q;
      if (w <= 0) return;
      const float* src = d.values + uint64_t(d.order[i]) * uint64_t(nc) + c0;
      for (int c = 0; c < m; ++c) acc[c] += w * src[c];
      wsum += w;
    });
    if (wsum <= 0) break;  // no particle within the radius: none for the other components either
    for (int c = 0; c < m; ++c) dst[c0 + c] = float(acc[c] / wsum);
    any = true;
  }
  if (any || nc == 0) return;
  const NearestPoint n = grid_nearest(grid, d.x[v]);
  for (int c = 0; c < nc; ++c)
    dst[c] = n.index == kNotFound ? 0.0f : d.values[uint64_t(d.order[n.index]) * uint64_t(nc) + c];
}

}  // namespace meniscus
