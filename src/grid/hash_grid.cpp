// meniscus — uniform hashed grid (Edespong 2010 §3.1).
#include "grid/hash_grid.hpp"

#include <algorithm>
#include <bit>
#include <fmt/format.h>

#include "common/for_each.hpp"
#include "common/primitives.hpp"
#include "common/radix_sort.hpp"
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

  // Each point keyed by its cell's index in the cells' box, (z, y, x) row-major like
  // pack_coords' order, and sorted by a stable radix sort on the few bits that index needs (ties
  // keep the point order): a few bits, not a 64-bit key, to sort; the cells' heads are listed in
  // parallel too.
  const Vec3i first = cell_of(lo), last = cell_of(hi);  // cell_of is monotone on each axis
  const uint64_t nx = uint64_t(last.x - first.x) + 1, ny = uint64_t(last.y - first.y) + 1;
  std::vector<std::pair<uint64_t, uint32_t>> keyed(n);
  for_each_index(n, 4096, [&](std::size_t i) {
    const Vec3i c = cell_of(points[i]);
    keyed[i] = {(uint64_t(c.z - first.z) * ny + uint64_t(c.y - first.y)) * nx + uint64_t(c.x - first.x), uint32_t(i)};
  });
  const uint64_t nz = uint64_t(last.z - first.z) + 1;
  radix_sort_by(keyed, [](const std::pair<uint64_t, uint32_t>& k) { return k.first; }, 0,
                std::max(1, int(std::bit_width(nx * ny * nz - 1))));

  sorted_.resize(n);
  order_.resize(n);
  for_each_index(n, 4096, [&](std::size_t i) {
    order_[i] = keyed[i].second;
    sorted_[i] = points[keyed[i].second];
  });
  // The cells' first points, found per chunk in parallel and listed in order.
  auto is_head = [&](std::size_t i) { return i == 0 || keyed[i].first != keyed[i - 1].first; };
  std::vector<std::size_t> offsets;
  const std::size_t cells = chunk_offsets(n, is_head, offsets);
  cell_keys_.resize(cells);
  cell_starts_.resize(cells + 1);
  for_each_set(n, is_head, offsets, [&](std::size_t i, std::size_t k) {
    const uint64_t d = keyed[i].first;
    cell_keys_[k] = pack_coords(first.x + int32_t(d % nx), first.y + int32_t(d / nx % ny), first.z + int32_t(d / nx / ny));
    cell_starts_[k] = uint32_t(i);
  });
  cell_starts_[cells] = uint32_t(n);
  std::vector<std::pair<uint64_t, uint32_t>>().swap(keyed);
  index_.build(cell_keys_);
}

}  // namespace meniscus
