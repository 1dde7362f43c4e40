// meniscus — attribute transfer by a smooth kernel-weighted mean (Zhu & Bridson 2005 weights).
#include "transfer/attribute_transfer.hpp"

#include <tbb/parallel_for.h>

#include <vector>

namespace meniscus {

Attribute transfer_attribute(const Attribute& attribute, const HashGrid& grid, std::span<const Vec3f> vertices,
                             float radius) {
  Attribute out;
  out.name = attribute.name;
  out.components = attribute.components;
  out.integer = false;
  const std::size_t nc = std::size_t(attribute.components);
  out.values.assign(vertices.size() * nc, 0.0f);
  const auto order = grid.order();
  const float inv_r2 = 1.0f / (radius * radius);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, vertices.size(), 512), [&](const auto& r) {
    std::vector<double> acc(nc);
    for (std::size_t v = r.begin(); v != r.end(); ++v) {
      std::fill(acc.begin(), acc.end(), 0.0);
      double wsum = 0;
      grid.for_each_within(vertices[v], radius, [&](uint32_t i, float d2) {
        const double q = 1.0 - double(d2 * inv_r2);
        const double w = q * q * q;
        if (w <= 0) return;
        const float* src = attribute.values.data() + std::size_t(order[i]) * nc;
        for (std::size_t c = 0; c < nc; ++c) acc[c] += w * src[c];
        wsum += w;
      });
      float* dst = out.values.data() + v * nc;
      if (wsum > 0) {
        for (std::size_t c = 0; c < nc; ++c) dst[c] = float(acc[c] / wsum);
      } else {
        const HashGrid::Nearest n = grid.nearest(vertices[v]);
        if (n.index == kNotFound) continue;
        const float* src = attribute.values.data() + std::size_t(order[n.index]) * nc;
        for (std::size_t c = 0; c < nc; ++c) dst[c] = src[c];
      }
    }
  });
  return out;
}

}  // namespace meniscus
