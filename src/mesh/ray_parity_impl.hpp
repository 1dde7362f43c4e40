// meniscus — the inside test by ray parity (TriangleBvh::inside, voids.cpp's blob test),
// shared by the CPU and CUDA backends: a ray from the point along +x, nudged off the lattice the
// extraction's vertices may share with the point, crosses a closed surface an odd number of times
// when the point is inside it.
#pragma once

#include <cmath>
#include <cstddef>

#include "grid/hash_grid_impl.hpp"
#include "meniscus/vec.hpp"

namespace meniscus {

/// The nudge scale of a surface with `triangles` triangles and bounds [lo, hi]: its y-z extent
/// over a grid of about one triangle per cell, i.e. about a triangle's size.
struct RayParityFrame {
  Vec3f lo{}, hi{};
  int res = 1;
  double sy = 1, sz = 1;
};

MENISCUS_HD inline RayParityFrame ray_parity_frame(Vec3f lo, Vec3f hi, std::size_t triangles) {
  RayParityFrame f;
  f.lo = lo;
  f.hi = hi;
  const int r = int(std::sqrt(double(triangles)));
  f.res = r < 1 ? 1 : (r > 2048 ? 2048 : r);
  const double ey = double(hi.y - lo.y), ez = double(hi.z - lo.z);
  f.sy = (ey > 1e-30 ? ey : 1e-30) / f.res;
  f.sz = (ez > 1e-30 ? ez : 1e-30) / f.res;
  return f;
}

/// The ray origin of point p (the nudged y and z); false when the ray cannot meet the surface
/// (the point is outside its bounds): the point is outside.
MENISCUS_HD inline bool ray_parity_origin(const RayParityFrame& f, Vec3f p, double* px, double* py, double* pz) {
  *py = double(p.y) + 1.234567e-7 * f.sy;
  *pz = double(p.z) + 2.345671e-7 * f.sz;
  *px = p.x;
  return !(*py < f.lo.y || *py > f.hi.y || *pz < f.lo.z || *pz > f.hi.z || *px > f.hi.x);
}

/// Whether the ray from (px, py, pz) along +x crosses triangle abc (barycentrics of (py, pz) in
/// the triangle's y-z projection, then the crossing's x beyond px).
MENISCUS_HD inline bool ray_crosses(Vec3f a, Vec3f b, Vec3f c, double px, double py, double pz) {
  const double d = (double(b.y) - a.y) * (double(c.z) - a.z) - (double(c.y) - a.y) * (double(b.z) - a.z);
  if (d == 0) return false;
  const double u = ((py - a.y) * (double(c.z) - a.z) - (double(c.y) - a.y) * (pz - a.z)) / d;
  const double v = ((double(b.y) - a.y) * (pz - a.z) - (py - a.y) * (double(b.z) - a.z)) / d;
  if (u < 0 || v < 0 || u + v > 1) return false;
  const double x = a.x + u * (double(b.x) - a.x) + v * (double(c.x) - a.x);
  return x > px;
}

/// How many points of the grid lie inside the closed surface made of the `count` triangles
/// ids[0, count) of `tris` (3 vertex indices each, into `x`), counting up to `limit`. Only the
/// points in the surface's bounding box are tested, each against every triangle.
template <class Grid>
MENISCUS_HD uint32_t count_enclosed_points(const Grid& g, const uint32_t* tris, const uint32_t* ids, uint32_t count,
                                           const Vec3f* x, uint32_t limit) {
  if (count == 0 || limit == 0) return 0;
  Vec3f lo = x[tris[3 * std::size_t(ids[0])]], hi = lo;
  for (uint32_t k = 0; k < count; ++k)
    for (int j = 0; j < 3; ++j) {
      const Vec3f v = x[tris[3 * std::size_t(ids[k]) + j]];
      lo = min(lo, v), hi = max(hi, v);
    }
  const RayParityFrame frame = ray_parity_frame(lo, hi, count);
  uint32_t inside = 0;
  grid_for_each_in_cells_of_box(g, lo, hi, [&](uint32_t i) {
    const Vec3f p = g.point(i);
    if (!(p.x >= lo.x && p.y >= lo.y && p.z >= lo.z && p.x <= hi.x && p.y <= hi.y && p.z <= hi.z)) return true;
    double px, py, pz;
    if (!ray_parity_origin(frame, p, &px, &py, &pz)) return true;
    int crossings = 0;
    for (uint32_t k = 0; k < count; ++k) {
      const uint32_t* t = tris + 3 * std::size_t(ids[k]);
      crossings += ray_crosses(x[t[0]], x[t[1]], x[t[2]], px, py, pz);
    }
    inside += crossings % 2 == 1;
    return inside < limit;  // stop at the limit
  });
  return inside;
}

/// Whether any point of the grid lies inside the closed surface (count_enclosed_points): the
/// blob test of remove_unsupported_blobs, on both backends (a blob has a few dozen triangles).
template <class Grid>
MENISCUS_HD bool encloses_a_point(const Grid& g, const uint32_t* tris, const uint32_t* ids, uint32_t count,
                                  const Vec3f* x) {
  return count_enclosed_points(g, tris, ids, count, x, 1) > 0;
}

}  // namespace meniscus
