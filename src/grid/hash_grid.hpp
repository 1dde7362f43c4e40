// meniscus — uniform hashed grid over points (Edespong 2010 §3.1; Green 2008 "Particle
// Simulation using CUDA"): points sorted by cell key, each occupied cell a [begin, end) range
// of the sorted array. Cells are keyed by their unbounded integer coordinates (63-bit key), so
// the domain size is not limited by a modulo hash. The CPU's fast path of build_grid
// (build_grid.hpp, the build both backends share): its sort keys are the cells' indices in their
// box, a few bits, and its queries go through a KeyIndex; test_hash_grid.cpp holds the two to the
// same grid bit for bit.
#pragma once

#include <cmath>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "grid/hash_grid_impl.hpp"
#include "grid/key_index.hpp"
#include "meniscus/vec.hpp"

namespace meniscus {

class HashGrid {
 public:
  /// index into sorted_points() (kNotFound: none found) and the squared distance.
  using Nearest = NearestPoint;

  HashGrid() = default;
  /// Sorts the points by cell (parallel). `cell_size` > 0. Throws ResourceError when the points
  /// span more cells than a 21-bit coordinate can hold.
  HashGrid(std::span<const Vec3f> points, float cell_size);

  float cell_size() const { return cell_size_; }
  std::size_t size() const { return sorted_.size(); }
  /// Points in cell order; `order()[i]` is the original index of `sorted_points()[i]`.
  std::span<const Vec3f> sorted_points() const { return sorted_; }
  std::span<const uint32_t> order() const { return order_; }
  /// Frees order() (empty from then on), for a caller that needs no more original indices: 4
  /// bytes a point (the pipeline, through the smoothing when no attribute is transferred).
  void release_order() { std::vector<uint32_t>().swap(order_); }
  /// Occupied cells, sorted by key; cell c holds sorted points [cell_start[c], cell_start[c+1]).
  std::span<const uint64_t> cell_keys() const { return cell_keys_; }
  std::span<const uint32_t> cell_starts() const { return cell_starts_; }
  /// The box of the occupied cells (min > max when there are none).
  Vec3i cell_min() const { return index_.box_min(); }
  Vec3i cell_max() const { return index_.box_max(); }

  Vec3i cell_of(Vec3f p) const { return grid_cell_of(p, cell_size_); }
  Vec3f point(uint32_t i) const { return sorted_[i]; }
  const Vec3f* points() const { return sorted_.data(); }
  /// [begin, end) into sorted_points() of cell c (empty when unoccupied or out of range).
  std::pair<uint32_t, uint32_t> cell_range(Vec3i c) const {
    const uint32_t i = index_.find(c);  // kNotFound outside the cells' box too
    if (i == kNotFound) return {0, 0};
    return {cell_starts_[i], cell_starts_[i + 1]};
  }

  /// Calls f(sorted_index) for every point of the cells that touch the box [lo, hi] (a superset
  /// of the points inside it, cell by cell in z, y, x order).
  template <class F>
  void for_each_in_cells_of_box(Vec3f lo, Vec3f hi, F&& f) const {
    grid_for_each_in_cells_of_box(*this, lo, hi, f);
  }

  /// Calls f(sorted_index, dist2) for every point within distance r of p.
  template <class F>
  void for_each_within(Vec3f p, float r, F&& f) const {
    grid_for_each_within(*this, p, r, f);
  }

  /// The exact nearest point within max_radius of p (index kNotFound when there is none).
  Nearest nearest(Vec3f p, float max_radius) const { return grid_nearest_within(*this, p, max_radius); }
  /// The exact nearest point, however far (kNotFound only for an empty grid).
  Nearest nearest(Vec3f p) const { return grid_nearest(*this, p); }

  std::size_t memory_bytes() const {
    return sorted_.size() * sizeof(Vec3f) + order_.size() * 4 + cell_keys_.size() * 12 + index_.memory_bytes();
  }
  /// Whether the occupied cells are found through a dense array (CellIndex) rather than a hash.
  bool dense_index() const { return index_.dense(); }

 private:
  float cell_size_ = 1;
  std::vector<Vec3f> sorted_;
  std::vector<uint32_t> order_;
  std::vector<uint64_t> cell_keys_;
  std::vector<uint32_t> cell_starts_;
  CellIndex index_;
};

}  // namespace meniscus
