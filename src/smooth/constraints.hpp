// meniscus — constraint projection against the particles (Williams 2008 §4.2).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

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

/// Per-vertex lists of the particles near each vertex, so that the projection in the smoothing
/// sweeps (where vertices move little from one sweep to the next) scans a short contiguous
/// list instead of querying the hash grid. Exact: a vertex that has moved too far from where its
/// list was built, or whose nearest candidate cannot be certified, falls back to the grid.
class NeighbourCache {
 public:
  /// Lists, for every vertex, the particles within 1.5·r_outer of its current position.
  void build(const ShellConstraint& c, std::span<const Vec3f> x);
  /// project_vertex(c, x) for vertex i, using its list where that is exact.
  Vec3f project(const ShellConstraint& c, uint32_t i, Vec3f x) const;
  std::size_t memory_bytes() const { return anchors_.size() * 16 + ids_.size() * 4; }

 private:
  float margin_ = 0;
  std::vector<Vec3f> anchors_;
  std::vector<uint32_t> offsets_, ids_;
};

/// Projects every vertex in parallel.
void project_vertices(const ShellConstraint& c, std::span<Vec3f> x);

}  // namespace meniscus
