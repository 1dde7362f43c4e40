// meniscus — constraint projection (Williams 2008 §4.2).
#include "smooth/constraints.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "common/for_each.hpp"
#include "smooth/constraint_impl.hpp"

namespace meniscus {

namespace {

/// The K smallest (distance, id) pairs offered, sorted by distance (ties: smaller id first), by
/// insertion — the lists are short. The per-vertex caches keep K − 1 of them and use the K-th as
/// the bound up to which the list is complete.
template <int K>
struct NearestK {
  struct Candidate {
    float distance;
    uint32_t id;
  };
  std::array<Candidate, K> best;
  int count = 0;
  void offer(float distance, uint32_t id) {
    if (count == K && distance >= best[K - 1].distance) return;
    int k = count < K ? count++ : K - 1;
    while (k > 0 && (best[k - 1].distance > distance || (best[k - 1].distance == distance && best[k - 1].id > id))) {
      best[k] = best[k - 1];
      --k;
    }
    best[k] = {distance, id};
  }
  /// Stores the first `capacity` ids at `slots`, followed by kNotFound when there are fewer.
  void store(int capacity, uint32_t* slots) const {
    const int stored = std::min(count, capacity);
    for (int k = 0; k < stored; ++k) slots[k] = best[std::size_t(k)].id;
    if (stored < capacity) slots[stored] = kNotFound;
  }
  /// The distance of the first candidate a list of `capacity` leaves out, or `otherwise` (the
  /// search radius) when it leaves none out: the list holds every candidate strictly below it.
  float first_left_out(int capacity, float otherwise) const {
    return count > capacity ? best[std::size_t(capacity)].distance : otherwise;
  }
};

HashGrid::Nearest nearest_particle(const ShellConstraint& c, Vec3f x) { return constraint_nearest(*c.particles, x, c.r_outer); }

template <class NearestFn>
Vec3f project_with(const ShellConstraint& c, Vec3f x, NearestFn&& nearest) {
  return meniscus::project_with(x, c.r_inner, c.r_outer, c.particles->sorted_points().data(), nearest,
                                [&](Vec3f y) { return clear_of_inner_shells(*c.particles, y, c.r_inner); });
}

}  // namespace

Vec3f project_vertex(const ShellConstraint& c, Vec3f x) {
  return project_with(c, x, [&](Vec3f y) { return nearest_particle(c, y); });
}

void NeighbourCache::refresh(const ShellConstraint& c, uint32_t i, Vec3f y) {
  // The kCapacity + 1 nearest particles within r_outer + margin (distances, so the reach is one).
  NearestK<kCapacity + 1> nearest;  // by squared distance
  const float radius = c.r_outer + margin_;
  c.particles->for_each_within(y, radius, [&](uint32_t id, float d2) { nearest.offer(d2, id); });
  uint32_t* ids = slots(i);
  nearest.store(kCapacity, ids);
  PackedParticleList& e = entries_[i];
  if (ids[0] == kNotFound) {  // no anchor: the next projection refreshes again
    e = {{0, 0, 0}, 0};
    return;
  }
  // Complete within the radius, or only up to (strictly below) the first particle left out.
  const float left_out2 = nearest.first_left_out(kCapacity, -1.0f);
  const float reach = left_out2 >= 0 ? std::sqrt(left_out2) * (1.0f - 1e-6f) : radius;
  // y rounded to the anchor grid around the first particle; the reach shortened by the distance
  // between them (with a margin for the rounding of that distance) and rounded down.
  const Vec3f from_first = (y - c.particles->point(ids[0])) / unit_;
  for (int k = 0; k < 3; ++k) e.anchor_units[k] = int16_t(std::clamp(std::lround(from_first[k]), -32767l, 32767l));
  const float off = length(anchor(c, i) - y) * 1.001f + unit_ * 1e-3f;
  const float units = (reach - off) * (1.0f - 1e-6f) / unit_;
  e.reach_units = units > 0 ? uint16_t(std::min(std::floor(units), 65535.0f)) : 0;
}

Vec3f NeighbourCache::anchor(const ShellConstraint& c, uint32_t i) const {
  const PackedParticleList& e = entries_[i];
  const Vec3f units{float(e.anchor_units[0]), float(e.anchor_units[1]), float(e.anchor_units[2])};
  return c.particles->point(slots(i)[0]) + units * unit_;
}

HashGrid::Nearest NeighbourCache::scan(const ShellConstraint& c, uint32_t i, Vec3f y, float moved) const {
  const auto points = c.particles->sorted_points();
  const uint32_t* ids = slots(i);
  // The nearest of the (at most two) listed particles, ties to the smaller index.
  HashGrid::Nearest best;
  for (int k = 0; k < kCapacity && ids[k] != kNotFound; ++k) {
    const float d2 = length2(points[ids[k]] - y);
    if (d2 < best.dist2 || (d2 == best.dist2 && ids[k] < best.index)) best = {ids[k], d2};
  }
  const float certain = float(entries_[i].reach_units) * unit_ - moved;
  if (best.index != kNotFound && certain > 0 && best.dist2 <= certain * certain) return best;
  return {};
}

void NeighbourCache::build(const ShellConstraint& c, std::span<const Vec3f> x) {
  margin_ = 0.3f * c.r_outer;
  unit_ = c.r_outer / 16384.0f;
  make_lists(x, [&](uint32_t i, Vec3f y) { refresh(c, i, y); });
}

Vec3f NeighbourCache::project_moved(const ShellConstraint& c, uint32_t i, Vec3f x) {
  float last_dist2 = -1;
  const Vec3f out = project_with(c, x, [&](Vec3f y) {
    HashGrid::Nearest n;
    if (slots(i)[0] != kNotFound) {
      const float moved = length(y - anchor(c, i));
      if (moved < margin_) n = scan(c, i, y, moved);
    }
    if (n.index == kNotFound) {
      refresh(c, i, y);
      if (slots(i)[0] != kNotFound) n = scan(c, i, y, length(y - anchor(c, i)));
      if (n.index == kNotFound) n = nearest_particle(c, y);
    }
    last_dist2 = n.dist2;
    return n;
  });
  // Accepted as it was: its distance is √last_dist2; otherwise the distance of `out` is unknown.
  set_slack(i, out == x && last_dist2 >= 0 ? std::sqrt(last_dist2) : -1.0f, c.r_inner, c.r_outer);
  return out;
}

MetricNearest nearest_in_metric(const EllipsoidConstraint& c, Vec3f x) {
  return grid_nearest_in_metric(*c.particles, c.ellipsoids.data(), x, c.r_outer, c.max_axis);
}

namespace {

/// project_ellipsoid_with of constraint_impl.hpp for `c`, the metric-nearest particle from
/// `nearest(y)` (the exact search or a vertex's EllipsoidCache list).
template <class NearestFn>
Vec3f project_ellipsoid_with(const EllipsoidConstraint& c, Vec3f x, Vec3f from, NearestFn&& nearest,
                             float* last_distance) {
  return project_ellipsoid_with(
      x, from, c.r_inner, c.r_outer, c.particles->points(), c.ellipsoids.data(), nearest,
      [&](Vec3f y) { return nearest_in_metric(c, y); }, last_distance);
}

}  // namespace

Vec3f project_vertex(const EllipsoidConstraint& c, Vec3f x, Vec3f from) {
  return project_vertex_in_metric(*c.particles, c.ellipsoids.data(), x, from, c.r_inner, c.r_outer, c.max_axis);
}

void EllipsoidCache::refresh(const EllipsoidConstraint& c, uint32_t i, Vec3f y) {
  // The kCapacity + 1 metric-nearest particles of metric distance ≤ r_outer + margin: every such
  // particle lies within max_axis·(r_outer + margin) of y (as in nearest_in_metric).
  NearestK<kCapacity + 1> nearest;
  const float radius = c.r_outer + margin_;
  const auto points = c.particles->sorted_points();
  c.particles->for_each_within(y, c.max_axis * radius * 1.0001f, [&](uint32_t id, float) {
    const float m = metric_distance(c.ellipsoids[id].metric, y, points[id]);
    if (m <= radius) nearest.offer(m, id);
  });
  CachedParticleList& e = entries_[i];
  e.set_anchor(y);
  nearest.store(kCapacity, slots(i));
  // (1 − 1e-5: the metric distances are evaluated in float at the anchor and at y.)
  e.reach = nearest.first_left_out(kCapacity, radius) * (1.0f - 1e-5f);
}

MetricNearest EllipsoidCache::scan(const EllipsoidConstraint& c, uint32_t i, Vec3f y, float moved) const {
  const auto points = c.particles->sorted_points();
  const CachedParticleList& e = entries_[i];
  const uint32_t* ids = slots(i);
  MetricNearest best;
  for (int k = 0; k < kCapacity && ids[k] != kNotFound; ++k) {
    const uint32_t id = ids[k];
    const float m = metric_distance(c.ellipsoids[id].metric, y, points[id]);
    if (m < best.distance || (m == best.distance && id < best.index)) best = {id, m};
  }
  // An unlisted particle measured ≥ reach at the anchor, so ≥ reach − L·moved at y (the rounding
  // allowance covers the float evaluation of both metric distances).
  const float certain = e.reach - lipschitz_ * moved * (1.0f + 1e-5f) - 1e-6f * c.r_outer;
  if (best.index != kNotFound && best.distance <= certain) return best;
  return {};
}

MetricNearest EllipsoidCache::nearest(const EllipsoidConstraint& c, uint32_t i, Vec3f y) {
  const float moved = length(y - entries_[i].anchor());
  MetricNearest n;
  if (lipschitz_ * moved < margin_) n = scan(c, i, y, moved);
  if (n.index == kNotFound) {
    refresh(c, i, y);
    n = scan(c, i, y, 0.0f);
    if (n.index == kNotFound) n = nearest_in_metric(c, y);
  }
  return n;
}

void EllipsoidCache::build(const EllipsoidConstraint& c, std::span<const Vec3f> x) {
  lipschitz_ = 1;
  for (const Ellipsoid& e : c.ellipsoids) lipschitz_ = std::max(lipschitz_, 1.0f / e.min_axis);
  lipschitz_ *= 1.001f;  // the metric's eigenvectors are orthonormal only up to rounding
  margin_ = 0.3f * c.r_outer;
  make_lists(x, [&](uint32_t i, Vec3f y) { refresh(c, i, y); });
}

Vec3f EllipsoidCache::project_moved(const EllipsoidConstraint& c, uint32_t i, Vec3f x, Vec3f from) {
  float last_distance = -1;
  const Vec3f out = project_ellipsoid_with(c, x, from, [&](Vec3f y) { return nearest(c, i, y); }, &last_distance);
  set_slack(i, last_distance, c.r_inner, c.r_outer);  // out measured last_distance (−1: unknown)
  return out;
}

double ellipsoid_constraint_residual(const EllipsoidConstraint& c, std::span<const Vec3f> x) {
  double worst = 0;
  for (const Vec3f& v : x) {
    const MetricNearest n = nearest_in_metric(c, v);
    if (n.index == kNotFound) continue;
    worst = std::max({worst, double(c.r_inner) - double(n.distance), double(n.distance) - double(c.r_outer)});
  }
  return worst;
}

void project_vertices(const ShellConstraint& c, std::span<Vec3f> x) {
  for_each_index(x.size(), 1024, [&](std::size_t i) { x[i] = project_vertex(c, x[i]); });
}

}  // namespace meniscus
