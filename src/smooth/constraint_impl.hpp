// meniscus — per-vertex constraint projection (Williams 2008 §4.2), shared by the CPU and CUDA
// backends: a vertex must lie between r_inner and r_outer from its nearest particle.
#pragma once

#include <cstdint>

#include "grid/hash_grid_impl.hpp"
#include "field/eigen_sym3_impl.hpp"
#include "field/kernel_impl.hpp"
#include "meniscus/vec.hpp"

namespace meniscus {

/// Moves x radially from the particle p onto the shell r_inner ≤ |x − p| ≤ r_outer.
/// A vertex exactly on the particle is pushed along +z (any direction satisfies the constraint).
MENISCUS_HD inline Vec3f project_to_shell(Vec3f x, Vec3f p, float r_inner, float r_outer) {
  const Vec3f d = x - p;
  const float l2 = length2(d);
  if (l2 < r_inner * r_inner) {
    if (l2 == 0.0f) return p + Vec3f{0, 0, r_inner};
    return p + d * (r_inner / std::sqrt(l2));
  }
  if (l2 > r_outer * r_outer) return p + d * (r_outer / std::sqrt(l2));
  return x;
}

/// The full projection of one vertex (Williams 2008 §4.2), shared by both backends: repeatedly
/// project onto the shell of the current nearest particle (`nearest(y)` → NearestPoint) until the
/// vertex lies in [r_inner, r_outer] of its nearest particle; in the rare case where the shells of
/// two particles undo each other, search rays from the first nearest particle for a point that
/// `clear(y)` (no particle within r_inner of y) accepts. `points` are the grid's sorted points.
template <class NearestFn, class ClearFn>
MENISCUS_HD Vec3f project_with(Vec3f x, float r_inner, float r_outer, const Vec3f* points, NearestFn&& nearest,
                               ClearFn&& clear) {
  // Accept within a few ulps of the shell, and project a hair inside it: a point projected
  // exactly onto the shell measures up to an ulp outside half the time, which would otherwise
  // send it round again.
  const float lo2 = r_inner * r_inner * (1.0f - 4e-6f), hi2 = r_outer * r_outer * (1.0f + 4e-6f);
  const float target_in = r_inner * (1.0f + 1e-6f), target_out = r_outer * (1.0f - 1e-6f);
  // Each round fixes the violation against the current nearest particle; a second round is
  // needed only where the inner shells of two particles overlap.
  uint32_t first = kNotFound;
  for (int round = 0; round < 4; ++round) {
    const NearestPoint n = nearest(x);
    if (n.index == kNotFound) return x;
    if (n.dist2 >= lo2 && n.dist2 <= hi2) return x;
    if (first == kNotFound) first = n.index;
    x = project_to_shell(x, points[n.index], target_in, target_out);
  }
  const NearestPoint n = nearest(x);
  if (n.dist2 >= lo2 && n.dist2 <= hi2) return x;
  // Rare: projections against different particles undo each other (a vertex squeezed between
  // the inner shell of one particle and the outer shell of another). Search the ray from the
  // first nearest particle through x, from the outer shell inwards, for a point clear of every
  // inner shell; on it the first particle is within r_outer, so the constraint holds.
  const Vec3f p = points[first];
  const Vec3f u = x == p ? Vec3f{0, 0, 1} : normalized(x - p);
  constexpr int kSteps = 8;
  auto search_ray = [&](Vec3f dir, Vec3f* out) {
    for (int k = 0; k <= kSteps; ++k) {
      const float t = target_out - (target_out - target_in) * float(k) / kSteps;
      if (clear(p + dir * t)) {
        *out = p + dir * t;
        return true;
      }
    }
    return false;
  };
  Vec3f y;
  if (search_ray(u, &y)) return y;
  // Then the directions around u, nearest first.
  Vec3f best_y = x;
  float best_dot = -2;
  const float weights[2] = {0.5f, 2.0f};
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        if (dx == 0 && dy == 0 && dz == 0) continue;
        const Vec3f e = normalized(Vec3f{float(dx), float(dy), float(dz)});
        for (float w : weights) {
          const Vec3f dir = normalized(u + e * w);
          if (length2(dir) == 0 || dot(dir, u) <= best_dot) continue;
          if (search_ray(dir, &y)) best_y = y, best_dot = dot(dir, u);
        }
      }
  if (best_dot > -2) return best_y;
  return x;  // no feasible point on that ray: keep the best effort
}

/// Whether no point of the grid lies strictly within r_inner of y (a few ulps of slack).
template <class Grid>
MENISCUS_HD bool clear_of_inner_shells(const Grid& g, Vec3f y, float r_inner) {
  bool clear = true;
  const float lo2 = r_inner * r_inner * (1.0f - 4e-6f);
  grid_for_each_within(g, y, r_inner, [&](uint32_t, float d2) { clear &= d2 >= lo2; });
  return clear;
}

/// The nearest particle for the projection: within 2·r_outer (the usual case, a short search),
/// else anywhere.
template <class Grid>
MENISCUS_HD NearestPoint constraint_nearest(const Grid& g, Vec3f x, float r_outer) {
  NearestPoint n = grid_nearest_within(g, x, 2.0f * r_outer);
  if (n.index == kNotFound) n = grid_nearest(g, x);
  return n;
}

/// project_with against the grid's exact nearest particle (the CUDA backend's projection; the CPU
/// gets the same nearest particle from its NeighbourCache).
template <class Grid>
MENISCUS_HD Vec3f project_vertex_on(const Grid& g, Vec3f x, float r_inner, float r_outer) {
  return project_with(
      x, r_inner, r_outer, g.points(), [&](Vec3f y) { return constraint_nearest(g, y, r_outer); },
      [&](Vec3f y) { return clear_of_inner_shells(g, y, r_inner); });
}

}  // namespace meniscus

namespace meniscus {

/// Distance of x from an ellipsoid's centre c in the ellipsoid's metric, |A(x − c)|.
MENISCUS_HD inline float metric_distance(const SymMat3& a, Vec3f x, Vec3f c) { return length(a * (x - c)); }

/// Moves x along the line from the ellipsoid's centre c (the metric's radial direction, the
/// ellipsoid analogue of Williams' radial projection) onto the shell r_inner ≤ |A(x − c)| ≤
/// r_outer. Not the closest point of the ellipsoid shell, but exact in the metric (the projected
/// point measures r_inner or r_outer up to rounding) and without iteration. A vertex exactly at
/// the centre is pushed along +z.
MENISCUS_HD inline Vec3f project_to_ellipsoid_shell(Vec3f x, Vec3f c, const SymMat3& a, float r_inner, float r_outer) {
  Vec3f d = x - c;
  float m = length(a * d);
  if (m >= r_inner && m <= r_outer) return x;
  const float target = m < r_inner ? r_inner : r_outer;
  if (m == 0.0f) {
    d = Vec3f{0, 0, 1};
    m = length(a * d);
  }
  return c + d * (target / m);
}

/// The result of a metric-nearest query: index into the grid's sorted points (kNotFound: none).
struct MetricNearest {
  uint32_t index = kNotFound;  ///< sorted particle index
  float distance = INFINITY;   ///< |A(x − P)|
};

/// The particle nearest to x in its own metric, argmin_i |A_i(x − P_i)| (ties: the lower sorted
/// index). Exact: |x − P| ≤ σ̃₁(P)·|A_P(x − P)| ≤ max_axis·|A_P(x − P)|, so a particle with metric
/// distance ≤ m lies within max_axis·m of x. `ellipsoids` per sorted point.
template <class Grid>
MENISCUS_HD MetricNearest grid_nearest_in_metric(const Grid& g, const Ellipsoid* ellipsoids, Vec3f x, float r_outer,
                                                 float max_axis) {
  MetricNearest best;
  auto scan = [&](float radius) {
    grid_for_each_within(g, x, radius, [&](uint32_t i, float) {
      const float m = metric_distance(ellipsoids[i].metric, x, g.point(i));
      if (m < best.distance || (m == best.distance && i < best.index)) best = MetricNearest{i, m};
    });
  };
  scan(max_axis * r_outer * 1.0001f);
  if (best.index != kNotFound && best.distance <= r_outer) return best;
  const NearestPoint e = grid_nearest(g, x);
  if (e.index == kNotFound) return best;
  const float m = metric_distance(ellipsoids[e.index].metric, x, g.point(e.index));
  best = MetricNearest{};
  scan(max_axis * m * 1.0001f + 1e-6f * r_outer);
  return best;
}

/// The projection of one vertex for ellipsoid constraints, shared by both backends: repeatedly
/// project onto the shell of the metric-nearest particle (`nearest(y)` → MetricNearest: the
/// CPU's EllipsoidCache list or the exact search), and where the shells of two particles undo
/// each other, search rays from the first particle for a feasible point (`exact(y)`: the exact
/// metric-nearest). `last_distance` receives the metric distance of the returned point's last
/// query (−1 when unknown). `points`, `ellipsoids`: per sorted particle.
template <class NearestFn, class ExactFn>
MENISCUS_HD Vec3f project_ellipsoid_with(Vec3f x, float r_inner, float r_outer, const Vec3f* points,
                                         const Ellipsoid* ellipsoids, NearestFn&& nearest, ExactFn&& exact,
                                         float* last_distance) {
  const float lo = r_inner * (1.0f - 2e-6f), hi = r_outer * (1.0f + 2e-6f);
  const float target_in = r_inner * (1.0f + 1e-6f), target_out = r_outer * (1.0f - 1e-6f);
  uint32_t first = kNotFound;
  *last_distance = -1;
  for (int round = 0; round < 4; ++round) {
    const MetricNearest n = nearest(x);
    *last_distance = n.index == kNotFound ? -1.0f : n.distance;
    if (n.index == kNotFound) return x;
    if (n.distance >= lo && n.distance <= hi) return x;
    if (first == kNotFound) first = n.index;
    x = project_to_ellipsoid_shell(x, points[n.index], ellipsoids[n.index].metric, target_in, target_out);
  }
  const MetricNearest n = nearest(x);
  *last_distance = n.distance;
  if (n.distance >= lo && n.distance <= hi) return x;
  *last_distance = -1;  // whatever the ray search returns is not x at a known distance
  // Projections against different particles undo each other (a vertex squeezed between the
  // inner ellipsoid of one particle and the outer one of another): search rays from the first
  // particle, from its outer shell inwards, for a point outside every inner ellipsoid — on such a
  // ray the first particle measures ≤ r_outer, so the constraint holds. The ray through x first,
  // then the directions around it, nearest first.
  const Vec3f p = points[first];
  const SymMat3& a = ellipsoids[first].metric;
  const Vec3f u = x == p ? Vec3f{0, 0, 1} : normalized(x - p);
  constexpr int kSteps = 12;
  auto search_ray = [&](Vec3f dir, Vec3f* out) {
    const float mu = length(a * dir);
    for (int k = 0; k <= kSteps; ++k) {
      const float t = target_out - (target_out - target_in) * float(k) / kSteps;
      const Vec3f y = p + dir * (t / mu);
      const MetricNearest m = exact(y);
      if (m.distance >= lo && m.distance <= hi) {
        *out = y;
        return true;
      }
    }
    return false;
  };
  Vec3f y;
  if (search_ray(u, &y)) return y;
  Vec3f best_y = x;
  float best_dot = -2;
  const float weights[4] = {0.25f, 0.5f, 1.0f, 2.0f};
  for (float w : weights)
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          if (dx == 0 && dy == 0 && dz == 0) continue;
          const Vec3f dir = normalized(u + normalized(Vec3f{float(dx), float(dy), float(dz)}) * w);
          if (length2(dir) == 0 || dot(dir, u) <= best_dot) continue;
          if (search_ray(dir, &y)) best_y = y, best_dot = dot(dir, u);
        }
  if (best_dot > -2) return best_y;
  return x;  // best effort
}

/// project_ellipsoid_with against the exact metric-nearest particle of the grid (the CUDA
/// backend's projection; the CPU gets the same particle from its EllipsoidCache).
template <class Grid>
MENISCUS_HD Vec3f project_vertex_in_metric(const Grid& g, const Ellipsoid* ellipsoids, Vec3f x, float r_inner,
                                           float r_outer, float max_axis) {
  float last = 0;
  auto exact = [&](Vec3f y) { return grid_nearest_in_metric(g, ellipsoids, y, r_outer, max_axis); };
  return project_ellipsoid_with(x, r_inner, r_outer, g.points(), ellipsoids, exact, exact, &last);
}

}  // namespace meniscus
