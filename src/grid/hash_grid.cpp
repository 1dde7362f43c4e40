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
  auto is_head = [&](std::size_t i) { return i == 0 || keyed[i].first != keyed[i - 1].first; };
  std::size_t cells = 0;
  for (std::size_t i = 0; i < n; ++i) cells += is_head(i) ? 1 : 0;
  cell_keys_.reserve(cells);
  cell_starts_.reserve(cells + 1);
  for (std::size_t i = 0; i < n; ++i) {
    if (is_head(i)) {
      cell_keys_.push_back(keyed[i].first);
      cell_starts_.push_back(uint32_t(i));
    }
  }
  cell_starts_.push_back(uint32_t(n));
  std::vector<std::pair<uint64_t, uint32_t>>().swap(keyed);
  index_.build(cell_keys_);
}

}  // namespace meniscus
