// meniscus — the uniform hashed grid (Edespong 2010 §3.1; Green 2008), built once for either
// backend over its primitives: cell keys, a stable sort of (key, index) — ties keep the point
// order, as the CPU's HashGrid sorts — and one [start, end) range per occupied cell; with the
// per-particle passes that follow it (the points' bounds, per-particle data into the grid's order).
// The backend is a tag (Host or cuda::Device) whose for_each_index, sort_pairs and exclusive_sum
// are found by argument-dependent lookup; a file that instantiates these for the device includes
// cuda/primitives.hpp first. The CPU pipeline builds its own HashGrid (hash_grid.cpp: a compact
// key of the cells' box, a KeyIndex for its queries); tests/unit/test_hash_grid.cpp holds it to
// build_grid(Host{}, …) bit for bit.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "common/buffer.hpp"
#include "common/primitives.hpp"
#include "grid/grid_buffers.hpp"
#include "grid/hash_grid_impl.hpp"
#include "grid/key_index.hpp"
#include "meniscus/vec.hpp"

namespace meniscus {

namespace grid_build {

/// keys[i]: the cell key of point i; index[i] = i (the sort's values).
struct CellKeys {
  const Vec3f* points;
  float cell_size;
  uint64_t* keys;
  uint32_t* index;
  MENISCUS_HD void operator()(uint64_t i) const {
    const Vec3i c = grid_cell_of(points[i], cell_size);
    keys[i] = pack_coords(c.x, c.y, c.z);
    index[i] = uint32_t(i);
  }
};

/// sorted[i] = points[order[i]]; heads[i] = 1 where a cell's run of the sorted keys begins.
struct GatherPoints {
  const Vec3f* points;
  const uint32_t* order;
  const uint64_t* keys;
  Vec3f* sorted;
  uint32_t* heads;
  MENISCUS_HD void operator()(uint64_t i) const {
    sorted[i] = points[order[i]];
    heads[i] = (i == 0 || keys[i] != keys[i - 1]) ? 1u : 0u;
  }
};

/// Each cell's key and first point, at its rank among the heads (cell_of_head, n + 1 entries);
/// the last point also closes the last cell (starts[cells] = n).
struct CellRanges {
  const uint64_t* keys;
  const uint32_t* heads;
  const uint32_t* cell_of_head;
  uint64_t n;
  uint64_t* cell_keys;
  uint32_t* starts;
  MENISCUS_HD void operator()(uint64_t i) const {
    if (heads[i]) {
      cell_keys[cell_of_head[i]] = keys[i];
      starts[cell_of_head[i]] = uint32_t(i);
    }
    if (i + 1 == n) starts[cell_of_head[n]] = uint32_t(n);
  }
};

/// The lower and upper corners of a set of points.
struct Bounds {
  Vec3f lo, hi;
};

/// A point's bounds (itself), for reduce_index.
struct PointBounds {
  const Vec3f* points;
  MENISCUS_HD Bounds operator()(uint64_t i) const { return {points[i], points[i]}; }
};

/// Joins two bounds: per axis the smaller lower and the larger upper corner (exact, whatever the
/// order; the sign of a zero bound may depend on it, which puts it in the same cell either way).
struct JoinBounds {
  MENISCUS_HD Bounds operator()(const Bounds& a, const Bounds& b) const {
    Bounds r;
    for (int ax = 0; ax < 3; ++ax) {
      r.lo[ax] = b.lo[ax] < a.lo[ax] ? b.lo[ax] : a.lo[ax];
      r.hi[ax] = b.hi[ax] > a.hi[ax] ? b.hi[ax] : a.hi[ax];
    }
    return r;
  }
};

/// out[i] = values[order[i]].
template <class T>
struct Gather {
  const T* values;
  const uint32_t* order;
  T* out;
  MENISCUS_HD void operator()(uint64_t i) const { out[i] = values[order[i]]; }
};

}  // namespace grid_build

/// The hash grid of `count` points (on backend B) with cells of edge `cell_size` > 0; `lo`/`hi`:
/// the points' cell range (checked by the caller against the key range, kMaxCoord).
template <class B>
GridBuffers<B> build_grid(B b, const Vec3f* points, uint32_t count, float cell_size, Vec3i lo, Vec3i hi) {
  GridBuffers<B> g;
  g.count = count;
  g.cell_size = cell_size;
  g.lo = lo;
  g.hi = hi;
  if (count == 0) return g;
  BufferOf<B, uint64_t> keys(count);
  g.order.resize(count);
  for_each_index(b, count, grid_build::CellKeys{points, cell_size, keys.data(), g.order.data()});
  sort_pairs(b, keys.data(), g.order.data(), count, 0, 63);
  g.sorted.resize(count);
  BufferOf<B, uint32_t> heads(count), cell_of_head(std::size_t(count) + 1);
  for_each_index(b, count,
                 grid_build::GatherPoints{points, g.order.data(), keys.data(), g.sorted.data(), heads.data()});
  exclusive_sum(b, heads.data(), cell_of_head.data(), count);
  g.cells = cell_of_head.get(count);
  g.keys.resize(g.cells);
  g.starts.resize(std::size_t(g.cells) + 1);
  for_each_index(b, count,
                 grid_build::CellRanges{keys.data(), heads.data(), cell_of_head.data(), count, g.keys.data(),
                                        g.starts.data()});
  return g;
}

/// The bounds of `count` points (on backend B; count > 0), exact (min and max).
template <class B>
void point_bounds(B b, const Vec3f* points, uint32_t count, Vec3f* lo, Vec3f* hi) {
  const grid_build::Bounds none{Vec3f{INFINITY, INFINITY, INFINITY}, Vec3f{-INFINITY, -INFINITY, -INFINITY}};
  const grid_build::Bounds r =
      reduce_index(b, count, none, grid_build::PointBounds{points}, grid_build::JoinBounds{});
  *lo = r.lo;
  *hi = r.hi;
}

/// out[i] = values[order[i]]: per-particle data from the original order into the grid's.
template <class T, class B>
BufferOf<B, T> to_sorted_order(B b, const GridBuffers<B>& grid, const T* values) {
  BufferOf<B, T> out(grid.count);
  for_each_index(b, grid.count, grid_build::Gather<T>{values, grid.order.data(), out.data()});
  return out;
}

}  // namespace meniscus
