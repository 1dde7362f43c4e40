// meniscus — the hash grid as arrays of either backend (BufferOf<B, T>): the form the stages
// written once over the backend tag build and read, with GridView, the Grid of hash_grid_impl.hpp
// over its pointers (binary search over the sorted cell keys). The CPU's own HashGrid
// (hash_grid.hpp) answers the same queries with its KeyIndex.
#pragma once

#include <cstdint>

#include "common/buffer.hpp"
#include "grid/hash_grid_impl.hpp"
#include "grid/key_index.hpp"
#include "meniscus/vec.hpp"

namespace meniscus {

/// Index of `key` in sorted keys[0, n), or kNotFound (binary search).
MENISCUS_HD inline uint32_t find_sorted(const uint64_t* keys, uint32_t n, uint64_t key) {
  uint32_t lo = 0, hi = n;
  while (lo < hi) {
    const uint32_t mid = lo + (hi - lo) / 2;
    if (keys[mid] < key) lo = mid + 1; else hi = mid;
  }
  return lo < n && keys[lo] == key ? lo : kNotFound;
}

struct CellRange {
  uint32_t first = 0, second = 0;
};

/// The hash grid over plain pointers (the Grid of hash_grid_impl.hpp).
struct GridView {
  const Vec3f* sorted = nullptr;
  const uint64_t* keys = nullptr;
  const uint32_t* starts = nullptr;
  uint32_t cells = 0, count = 0;
  float cs = 1;
  Vec3i lo{}, hi{-1, -1, -1};

  MENISCUS_HD float cell_size() const { return cs; }
  MENISCUS_HD Vec3i cell_min() const { return lo; }
  MENISCUS_HD Vec3i cell_max() const { return hi; }
  MENISCUS_HD uint32_t size() const { return count; }
  MENISCUS_HD Vec3f point(uint32_t i) const { return sorted[i]; }
  MENISCUS_HD const Vec3f* points() const { return sorted; }
  MENISCUS_HD CellRange cell_range(Vec3i c) const {
    if (c.x < lo.x || c.y < lo.y || c.z < lo.z || c.x > hi.x || c.y > hi.y || c.z > hi.z) return {};
    const uint32_t i = find_sorted(keys, cells, pack_coords(c.x, c.y, c.z));
    if (i == kNotFound) return {};
    return {starts[i], starts[i + 1]};
  }
};

/// The hash grid's arrays on backend B: the points in cell order, their original indices, the
/// occupied cells' sorted keys and their first points (cells + 1 entries).
template <class B>
struct GridBuffers {
  BufferOf<B, Vec3f> sorted;
  BufferOf<B, uint32_t> order;
  BufferOf<B, uint64_t> keys;
  BufferOf<B, uint32_t> starts;
  uint32_t cells = 0, count = 0;
  float cell_size = 1;
  Vec3i lo{}, hi{-1, -1, -1};
  GridView view() const { return {sorted.data(), keys.data(), starts.data(), cells, count, cell_size, lo, hi}; }
};

}  // namespace meniscus
