// meniscus — constraint projection (Williams 2008 §4.2).
#include "smooth/constraints.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "smooth/constraint_impl.hpp"

namespace meniscus {

namespace {

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
  // The kCapacity + 1 nearest particles within r_outer + margin, by insertion (lists are short).
  struct Candidate {
    float d2;
    uint32_t id;
  };
  std::array<Candidate, kCapacity + 1> best;
  int n = 0;
  const float radius = c.r_outer + margin_;
  c.particles->for_each_within(y, radius, [&](uint32_t id, float d2) {
    if (n == kCapacity + 1 && d2 >= best[kCapacity].d2) return;
    int k = n < kCapacity + 1 ? n++ : kCapacity;
    while (k > 0 && (best[k - 1].d2 > d2 || (best[k - 1].d2 == d2 && best[k - 1].id > id))) {
      best[k] = best[k - 1];
      --k;
    }
    best[k] = {d2, id};
  });
  Entry& e = entries_[i];
  e.anchor = y;
  e.count = uint32_t(std::min(n, kCapacity));
  // With more than kCapacity particles in range, the list is complete only up to the first one
  // left out (strictly below its distance).
  e.reach = n > kCapacity ? std::sqrt(best[kCapacity].d2) * (1.0f - 1e-6f) : radius;
  uint32_t* slots = ids_.data() + std::size_t(i) * kCapacity;
  for (uint32_t k = 0; k < e.count; ++k) slots[k] = best[k].id;
}

HashGrid::Nearest NeighbourCache::scan(const ShellConstraint& c, uint32_t i, Vec3f y, float moved) const {
  const auto points = c.particles->sorted_points();
  const Entry& e = entries_[i];
  const uint32_t* slots = ids_.data() + std::size_t(i) * kCapacity;
  HashGrid::Nearest best;
  float best_dist = INFINITY;
  for (uint32_t k = 0; k < e.count; ++k) {
    const Vec3f p = points[slots[k]];
    // Sorted by distance to the anchor, and |p − y| ≥ |p − anchor| − moved: once the anchor
    // distance exceeds best + moved (with a rounding allowance), no later entry is nearer.
    const float from_anchor2 = length2(p - e.anchor);
    const float bound = (best_dist + moved) * (1.0f + 1e-5f);
    if (from_anchor2 > bound * bound) break;
    const float d2 = length2(p - y);
    if (d2 < best.dist2 || (d2 == best.dist2 && slots[k] < best.index)) {
      best = {slots[k], d2};
      best_dist = std::sqrt(d2);
    }
  }
  const float certain = e.reach - moved;
  if (best.index != kNotFound && certain > 0 && best.dist2 <= certain * certain) return best;
  return {};
}

void NeighbourCache::build(const ShellConstraint& c, std::span<const Vec3f> x) {
  margin_ = 0.3f * c.r_outer;
  entries_.resize(x.size());
  ids_.resize(x.size() * kCapacity);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, x.size(), 1024), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) refresh(c, uint32_t(i), x[i]);
  });
}

Vec3f NeighbourCache::project(const ShellConstraint& c, uint32_t i, Vec3f x) {
  return project_with(c, x, [&](Vec3f y) {
    float moved = length(y - entries_[i].anchor);
    if (moved < margin_) {
      const HashGrid::Nearest n = scan(c, i, y, moved);
      if (n.index != kNotFound) return n;
    }
    refresh(c, i, y);
    const HashGrid::Nearest n = scan(c, i, y, 0.0f);
    return n.index != kNotFound ? n : nearest_particle(c, y);
  });
}

void project_vertices(const ShellConstraint& c, std::span<Vec3f> x) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, x.size(), 1024), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) x[i] = project_vertex(c, x[i]);
  });
}

}  // namespace meniscus
