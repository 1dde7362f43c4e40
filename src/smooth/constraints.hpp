// meniscus — constraint projection against the particles (Williams 2008 §4.2).
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>
#include <vector>

#include "common/for_each.hpp"
#include "common/huge_pages.hpp"
#include "smooth/constraint_impl.hpp"
#include "grid/hash_grid.hpp"
#include "meniscus/vec.hpp"

namespace meniscus {

struct ShellConstraint {
  const HashGrid* particles = nullptr;  ///< particles, cell size ≥ r_outer
  float r_inner = 0, r_outer = 0;
};

/// Projects one vertex: nearest particle P (hash grid, exact), then project_to_shell; repeated
/// (at most a few rounds) while the projection brings the vertex within r_inner of another
/// particle, so the result satisfies the constraint against its *new* nearest particle.
Vec3f project_vertex(const ShellConstraint& c, Vec3f x);

/// The per-vertex record of NeighbourCache and EllipsoidCache (the list's ids, and the slack the
/// sweeps test first, are stored apart; a list shorter than the capacity ends with kNotFound, so
/// the record needs no count: 16 bytes a vertex).
/// Trivial (no initialisers): the caches' arrays are first written by the parallel refreshes.
struct CachedParticleList {
  float anchor_xyz[3];  ///< where the list was made
  float reach;          ///< every particle within this distance (or metric distance) is listed
  Vec3f anchor() const { return {anchor_xyz[0], anchor_xyz[1], anchor_xyz[2]}; }
  void set_anchor(Vec3f p) {
    anchor_xyz[0] = p.x;
    anchor_xyz[1] = p.y;
    anchor_xyz[2] = p.z;
  }
};
static_assert(sizeof(CachedParticleList) == 16);

/// NeighbourCache's record (8 bytes): the anchor as a multiple of a unit (r_outer / 16384) away
/// from the list's first particle, and the reach in that unit. The list is made at y and stored
/// at the anchor it rounds y to, its reach shortened by their distance (and rounded down): every
/// particle within the reach of that anchor lies within the reach of y, so the list stays exact.
/// A vertex lies within r_outer · 1.3 of its list's first particle (the search radius), 21299
/// units; an empty list has no anchor.
struct PackedParticleList {
  int16_t anchor_units[3];
  uint16_t reach_units;
};
static_assert(sizeof(PackedParticleList) == 8);

/// What NeighbourCache and EllipsoidCache share: per vertex a record (Entry), K particle slots
/// and the slack of the skip test — how far, in the constraint's distance, the vertex may move
/// from where its last projection left it and stay inside its shell (negative: unknown).
template <int K, class Entry = CachedParticleList>
class CachedParticleLists {
 public:
  static constexpr int kCapacity = K;
  /// Hints the cache to load vertex i's slack and list (a few vertices before projecting it).
  void prefetch(uint32_t i) const {
    __builtin_prefetch(&slack_[i]);
    __builtin_prefetch(&entries_[i]);
    __builtin_prefetch(slots(i));
  }
  std::size_t memory_bytes() const {
    return entries_.size() * sizeof(Entry) + ids_.size() * sizeof(uint32_t) +
           slack_.size() * sizeof(float);
  }

 protected:
  /// One list per vertex, each made by refresh(i, x[i]) (in parallel), every slack unknown. The
  /// arrays are written first there, in parallel (no serial zeroing; a list's unused slots stay
  /// unwritten and are never read).
  template <class Refresh>
  void make_lists(std::span<const Vec3f> x, Refresh&& refresh) {
    resize_huge(entries_, x.size());
    resize_huge(ids_, x.size() * std::size_t(K));
    resize_huge(slack_, x.size());
    for_each_index(x.size(), 1024, [&](std::size_t i) {
      slack_[i] = -1.0f;
      refresh(uint32_t(i), x[i]);
    });
  }
  /// Whether vertex i, having moved `moved` (in the constraint's distance) since its last
  /// projection, is certainly still inside its shell; if so the move is taken off its slack.
  bool still_inside(uint32_t i, float moved) {
    float& slack = slack_[i];
    if (!(moved <= slack)) return false;
    slack -= moved;
    return true;
  }
  /// The slack after a projection that left vertex i at `distance` from its nearest particle
  /// (negative: not known, slack 0), less a margin over the projection's acceptance tolerance.
  void set_slack(uint32_t i, float distance, float r_inner, float r_outer) {
    slack_[i] = distance < 0 ? 0.0f
                             : std::max(std::min(distance - r_inner, r_outer - distance) - 1e-5f * r_outer, 0.0f);
  }
  uint32_t* slots(uint32_t i) { return ids_.data() + std::size_t(i) * K; }
  const uint32_t* slots(uint32_t i) const { return ids_.data() + std::size_t(i) * K; }

  UninitVector<Entry> entries_;
  UninitVector<uint32_t> ids_;  ///< K slots per vertex, nearest to the anchor first
  UninitVector<float> slack_;
};

/// Per-vertex lists of the particles near each vertex, so that the projection in the smoothing
/// sweeps (where vertices move little from one sweep to the next) scans a short contiguous
/// list instead of querying the hash grid. Each list holds the (at most kCapacity) particles
/// nearest to where it was made, sorted by distance, and the radius `reach` around its anchor (that
/// point rounded, PackedParticleList) within which it holds every particle. Exact: the nearest
/// particle to a point y with |y − anchor| = m is the nearest listed one when its distance is ≤
/// reach − m (certified); otherwise the list is rebuilt at y (and the grid answers if even that
/// cannot certify). Each vertex touches only its own list, so vertices may be projected in parallel
/// as long as no vertex is projected by two threads at once. Two particles a list (20 bytes a
/// vertex with the packed record and the slack): as fast as four or eight — the slack test ends
/// most projections, and the nearest particle rarely changes between refreshes — and 8 bytes a
/// vertex less than four, through the whole smoothing.
class NeighbourCache : public CachedParticleLists<2, PackedParticleList> {
 public:
  /// Lists, for every vertex, the particles nearest to its current position.
  void build(const ShellConstraint& c, std::span<const Vec3f> x);
  /// project_vertex(c, x) for vertex i, using (and if needed refreshing) its list. `from` is
  /// where the vertex was before the move being projected, i.e. where its previous projection
  /// left it (any value the first time): a vertex that moved less than its slack from there is
  /// still inside its shell (its nearest distance is 1-Lipschitz) and returned at once.
  Vec3f project(const ShellConstraint& c, uint32_t i, Vec3f x, Vec3f from) {
    // The nearest distance D is 1-Lipschitz: a vertex that moved m ≤ slack from where its last
    // projection left it (with D − r_inner ≥ slack and r_outer − D ≥ slack there) is inside its
    // shell without any query, and project_with would return it unchanged. The margins keep this
    // exact under rounding (project_with accepts 4e-6 outside the shell). Inline: most calls end
    // here.
    if (still_inside(i, length(x - from))) return x;
    return project_moved(c, i, x);
  }

 private:
  /// project for a vertex that may have left its shell.
  Vec3f project_moved(const ShellConstraint& c, uint32_t i, Vec3f x);
  void refresh(const ShellConstraint& c, uint32_t i, Vec3f y);
  HashGrid::Nearest scan(const ShellConstraint& c, uint32_t i, Vec3f y, float moved) const;
  /// Vertex i's anchor (its list not empty).
  Vec3f anchor(const ShellConstraint& c, uint32_t i) const;
  float margin_ = 0;
  float unit_ = 0;  ///< of PackedParticleList
};

/// Projects every vertex in parallel.
void project_vertices(const ShellConstraint& c, std::span<Vec3f> x);

/// Ellipsoid constraints (anisotropic kernels, Yu & Turk 2010): a vertex x must satisfy
/// r_inner ≤ |A_P (x − P)| ≤ r_outer for the particle P nearest to it *in that particle's
/// metric* A_P (argmin_i |A_i (x − P_i)|); with A = I these are Williams' spherical shells.
struct EllipsoidConstraint {
  const HashGrid* particles = nullptr;    ///< the kernel centres
  std::span<const Ellipsoid> ellipsoids;  ///< per sorted particle
  float r_inner = 0, r_outer = 0;
  float max_axis = 1;                     ///< max σ̃₁ over the particles (bounds the search)
};

/// The particle nearest to x in its own metric (exact: every particle whose metric distance
/// can be smaller is within max_axis · distance of x in Euclidean terms).
MetricNearest nearest_in_metric(const EllipsoidConstraint& c, Vec3f x);

/// Projects one vertex, moved to x from `from` (where its previous projection left it), onto the
/// shell of its metric-nearest particle: back to where the move entered an inner shell it entered
/// from outside (enter_ellipsoid), else along the metric radial direction
/// (project_to_ellipsoid_shell); repeated while that makes another particle the nearest and
/// violated; a ray search from the first particle settles the rare vertex squeezed between two
/// shells (project_ellipsoid_with). Thread-safe.
Vec3f project_vertex(const EllipsoidConstraint& c, Vec3f x, Vec3f from);

/// NeighbourCache's counterpart for ellipsoid constraints. Each vertex keeps the (at most
/// kCapacity) particles nearest to its anchor *in their own metrics*, sorted, with the metric
/// radius `reach` within which the list is complete. The metric distance of any particle is
/// L-Lipschitz in the vertex position (L = max ‖A_P‖₂ = max 1/σ̃₃ over the particles), so at a
/// point y with |y − anchor| = m the list's best b is certified when b ≤ reach − L·m; a vertex
/// whose last projection left it with slack s inside its shell (in metric units) needs no query
/// at all while L·(its move) ≤ s. Otherwise the list is rebuilt at y, and nearest_in_metric
/// answers if even that cannot certify. Gives exactly project_vertex(c, x, from); each vertex touches
/// only its own list (vertices may be projected in parallel, no vertex by two threads at once).
/// Four particles a list: as fast as eight, 16 bytes a vertex less; two make the A sweeps slower
/// (the metric-nearest particle changes more often).
class EllipsoidCache : public CachedParticleLists<4> {
 public:
  void build(const EllipsoidConstraint& c, std::span<const Vec3f> x);
  /// As NeighbourCache::project (`from`: where the previous projection left the vertex, which the
  /// projection also reads; the slack is in metric units): exactly project_vertex(c, x, from).
  Vec3f project(const EllipsoidConstraint& c, uint32_t i, Vec3f x, Vec3f from) {
    // The metric distance to the metric-nearest particle is L-Lipschitz: a vertex that moved m
    // with L·m ≤ slack from where its last projection left it is still inside its shell.
    if (still_inside(i, lipschitz_ * length(x - from))) return x;
    return project_moved(c, i, x, from);
  }

 private:
  Vec3f project_moved(const EllipsoidConstraint& c, uint32_t i, Vec3f x, Vec3f from);
  void refresh(const EllipsoidConstraint& c, uint32_t i, Vec3f y);
  MetricNearest scan(const EllipsoidConstraint& c, uint32_t i, Vec3f y, float moved) const;
  MetricNearest nearest(const EllipsoidConstraint& c, uint32_t i, Vec3f y);
  float lipschitz_ = 1, margin_ = 0;
};

/// Max over the vertices of the metric distance outside [r_inner, r_outer] to the metric-nearest
/// particle (the constraint residual of ellipsoid constraints).
double ellipsoid_constraint_residual(const EllipsoidConstraint& c, std::span<const Vec3f> x);

}  // namespace meniscus
