// meniscus — per-vertex constraint projection (Williams 2008 §4.2), shared by the CPU and CUDA
// backends: a vertex must lie between r_inner and r_outer from its nearest particle.
#pragma once

#include <cmath>
#include <cstdint>

#include "grid/hash_grid_impl.hpp"
#include "field/eigen_sym3_impl.hpp"
#include "field/kernel_impl.hpp"
#include "meniscus/vec.hpp"

namespace meniscus {

/// The larger and smaller of two floats, one instruction each (maxss, minss): std::fmax and
/// std::fmin are calls into libm on x86-64 (their NaN rules have no instruction), and the
/// projection of every vertex that left its shell made three of them. Equal to fmax and fmin for
/// all but NaN arguments, which these positions and radii never are.
MENISCUS_HD inline float max_of(float a, float b) { return a > b ? a : b; }
MENISCUS_HD inline float min_of(float a, float b) { return a < b ? a : b; }

/// How far a float position of x's magnitude may be from where it was meant to be: each
/// coordinate rounds by up to half an ulp of the largest, √3/2 ulp in all, and an ulp is at most
/// FLT_EPSILON times the coordinate. A point projected onto a shell lands up to this far off it.
MENISCUS_HD inline float position_rounding(Vec3f x) {
  constexpr float kEpsilon = 1.1920929e-7f;  // FLT_EPSILON
  return kEpsilon * max_of(std::fabs(x.x), max_of(std::fabs(x.y), std::fabs(x.z)));
}

/// A shell [r_inner, r_outer] as the projections test and target it: accepted within a few ulps
/// of its walls plus `slop` (the rounding of the coordinates, in the shell's units), and a
/// projected vertex placed a hair inside: a point projected exactly onto a wall measures up to an
/// ulp outside half the time, which would otherwise send it round again.
struct ShellBounds {
  float lo, hi;                 ///< accepted distances (lo ≥ 0)
  float target_in, target_out;  ///< where a projection puts a vertex that was inside / outside
};
MENISCUS_HD inline float accepted_inner(float r_inner, float slop) {
  return max_of(r_inner * (1.0f - 2e-6f) - slop, 0.0f);
}
MENISCUS_HD inline ShellBounds shell_bounds(float r_inner, float r_outer, float slop) {
  return {accepted_inner(r_inner, slop), r_outer * (1.0f + 2e-6f) + slop, r_inner * (1.0f + 1e-6f) + slop,
          r_outer * (1.0f - 1e-6f) - slop};
}

/// Offers try_at the distances of [t_in, t_out] nearest t first: t itself, then steps of
/// (t_out − t_in)/steps outwards and inwards alternately, then the two ends (which those steps
/// need not land on). Whether try_at accepted one.
template <class TryAt>
MENISCUS_HD bool try_shell_distances(float t, float t_in, float t_out, int steps, TryAt&& try_at) {
  const float dt = (t_out - t_in) / float(steps);
  for (int k = 0; k <= 2 * steps; ++k) {
    const float d = k == 0 ? t : t + float((k + 1) / 2) * dt * (k % 2 ? 1.0f : -1.0f);
    if (d >= t_in && d <= t_out && try_at(d)) return true;
  }
  return try_at(t_in) || try_at(t_out);
}

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

/// The point nearest to x on the circle where the spheres of radius r about p and q meet (x
/// inside both balls: the crease between two overlapping inner shells); false when the spheres
/// do not meet in a circle.
MENISCUS_HD inline bool nearest_on_crease(Vec3f x, Vec3f p, Vec3f q, float r, Vec3f* out) {
  const Vec3f pq = q - p;
  const float l2 = length2(pq);
  if (!(l2 > 0.0f) || l2 >= 4.0f * r * r) return false;
  const float l = std::sqrt(l2);
  const Vec3f n = pq / l;
  const Vec3f c = p + n * (0.5f * l);                 // the circle's centre
  const float rho = std::sqrt(r * r - 0.25f * l2);   // and radius
  Vec3f v = x - c;
  v -= n * dot(v, n);                                 // x's direction from the centre, in the plane
  float v2 = length2(v);
  if (!(v2 > 0.0f)) {                                 // x on the axis: any point of the circle
    v = std::fabs(n.x) < 0.9f ? Vec3f{1, 0, 0} : Vec3f{0, 1, 0};
    v -= n * dot(v, n);
    v2 = length2(v);
  }
  *out = c + v * (rho / std::sqrt(v2));
  return true;
}

/// The full projection of one vertex (Williams 2008 §4.2), shared by both backends: repeatedly
/// project onto the shell of the current nearest particle (`nearest(y)` → NearestPoint) until the
/// vertex lies in [r_inner, r_outer] of its nearest particle. A vertex pushed out of one inner
/// shell into another (the inner shells of neighbouring particles overlap where the particles are
/// closer than 2 r_inner: the smoothing presses vertices into the crease between them) goes to
/// the nearest point of the crease, where radial projections would bounce between the two shells.
/// If that does not settle it, search rays from the first nearest particle for the point nearest
/// the vertex that `clear(y)` (no particle within r_inner of y) accepts. `points` are the grid's
/// sorted points.
template <class NearestFn, class ClearFn>
MENISCUS_HD Vec3f project_with(Vec3f x, float r_inner, float r_outer, const Vec3f* points, NearestFn&& nearest,
                               ClearFn&& clear) {
  // Far from the origin the ulp of the coordinates, not of the radii, is what a projected point
  // is rounded to.
  const ShellBounds shell = shell_bounds(r_inner, r_outer, position_rounding(x));
  const float lo2 = shell.lo * shell.lo, hi2 = shell.hi * shell.hi;
  const float target_in = shell.target_in, target_out = shell.target_out;
  uint32_t first = kNotFound;
  uint32_t pushed_from = kNotFound;  // the particle whose inner shell the last round moved x onto
  for (int round = 0; round < 4; ++round) {
    const NearestPoint n = nearest(x);
    if (n.index == kNotFound) return x;
    if (n.dist2 >= lo2 && n.dist2 <= hi2) return x;
    if (first == kNotFound) first = n.index;
    const bool inside = n.dist2 < lo2;
    if (inside && pushed_from != kNotFound && pushed_from != n.index &&
        nearest_on_crease(x, points[pushed_from], points[n.index], target_in, &x)) {
      pushed_from = n.index;
      continue;
    }
    pushed_from = inside ? n.index : kNotFound;
    x = project_to_shell(x, points[n.index], target_in, target_out);
  }
  const NearestPoint n = nearest(x);
  if (n.dist2 >= lo2 && n.dist2 <= hi2) return x;
  // Rare: projections against different particles undo each other (a vertex squeezed among the
  // inner shells of three particles, or between the inner shell of one and the outer shell of
  // another). Search the ray from the first nearest particle through x for a point clear of
  // every inner shell, nearest to x's own distance first; on it the first particle is within
  // r_outer, so the constraint holds.
  const Vec3f p = points[first];
  const Vec3f u = x == p ? Vec3f{0, 0, 1} : normalized(x - p);
  constexpr int kSteps = 8;
  const float t_x = min_of(max_of(length(x - p), target_in), target_out);
  auto search_ray = [&](Vec3f dir, Vec3f* out) {
    return try_shell_distances(t_x, target_in, target_out, kSteps, [&](float t) {
      if (!clear(p + dir * t)) return false;
      *out = p + dir * t;
      return true;
    });
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

/// Whether no point of the grid lies strictly within r_inner of y (with project_with's allowance
/// for rounding).
template <class Grid>
MENISCUS_HD bool clear_of_inner_shells(const Grid& g, Vec3f y, float r_inner) {
  bool clear = true;
  const float lo = accepted_inner(r_inner, position_rounding(y)), lo2 = lo * lo;
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

/// Where the segment from → x first reaches metric distance r from c (|A(y − c)| = r up to
/// rounding), given that `from` measures at least r and x less: the point where a vertex that
/// moved from `from` to x entered the ellipsoid.
MENISCUS_HD inline Vec3f enter_ellipsoid(Vec3f from, Vec3f x, Vec3f c, const SymMat3& a, float r) {
  const Vec3f u = a * (from - c), v = a * (x - from);
  // |u + t v|² = r²: qa t² + 2 qb t + qc = 0 with qc ≥ 0 at t = 0 and < 0 at t = 1, so qb < 0 and
  // the smaller root, written without cancellation, is the entry.
  const float qa = dot(v, v), qb = dot(u, v), qc = max_of(dot(u, u) - r * r, 0.0f);
  const float den = std::sqrt(max_of(qb * qb - qa * qc, 0.0f)) - qb;
  const float t = den > 0.0f ? min_of(qc / den, 1.0f) : 0.0f;
  return from + (x - from) * t;
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
///
/// x is where the sweep moved the vertex from `from` (where its previous projection left it). A
/// vertex that entered an inner shell from outside goes back to where its move entered it
/// (enter_ellipsoid), not out along the line from the centre: a surface particle's inner shell is
/// thin along the normal (0.2–0.3 d), the accelerated sweeps move vertices 0.3–1 d at convex spots,
/// and a vertex carried past the centre would go out on the far side, taking the surface across the
/// particle (docs/fields.md, "Keeping every particle inside"). A vertex that was inside already
/// (the extracted surface, a ray search's best effort) goes out along the line from the centre, as
/// on Williams' spheres.
template <class NearestFn, class ExactFn>
MENISCUS_HD Vec3f project_ellipsoid_with(Vec3f x, Vec3f from, float r_inner, float r_outer, const Vec3f* points,
                                         const Ellipsoid* ellipsoids, NearestFn&& nearest, ExactFn&& exact,
                                         float* last_distance) {
  // As project_with: the tolerance allows the rounding of float coordinates, here in the metric of
  // the particle measured (a position off by e measures up to e / min_axis off).
  const float rounding = position_rounding(x);
  auto shell_of = [&](uint32_t i) { return shell_bounds(r_inner, r_outer, rounding / ellipsoids[i].min_axis); };
  auto in_shell = [&](const MetricNearest& m) {
    const ShellBounds s = shell_of(m.index);
    return m.distance >= s.lo && m.distance <= s.hi;
  };
  uint32_t first = kNotFound;
  *last_distance = -1;
  for (int round = 0; round < 4; ++round) {
    const MetricNearest n = nearest(x);
    *last_distance = n.index == kNotFound ? -1.0f : n.distance;
    if (n.index == kNotFound) return x;
    if (in_shell(n)) return x;
    if (first == kNotFound) first = n.index;
    const ShellBounds s = shell_of(n.index);
    const SymMat3& a = ellipsoids[n.index].metric;
    if (n.distance < s.lo && metric_distance(a, from, points[n.index]) >= s.target_in)
      x = enter_ellipsoid(from, x, points[n.index], a, s.target_in);  // entered from outside
    else
      x = project_to_ellipsoid_shell(x, points[n.index], a, s.target_in, s.target_out);
  }
  const MetricNearest n = nearest(x);
  *last_distance = n.distance;
  if (n.index != kNotFound && in_shell(n)) return x;
  *last_distance = -1;  // whatever the ray search returns is not x at a known distance
  // Projections against different particles undo each other (a vertex squeezed between the
  // inner ellipsoid of one particle and the outer one of another): search rays from the first
  // particle for a point outside every inner ellipsoid, from x's own metric distance outwards and
  // inwards — on such a ray the first particle measures ≤ r_outer, so the constraint holds. The
  // ray through x first, then the directions around it, nearest first.
  const Vec3f p = points[first];
  const SymMat3& a = ellipsoids[first].metric;
  const Vec3f u = x == p ? Vec3f{0, 0, 1} : normalized(x - p);
  constexpr int kSteps = 12;
  const ShellBounds first_shell = shell_of(first);
  const float t_x = min_of(max_of(metric_distance(a, x, p), first_shell.target_in), first_shell.target_out);
  auto search_ray = [&](Vec3f dir, Vec3f* out) {
    const float mu = length(a * dir);
    return try_shell_distances(t_x, first_shell.target_in, first_shell.target_out, kSteps, [&](float t) {
      const Vec3f y = p + dir * (t / mu);
      const MetricNearest m = exact(y);
      if (m.index == kNotFound || !in_shell(m)) return false;
      *out = y;
      return true;
    });
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
MENISCUS_HD Vec3f project_vertex_in_metric(const Grid& g, const Ellipsoid* ellipsoids, Vec3f x, Vec3f from,
                                           float r_inner, float r_outer, float max_axis) {
  float last = 0;
  auto exact = [&](Vec3f y) { return grid_nearest_in_metric(g, ellipsoids, y, r_outer, max_axis); };
  return project_ellipsoid_with(x, from, r_inner, r_outer, g.points(), ellipsoids, exact, exact, &last);
}

}  // namespace meniscus
