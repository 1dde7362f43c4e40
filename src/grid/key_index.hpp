// meniscus — a read-only open-addressing hash map from 64-bit keys to dense indices, built
// once from a list of unique keys. Used to find hash-grid cells and field blocks in O(1).
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>
#include <vector>

#include "meniscus/vec.hpp"

namespace meniscus {

inline constexpr uint64_t kNoKey = ~uint64_t(0);
inline constexpr uint32_t kNotFound = ~uint32_t(0);

/// Packs signed lattice coordinates (each within ±2^20) into 63 bits, order-preserving in z,y,x.
MENISCUS_HD constexpr uint64_t pack_coords(int32_t x, int32_t y, int32_t z) {
  constexpr int64_t kOffset = int64_t(1) << 20;
  return (uint64_t(int64_t(z) + kOffset) << 42) | (uint64_t(int64_t(y) + kOffset) << 21) |
         uint64_t(int64_t(x) + kOffset);
}
MENISCUS_HD constexpr Vec3i unpack_coords(uint64_t key) {
  constexpr int64_t kOffset = int64_t(1) << 20;
  constexpr uint64_t kMask = (uint64_t(1) << 21) - 1;
  return {int32_t(int64_t(key & kMask) - kOffset), int32_t(int64_t((key >> 21) & kMask) - kOffset),
          int32_t(int64_t((key >> 42) & kMask) - kOffset)};
}
/// Largest |coordinate| pack_coords accepts.
inline constexpr int32_t kMaxCoord = (1 << 20) - 2;

MENISCUS_HD constexpr uint64_t mix64(uint64_t k) {
  k ^= k >> 33;
  k *= 0xff51afd7ed558ccdULL;
  k ^= k >> 33;
  k *= 0xc4ceb9fe1a85ec53ULL;
  k ^= k >> 33;
  return k;
}

class KeyIndex {
 public:
  KeyIndex() = default;
  /// `keys` must be unique and must not contain kNoKey; key i maps to index i.
  explicit KeyIndex(std::span<const uint64_t> keys) { build(keys); }

  /// The number of slots build() allocates for `keys` keys (16 bytes each).
  static std::size_t capacity_for(std::size_t keys) {
    std::size_t cap = 16;
    while (cap < keys * 2) cap <<= 1;
    return cap;
  }

  void build(std::span<const uint64_t> keys) {
    const std::size_t cap = capacity_for(keys.size());
    mask_ = cap - 1;
    slots_.assign(cap, Slot{});
    for (std::size_t i = 0; i < keys.size(); ++i) {
      std::size_t slot = mix64(keys[i]) & mask_;
      while (slots_[slot].key != kNoKey) slot = (slot + 1) & mask_;
      slots_[slot] = {keys[i], uint32_t(i)};
    }
  }

  /// Index of `key`, or kNotFound.
  uint32_t find(uint64_t key) const {
    if (slots_.empty()) return kNotFound;
    std::size_t slot = mix64(key) & mask_;
    for (;;) {
      const Slot& s = slots_[slot];
      if (s.key == key) return s.value;
      if (s.key == kNoKey) return kNotFound;
      slot = (slot + 1) & mask_;
    }
  }

  std::size_t memory_bytes() const { return slots_.size() * sizeof(Slot); }

 private:
  // Key and value side by side: a lookup touches one cache line.
  struct Slot {
    uint64_t key = kNoKey;
    uint32_t value = kNotFound;
  };
  std::vector<Slot> slots_;
  std::size_t mask_ = 0;
};

/// The index of a lattice cell among a sorted list of unique cell keys (pack_coords): a dense array
/// over the box of the cells (kNotFound where unoccupied) where it takes no more memory than the
/// hash index (4 bytes a box cell against 16 a slot, about two slots a cell), else a KeyIndex. A
/// dense lookup reads neighbouring entries for neighbouring cells, where the hash scatters them
/// and the distance field's scatter waits on each slot's load.
class CellIndex {
 public:
  CellIndex() = default;
  /// `keys`: sorted, unique; key i maps to index i.
  explicit CellIndex(std::span<const uint64_t> keys) { build(keys); }

  void build(std::span<const uint64_t> keys) {
    dense_.clear();
    hash_ = KeyIndex();
    lo_ = {0, 0, 0};
    hi_ = {-1, -1, -1};
    if (keys.empty()) return;
    lo_ = hi_ = unpack_coords(keys[0]);
    for (const uint64_t k : keys) {
      const Vec3i c = unpack_coords(k);
      lo_ = {std::min(lo_.x, c.x), std::min(lo_.y, c.y), std::min(lo_.z, c.z)};
      hi_ = {std::max(hi_.x, c.x), std::max(hi_.y, c.y), std::max(hi_.z, c.z)};
    }
    nx_ = std::size_t(hi_.x - lo_.x) + 1;
    ny_ = std::size_t(hi_.y - lo_.y) + 1;
    const std::size_t nz = std::size_t(hi_.z - lo_.z) + 1;
    // (Each axis spans < 2^21 cells: the product fits a double exactly enough to compare.)
    if (double(nx_) * double(ny_) * double(nz) <= 4.0 * double(KeyIndex::capacity_for(keys.size()))) {
      dense_.assign(nx_ * ny_ * nz, kNotFound);
      for (std::size_t i = 0; i < keys.size(); ++i) dense_[slot(unpack_coords(keys[i]))] = uint32_t(i);
    } else {
      hash_.build(keys);
    }
  }

  /// Index of cell c, or kNotFound.
  uint32_t find(Vec3i c) const {
    if (c.x < lo_.x || c.y < lo_.y || c.z < lo_.z || c.x > hi_.x || c.y > hi_.y || c.z > hi_.z) return kNotFound;
    return dense_.empty() ? hash_.find(pack_coords(c.x, c.y, c.z)) : dense_[slot(c)];
  }
  bool dense() const { return !dense_.empty(); }
  /// The box of the cells (lo > hi on an axis when there are none).
  Vec3i box_min() const { return lo_; }
  Vec3i box_max() const { return hi_; }
  std::size_t memory_bytes() const { return dense_.size() * sizeof(uint32_t) + hash_.memory_bytes(); }

 private:
  std::size_t slot(Vec3i c) const {
    return (std::size_t(c.z - lo_.z) * ny_ + std::size_t(c.y - lo_.y)) * nx_ + std::size_t(c.x - lo_.x);
  }
  Vec3i lo_{0, 0, 0}, hi_{-1, -1, -1};
  std::size_t nx_ = 0, ny_ = 0;
  std::vector<uint32_t> dense_;
  KeyIndex hash_;
};

}  // namespace meniscus
