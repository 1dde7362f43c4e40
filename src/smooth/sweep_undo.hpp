// meniscus — the positions before a Gauss-Seidel sweep, for the energy guard's undo, in 6 bytes a
// vertex instead of a 12-byte copy.
//
// A sweep moves each vertex once, and little: each coordinate's float bits before the move differ
// from those after it by a small integer (a move of 1e-4 at a coordinate of 1 is some 840 units
// in the last place). Each vertex keeps that difference per coordinate in 16 bits when all three
// fit, else its whole position aside; the undo adds the differences back to the bits — exact, so
// the guard redoes the sweep from the very same positions as with a copy.
#pragma once

#include <tbb/enumerable_thread_specific.h>

#include <bit>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "common/huge_pages.hpp"
#include "meniscus/vec.hpp"

namespace meniscus {

class SweepUndo {
 public:
  /// Starts a sweep of `vertex_count` vertices (what was recorded before is dropped).
  void begin(std::size_t vertex_count) {
    if (ulps_.size() != 3 * vertex_count) resize_huge(ulps_, 3 * vertex_count);
    for (auto& list : aside_) list.clear();
  }
  /// Vertex i moved from `before` to `after` in this sweep (once per vertex; vertices may be
  /// recorded from several threads at once).
  void record(uint32_t i, Vec3f before, Vec3f after) {
    int16_t* u = ulps_.data() + 3 * std::size_t(i);
    for (int k = 0; k < 3; ++k) {
      const int64_t d = int64_t(std::bit_cast<int32_t>(before[k])) - int64_t(std::bit_cast<int32_t>(after[k]));
      if (d < -INT16_MAX || d > INT16_MAX) {
        u[0] = kAside;
        aside_.local().emplace_back(i, before);
        return;
      }
      u[k] = int16_t(d);
    }
  }
  /// Puts every vertex of x (as the sweep left it) back where it was before the sweep.
  void undo(std::span<Vec3f> x) const;
  std::size_t memory_bytes() const { return ulps_.size() * sizeof(int16_t); }

 private:
  static constexpr int16_t kAside = INT16_MIN;  ///< the vertex's position before is in aside_
  UninitVector<int16_t> ulps_;                  ///< 3 a vertex: bits before − bits after
  tbb::enumerable_thread_specific<std::vector<std::pair<uint32_t, Vec3f>>> aside_;
};

}  // namespace meniscus
