// meniscus — coincident points (grid/coincident.hpp).
#include "grid/coincident.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <numeric>

#include "common/for_each.hpp"

namespace meniscus {

namespace {

/// A point's cell of the fine lattice (tolerance > 0), or its coordinates (0; + 0.0 makes −0 and
/// +0 one key). Doubles hold both exactly: |x| / tolerance stays far below 2^53 for the
/// coordinates a grid accepts.
using FineKey = std::array<double, 3>;
FineKey fine_key(Vec3f p, double tolerance) {
  if (tolerance > 0)
    return {std::floor(double(p.x) / tolerance), std::floor(double(p.y) / tolerance),
            std::floor(double(p.z) / tolerance)};
  return {double(p.x) + 0.0, double(p.y) + 0.0, double(p.z) + 0.0};
}

/// Cells of at most this many points are grouped pairwise, larger ones by sorting.
constexpr uint32_t kPairwise = 16;

}  // namespace

CoincidentPoints coincident_points(const HashGrid& grid, double tolerance) {
  CoincidentPoints out;
  const std::size_t n = grid.size();
  const auto starts = grid.cell_starts();
  const auto points = grid.sorted_points();
  const std::size_t cells = grid.cell_keys().size();
  // Per sorted point, the sorted index of its group's first. Within a cell the sorted order is
  // the original order (the grid's sort is stable), so the lowest sorted index of a group is its
  // lowest original index.
  std::vector<uint32_t> head(n);
  std::atomic<std::size_t> copies{0};
  for_each_index(cells, 64, [&](std::size_t c) {
    const uint32_t b = starts[c], e = starts[c + 1];
    head[b] = b;
    if (e - b == 1) return;
    std::size_t found = 0;
    if (e - b <= kPairwise) {  // pairwise: each point against the firsts before it
      std::array<FineKey, kPairwise> keys;
      for (uint32_t i = b; i < e; ++i) keys[i - b] = fine_key(points[i], tolerance);
      for (uint32_t i = b + 1; i < e; ++i) {
        head[i] = i;
        for (uint32_t j = b; j < i; ++j)
          if (head[j] == j && keys[j - b] == keys[i - b]) {
            head[i] = j;
            ++found;
            break;
          }
      }
    } else {  // sorted by key, then by index: each run's first is its group's first
      std::vector<FineKey> keys(e - b);
      for (uint32_t i = b; i < e; ++i) keys[i - b] = fine_key(points[i], tolerance);
      std::vector<uint32_t> local(e - b);
      std::iota(local.begin(), local.end(), 0u);
      std::sort(local.begin(), local.end(), [&](uint32_t x, uint32_t y) {
        return keys[x] != keys[y] ? keys[x] < keys[y] : x < y;
      });
      for (std::size_t k = 0; k < local.size(); ++k) {
        const bool starts_run = k == 0 || keys[local[k]] != keys[local[k - 1]];
        head[b + local[k]] = starts_run ? b + local[k] : head[b + local[k - 1]];
        found += !starts_run;
      }
    }
    if (found > 0) copies.fetch_add(found, std::memory_order_relaxed);
  });
  out.copies = copies.load();
  if (out.copies == 0) return out;
  const auto order = grid.order();
  out.first.resize(n);
  for_each_index(n, 4096, [&](std::size_t i) { out.first[order[i]] = order[head[i]]; });
  return out;
}

GroupHeads group_heads(const CoincidentPoints& groups, std::size_t n) {
  GroupHeads h;
  if (groups.first.empty()) {
    h.index.resize(n);
    std::iota(h.index.begin(), h.index.end(), 0u);
    h.count.assign(n, 1);
    return h;
  }
  // A group's first has the lowest index, so it is met before its copies.
  std::vector<uint32_t> slot(n);
  h.index.reserve(n - groups.copies);
  h.count.reserve(n - groups.copies);
  for (std::size_t i = 0; i < n; ++i) {
    const uint32_t f = groups.first[i];
    if (f == i) {
      slot[i] = uint32_t(h.index.size());
      h.index.push_back(uint32_t(i));
      h.count.push_back(1);
    } else {
      ++h.count[slot[f]];
    }
  }
  return h;
}

}  // namespace meniscus
