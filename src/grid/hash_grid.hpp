// meniscus — uniform hashed grid over points (Edespong 2010 §3.1; Green 2008 "Particle
// Simulation using CUDA"): points sorted by cell key, each occupied cell a [begin, end) range
// of the sorted array. Cells are keyed by their unbounded integer coordinates (63-bit key), so
// the domain size is not limited by a modulo hash.
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
  /// Occupied cells, sorted by key; cell c holds sorted points [cell_start[c], cell_start[c+1]).
  std::span<const uint64_t> cell_keys() const { return cell_keys_; }
  std::span<const uint32_t> cell_starts() const { return cell_starts_; }
  Vec3i cell_min() const { return cell_min_; }
  Vec3i cell_max() const { return cell_max_; }

  Vec3i cell_of(Vec3f p) const { return grid_cell_of(p, cell_size_); }
  Vec3f point(uint32_t i) const { return sorted_[i]; }
  const Vec3f* points() const { return sorted_.data(); }
  /// [begin, end) into sorted_points() of cell c (empty when unoccupied or out of range).
  std::pair<uint32_t, uint32_t> cell_range(Vec3i c) const {
    if (c.x < cell_min_.x || c.y < cell_min_.y || c.z < cell_min_.z || c.x > cell_max_.x ||
        c.y > cell_max_.y || c.z > cell_max_.z)
      return {0, 0};
    const uint32_t i = dense_.empty() ? index_.find(pack_coords(c.x, c.y, c.z)) : dense_[dense_slot(c)];
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
    return sorted_.size() * (sizeof(Vec3f) + 4) + cell_keys_.size() * 12 + index_.memory_bytes() +
           dense_.size() * sizeof(uint32_t);
  }
  /// Whether the occupied cells are found through a dense array over the bounding box of the
  /// cells (where that takes no more memory than the hash index) rather than the hash index.
  bool dense_index() const { return !dense_.empty(); }

 private:
  /// Index into dense_ of a cell within [cell_min_, cell_max_].
  std::size_t dense_slot(Vec3i c) const {
    return (std::size_t(c.z - cell_min_.z) * dense_ny_ + std::size_t(c.y - cell_min_.y)) * dense_nx_ +
           std::size_t(c.x - cell_min_.x);
  }

  float cell_size_ = 1;
  std::vector<Vec3f> sorted_;
  std::vector<uint32_t> order_;
  std::vector<uint64_t> cell_keys_;
  std::vector<uint32_t> cell_starts_;
  Vec3i cell_min_{}, cell_max_{-1, -1, -1};
  // The cells' index: a dense array over the box of the cells (kNotFound where unoccupied) when
  // it is no larger than the hash index (a block of fluid: a 16th of it), else the hash index. A
  // dense lookup reads neighbouring entries for neighbouring cells; the hash scatters them (the
  // distance field's scatter on splash 1M spent a tenth of its time on that one load).
  std::vector<uint32_t> dense_;
  std::size_t dense_nx_ = 0, dense_ny_ = 0;
  KeyIndex index_;
};

}  // namespace meniscus
