// meniscus — uniform hashed grid (Edespong 2010 §3.1).
#include "grid/hash_grid.hpp"

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <fmt/format.h>

#include "meniscus/errors.hpp"

namespace meniscus {

HashGrid::HashGrid(std::span<const Vec3f> points, float cell_size) : cell_size_(cell_size) {
  if (!(cell_size > 0) || !std::isfinite(cell_size))
    throw InvalidParameter(fmt::format("hash grid cell size must be positive, got {}", cell_size));
  const std::size_t n = points.size();
  if (n >= std::size_t(kNotFound)) throw ResourceError(fmt::format("{} points exceed the 2^32-1 limit", n));
  if (n == 0) return;

  // Check the coordinate range once, so that packing cannot overflow.
  Vec3f lo = points[0], hi = points[0];
  for (const Vec3f& p : points) lo = min(lo, p), hi = max(hi, p);
  const double limit = double(kMaxCoord) * cell_size;
  for (int a = 0; a < 3; ++a)
    if (std::abs(double(lo[a])) >= limit || std::abs(double(hi[a])) >= limit)
      throw ResourceError(fmt::format(
          "points reach {:g} on axis {}, more than {} cells of size {:g} from the origin; "
          "use a larger spacing or move the particles nearer the origin",
          std::max(std::abs(double(lo[a])), std::abs(double(hi[a]))), "xyz"[a], kMaxCoord, cell_size));
  cell_min_ = cell_of(lo);
  cell_max_ = cell_of(hi);

  std::vector<std::pair<uint64_t, uint32_t>> keyed(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      const Vec3i c = cell_of(points[i]);
      keyed[i] = {pack_coords(c.x, c.y, c.z), uint32_t(i)};
    }
  });
  tbb::parallel_sort(keyed.begin(), keyed.end());

  sorted_.resize(n);
  order_.resize(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      order_[i] = keyed[i].second;
      sorted_[i] = points[keyed[i].second];
    }
  });
  for (std::size_t i = 0; i < n; ++i) {
    if (i == 0 || keyed[i].first != keyed[i - 1].first) {
      cell_keys_.push_back(keyed[i].first);
      cell_starts_.push_back(uint32_t(i));
    }
  }
  cell_starts_.push_back(uint32_t(n));
  index_.build(cell_keys_);
}

HashGrid::Nearest HashGrid::nearest_rings(Vec3f p, int max_ring, float max_dist2) const {
  Nearest best;
  best.dist2 = max_dist2;
  const Vec3i c = cell_of(p);
  // p's offset inside its cell, to bound the distance to any other cell cheaply.
  const float cs = cell_size_;
  const Vec3f in_cell = p - Vec3f{float(c.x), float(c.y), float(c.z)} * cs;
  auto axis_gap = [cs](int d, float o) {
    return d > 0 ? float(d - 1) * cs + (cs - o) : (d < 0 ? float(-d - 1) * cs + o : 0.0f);
  };
  for (int r = 0; r <= max_ring; ++r) {
    for (int dz = -r; dz <= r; ++dz) {
      const float gz = axis_gap(dz, in_cell.z);
      if (gz * gz > best.dist2) continue;
      for (int dy = -r; dy <= r; ++dy) {
        const float gy = axis_gap(dy, in_cell.y);
        const float gyz = gy * gy + gz * gz;
        if (gyz > best.dist2) continue;
        const bool shell_yz = std::abs(dz) == r || std::abs(dy) == r;
        for (int dx = -r; dx <= r; dx += (shell_yz || r == 0) ? 1 : 2 * r) {
          const float gx = axis_gap(dx, in_cell.x);
          if (gx * gx + gyz > best.dist2) continue;  // the whole cell is farther than the best
          const auto [b, e] = cell_range({c.x + dx, c.y + dy, c.z + dz});
          for (uint32_t i = b; i < e; ++i) {
            const float d2 = length2(sorted_[i] - p);
            if (d2 <= best.dist2 && (d2 < best.dist2 || i < best.index)) best = {i, d2};
          }
        }
      }
    }
    // Every point in ring r+1 is at least r cell sizes away from p.
    const float reach = float(r) * cs;
    if (best.dist2 <= reach * reach) break;
  }
  if (best.index == kNotFound) best.dist2 = INFINITY;
  return best;
}

namespace {
bool finite(Vec3f p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }
}  // namespace

HashGrid::Nearest HashGrid::nearest(Vec3f p, float max_radius) const {
  if (sorted_.empty() || !finite(p)) return {};
  const int rings = int(std::ceil(max_radius / cell_size_)) + 1;
  return nearest_rings(p, rings, max_radius * max_radius);
}

HashGrid::Nearest HashGrid::nearest(Vec3f p) const {
  if (sorted_.empty() || !finite(p)) return {};
  const Vec3i c = cell_of(p);
  int rings = 0;
  for (int a = 0; a < 3; ++a)
    rings = std::max({rings, std::abs(c[a] - cell_min_[a]), std::abs(c[a] - cell_max_[a])});
  return nearest_rings(p, rings, INFINITY);
}

}  // namespace meniscus
