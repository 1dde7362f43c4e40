// meniscus — per-particle anisotropy (Yu & Turk 2010 §4–5).
#include "field/anisotropy.hpp"

#include <tbb/parallel_for.h>

namespace meniscus {

std::vector<Vec3f> smooth_positions(const HashGrid& grid, float radius, float lambda) {
  const auto points = grid.sorted_points();
  const auto order = grid.order();
  std::vector<Vec3f> out(points.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 512), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      const Vec3f p = points[i];
      // Sums relative to p: no cancellation far from the origin.
      Vec3f sum{0, 0, 0};
      float weight = 0;
      grid.for_each_within(p, radius, [&](uint32_t j, float d2) {
        const float w = yu_turk_weight(std::sqrt(d2), radius);
        sum += (points[j] - p) * w;
        weight += w;
      });
      out[order[i]] = weight > 0 ? p + sum * (lambda / weight) : p;
    }
  });
  return out;
}

std::vector<Ellipsoid> yu_turk_ellipsoids(const HashGrid& grid, float radius, const AnisotropyConstants& constants) {
  const auto points = grid.sorted_points();
  const auto order = grid.order();
  std::vector<Ellipsoid> out(points.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 256), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      const Vec3f p = points[i];
      double w_sum = 0, m[3] = {0, 0, 0}, c[6] = {0, 0, 0, 0, 0, 0};
      int count = 0;
      grid.for_each_within(p, radius, [&](uint32_t j, float d2) {
        const double w = yu_turk_weight(std::sqrt(d2), radius);
        const Vec3f q = points[j] - p;
        w_sum += w;
        m[0] += w * q.x, m[1] += w * q.y, m[2] += w * q.z;
        c[0] += w * q.x * q.x, c[1] += w * q.x * q.y, c[2] += w * q.x * q.z;
        c[3] += w * q.y * q.y, c[4] += w * q.y * q.z, c[5] += w * q.z * q.z;
        ++count;
      });
      // Excluding the point itself from the count, as "neighbours".
      float cov[3][3] = {};
      if (w_sum > 0) {
        for (double& v : m) v /= w_sum;
        cov[0][0] = float(c[0] / w_sum - m[0] * m[0]), cov[0][1] = float(c[1] / w_sum - m[0] * m[1]);
        cov[0][2] = float(c[2] / w_sum - m[0] * m[2]), cov[1][1] = float(c[3] / w_sum - m[1] * m[1]);
        cov[1][2] = float(c[4] / w_sum - m[1] * m[2]), cov[2][2] = float(c[5] / w_sum - m[2] * m[2]);
        cov[1][0] = cov[0][1], cov[2][0] = cov[0][2], cov[2][1] = cov[1][2];
      }
      out[order[i]] = yu_turk_ellipsoid(cov, count - 1, constants);
    }
  });
  return out;
}

}  // namespace meniscus
