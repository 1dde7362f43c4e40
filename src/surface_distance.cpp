// meniscus — point-to-surface distance (DESIGN §5, frame-to-frame flicker): closest points on
// triangles (Ericson 2005 §5.1.5) found through a uniform grid of the triangles.
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "grid/key_index.hpp"
#include "meniscus/quality.hpp"
#include "mesh/closest_point_impl.hpp"

namespace meniscus {

SurfaceDistanceReport distance_to_surface(std::span<const Vec3f> points, const TriangleMesh& surface) {
  SurfaceDistanceReport report;
  const auto& v = surface.vertices;
  const auto& tris = surface.triangles;
  if (points.empty() || tris.empty()) return report;
  Vec3f lo = v[tris[0][0]], hi = lo;
  double edge_sum = 0;
  for (const Triangle& t : tris)
    for (int k = 0; k < 3; ++k) {
      lo = min(lo, v[t[k]]), hi = max(hi, v[t[k]]);
      edge_sum += length(v[t[k]] - v[t[(k + 1) % 3]]);
    }
  // Cells of about two mean edges, but never so many that the coordinates overflow the keys.
  const float diag = length(hi - lo);
  const float cell = std::max({float(2 * edge_sum / (3.0 * double(tris.size()))), diag / float(kMaxCoord / 2), 1e-30f});
  const auto coord = [&](Vec3f p) {
    return Vec3i{int32_t(std::floor((p.x - lo.x) / cell)), int32_t(std::floor((p.y - lo.y) / cell)),
                 int32_t(std::floor((p.z - lo.z) / cell))};
  };
  // (cell key, triangle) pairs of every cell each triangle's bounding box touches.
  std::vector<std::pair<uint64_t, uint32_t>> entries;
  for (uint32_t ti = 0; ti < tris.size(); ++ti) {
    const Triangle& t = tris[ti];
    const Vec3i a = coord(min(min(v[t[0]], v[t[1]]), v[t[2]])), b = coord(max(max(v[t[0]], v[t[1]]), v[t[2]]));
    for (int32_t z = a.z; z <= b.z; ++z)
      for (int32_t y = a.y; y <= b.y; ++y)
        for (int32_t x = a.x; x <= b.x; ++x) entries.emplace_back(pack_coords(x, y, z), ti);
  }
  tbb::parallel_sort(entries.begin(), entries.end());
  std::unordered_map<uint64_t, std::pair<uint32_t, uint32_t>> cells;
  for (uint32_t i = 0; i < entries.size();) {
    uint32_t j = i;
    while (j < entries.size() && entries[j].first == entries[i].first) ++j;
    cells.emplace(entries[i].first, std::pair{i, j});
    i = j;
  }
  const Vec3i cmax = coord(hi);

  std::vector<float> dist(points.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 256), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      const Vec3f p = points[i];
      // Clamp the start cell into the grid; the ring bound uses the distance to the grid's box.
      const Vec3i c0 = coord(p);
      const Vec3i c{std::clamp(c0.x, 0, cmax.x), std::clamp(c0.y, 0, cmax.y), std::clamp(c0.z, 0, cmax.z)};
      const int max_ring = std::max({c.x, cmax.x - c.x, c.y, cmax.y - c.y, c.z, cmax.z - c.z});
      float best2 = INFINITY;
      for (int ring = 0; ring <= max_ring; ++ring) {
        for (int32_t z = c.z - ring; z <= c.z + ring; ++z)
          for (int32_t y = c.y - ring; y <= c.y + ring; ++y)
            for (int32_t x = c.x - ring; x <= c.x + ring; ++x) {
              if (std::max({std::abs(x - c.x), std::abs(y - c.y), std::abs(z - c.z)}) != ring) continue;
              if (x < 0 || y < 0 || z < 0 || x > cmax.x || y > cmax.y || z > cmax.z) continue;
              const auto it = cells.find(pack_coords(x, y, z));
              if (it == cells.end()) continue;
              for (uint32_t e = it->second.first; e < it->second.second; ++e) {
                const Triangle& t = tris[entries[e].second];
                best2 = std::min(best2, length2(closest_point_on_triangle(p, v[t[0]], v[t[1]], v[t[2]]) - p));
              }
            }
        // Cells outside ring `ring` are at least ring·cell from p (p lies in its start cell, or
        // beyond it on the side away from the grid when the start cell was clamped).
        const float reach = float(ring) * cell;
        if (best2 <= reach * reach) break;
      }
      dist[i] = std::sqrt(best2);
    }
  });
  report.count = dist.size();
  double sum = 0;
  for (float d : dist) sum += d, report.max = std::max(report.max, double(d));
  report.mean = sum / double(dist.size());
  auto q = dist.begin() + std::ptrdiff_t(double(dist.size() - 1) * 0.95);
  std::nth_element(dist.begin(), q, dist.end());
  report.p95 = *q;
  return report;
}

}  // namespace meniscus
