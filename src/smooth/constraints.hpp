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
/// list was built refreshes its own list, and a nearest candidate that cannot be certified falls
/// back to the grid. Each vertex touches only its own list, so vertices may be projected in
/// parallel as long as no vertex is projected by two threads at once.
class NeighbourCache {
 public:
  static constexpr int kCapacity = 32;
  /// Lists, for every vertex, the particles within 1.5·r_outer of its current position.
  void build(const ShellConstraint& c, std::span<const Vec3f> x);
  /// project_vertex(c, x) for vertex i, using (and if needed refreshing) its list.
  Vec3f project(const ShellConstraint& c, uint32_t i, Vec3f x);
  std::size_t memory_bytes() const { return anchors_.size() * (sizeof(Vec3f) + 1) + ids_.size() * 4; }

 private:
  void refresh(const ShellConstraint& c, uint32_t i, Vec3f y);
  float margin_ = 0;
  std::vector<Vec3f> anchors_;
  std::vector<uint8_t> counts_;  ///< list length, or kOverflow when more than kCapacity particles
  std::vector<uint32_t> ids_;    ///< kCapacity slots per vertex
};

/// Projects every vertex in parallel.
void project_vertices(const ShellConstraint& c, std::span<Vec3f> x);

}  // namespace meniscus
