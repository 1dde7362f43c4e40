// meniscus — constraint projection (Williams 2008 §4.2).
#include "smooth/constraints.hpp"

#include <tbb/parallel_for.h>

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

namespace {
constexpr uint8_t kOverflow = 0xFF;
}  // namespace

void NeighbourCache::refresh(const ShellConstraint& c, uint32_t i, Vec3f y) {
  anchors_[i] = y;
  uint32_t* slots = ids_.data() + std::size_t(i) * kCapacity;
  int n = 0;
  c.particles->for_each_within(y, c.r_outer + margin_, [&](uint32_t id, float) {
    if (n < kCapacity) slots[n] = id;
    ++n;
  });
  counts_[i] = n <= kCapacity ? uint8_t(n) : kOverflow;
}

void NeighbourCache::build(const ShellConstraint& c, std::span<const Vec3f> x) {
  margin_ = 0.5f * c.r_outer;
  anchors_.resize(x.size());
  counts_.resize(x.size());
  ids_.resize(x.size() * kCapacity);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, x.size(), 1024), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) refresh(c, uint32_t(i), x[i]);
  });
}

Vec3f NeighbourCache::project(const ShellConstraint& c, uint32_t i, Vec3f x) {
  const auto points = c.particles->sorted_points();
  const float reach = c.r_outer + margin_;
  return project_with(c, x, [&](Vec3f y) {
    // The list holds every particle within `reach` of the anchor, so it holds every particle
    // within reach − |y − anchor| of y: a nearest candidate inside that radius is exact.
    float moved = length(y - anchors_[i]);
    if (moved >= margin_) {
      refresh(c, i, y);
      moved = 0;
    }
    if (counts_[i] != kOverflow) {
      HashGrid::Nearest best;
      const uint32_t* slots = ids_.data() + std::size_t(i) * kCapacity;
      for (int k = 0; k < counts_[i]; ++k) {
        const float d2 = length2(points[slots[k]] - y);
        if (d2 < best.dist2 || (d2 == best.dist2 && slots[k] < best.index)) best = {slots[k], d2};
      }
      const float certain = reach - moved;
      if (best.index != kNotFound && best.dist2 <= certain * certain) return best;
    }
    return nearest_particle(c, y);
  });
}

void project_vertices(const ShellConstraint& c, std::span<Vec3f> x) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, x.size(), 1024), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) x[i] = project_vertex(c, x[i]);
  });
}

}  // namespace meniscus
