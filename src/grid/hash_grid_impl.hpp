// meniscus — the hash-grid queries (Edespong 2010 §3.1) written once for the CPU HashGrid and the
// CUDA backend's device view: any `Grid` with cell_size(), cell_min(), cell_max(), cell_range(Vec3i)
// (a pair-like {first, second} of sorted indices, empty when unoccupied) and point(i). The float
// operations are the same on both backends, and ties go to the lower sorted index, so both
// find the same particle.
#pragma once

#include <cmath>
#include <cstdint>
#include <type_traits>

#include "grid/key_index.hpp"
#include "meniscus/vec.hpp"

namespace meniscus {

/// The result of a nearest-point query: index into the grid's sorted points (kNotFound: none).
struct NearestPoint {
  uint32_t index = kNotFound;
  float dist2 = INFINITY;
};

/// The cell of position p in a grid of cells of edge `cell_size`.
MENISCUS_HD inline Vec3i grid_cell_of(Vec3f p, float cell_size) {
  const float inv = 1.0f / cell_size;
  return {int32_t(std::floor(p.x * inv)), int32_t(std::floor(p.y * inv)), int32_t(std::floor(p.z * inv))};
}

/// Finite in every coordinate (x − x is NaN for ±∞ and NaN; no <cmath> classification needed on
/// the device).
MENISCUS_HD inline bool finite_point(Vec3f p) { return p.x - p.x == 0.0f && p.y - p.y == 0.0f && p.z - p.z == 0.0f; }

/// Calls f(sorted_index) for every point of the cells that touch the box [lo, hi] (a superset of
/// the points inside it), cell by cell in z, y, x order and by sorted index within a cell — the
/// order the fields' scatters and gathers share. An f returning bool stops the walk with false.
template <class Grid, class F>
MENISCUS_HD void grid_for_each_in_cells_of_box(const Grid& g, Vec3f lo, Vec3f hi, F&& f) {
  const Vec3i clo = grid_cell_of(lo, g.cell_size()), chi = grid_cell_of(hi, g.cell_size());
  for (int32_t cz = clo.z; cz <= chi.z; ++cz)
    for (int32_t cy = clo.y; cy <= chi.y; ++cy)
      for (int32_t cx = clo.x; cx <= chi.x; ++cx) {
        const auto range = g.cell_range(Vec3i{cx, cy, cz});
        for (uint32_t i = range.first; i < range.second; ++i) {
          if constexpr (std::is_same_v<decltype(f(i)), bool>) {
            if (!f(i)) return;
          } else {
            f(i);
          }
        }
      }
}

/// Calls f(sorted_index, dist2) for every point within distance r of p, cells in z, y, x order.
template <class Grid, class F>
MENISCUS_HD void grid_for_each_within(const Grid& g, Vec3f p, float r, F&& f) {
  const float r2 = r * r;
  const Vec3i lo = grid_cell_of(p - Vec3f{r, r, r}, g.cell_size()), hi = grid_cell_of(p + Vec3f{r, r, r}, g.cell_size());
  const Vec3i cmin = g.cell_min(), cmax = g.cell_max();
  for (int32_t z = lo.z > cmin.z ? lo.z : cmin.z; z <= (hi.z < cmax.z ? hi.z : cmax.z); ++z)
    for (int32_t y = lo.y > cmin.y ? lo.y : cmin.y; y <= (hi.y < cmax.y ? hi.y : cmax.y); ++y)
      for (int32_t x = lo.x > cmin.x ? lo.x : cmin.x; x <= (hi.x < cmax.x ? hi.x : cmax.x); ++x) {
        const auto range = g.cell_range(Vec3i{x, y, z});
        for (uint32_t i = range.first; i < range.second; ++i) {
          const float d2 = length2(g.point(i) - p);
          if (d2 <= r2) f(i, d2);
        }
      }
}

/// The nearest point to p among the cells within `max_ring` rings of p's cell and within
/// sqrt(max_dist2), searching ring by ring and skipping cells farther than the best so far.
template <class Grid>
MENISCUS_HD NearestPoint grid_nearest_rings(const Grid& g, Vec3f p, int max_ring, float max_dist2) {
  NearestPoint best;
  best.dist2 = max_dist2;
  const float cs = g.cell_size();
  const Vec3i c = grid_cell_of(p, cs);
  // p's offset inside its cell, to bound the distance to any other cell cheaply.
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
        const bool shell_yz = dz == r || dz == -r || dy == r || dy == -r;
        for (int dx = -r; dx <= r; dx += (shell_yz || r == 0) ? 1 : 2 * r) {
          const float gx = axis_gap(dx, in_cell.x);
          if (gx * gx + gyz > best.dist2) continue;  // the whole cell is farther than the best
          const auto range = g.cell_range(Vec3i{c.x + dx, c.y + dy, c.z + dz});
          for (uint32_t i = range.first; i < range.second; ++i) {
            const float d2 = length2(g.point(i) - p);
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

/// The exact nearest point within max_radius of p (index kNotFound when there is none).
template <class Grid>
MENISCUS_HD NearestPoint grid_nearest_within(const Grid& g, Vec3f p, float max_radius) {
  if (g.size() == 0 || !finite_point(p)) return {};
  const int rings = int(std::ceil(max_radius / g.cell_size())) + 1;
  return grid_nearest_rings(g, p, rings, max_radius * max_radius);
}

/// The exact nearest point, however far (kNotFound only for an empty grid or a non-finite p).
template <class Grid>
MENISCUS_HD NearestPoint grid_nearest(const Grid& g, Vec3f p) {
  if (g.size() == 0 || !finite_point(p)) return {};
  const Vec3i c = grid_cell_of(p, g.cell_size());
  const Vec3i cmin = g.cell_min(), cmax = g.cell_max();
  int rings = 0;
  for (int a = 0; a < 3; ++a) {
    const int d0 = c[a] - cmin[a], d1 = c[a] - cmax[a];
    const int m = (d0 < 0 ? -d0 : d0) > (d1 < 0 ? -d1 : d1) ? (d0 < 0 ? -d0 : d0) : (d1 < 0 ? -d1 : d1);
    if (m > rings) rings = m;
  }
  return grid_nearest_rings(g, p, rings, INFINITY);
}

}  // namespace meniscus
