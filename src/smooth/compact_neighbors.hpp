// meniscus — the adjacency's neighbour lists in 16 bits an entry, for the smoothing sweeps (CPU).
//
// The sweeps' vertices are numbered in space (a Z-ordered mesh, renumbered only within chunks of
// 4096): on the meshes the pipeline makes nearly all of a row's neighbours lie within ±32767 of the
// row's own vertex. Each entry is then stored as that difference, and the few further ones as an
// index into a list kept aside: 2 bytes an entry instead of 4, about 12 bytes a vertex of the
// largest arrays of the B sweeps. Reading an entry costs an add; a far one a load (a binary search
// past a chunk's first 2767 far entries).
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>
#include <vector>

#include "common/huge_pages.hpp"

namespace meniscus {

/// A view of CompactNeighborLists for the row functions of operators_impl.hpp (neighbor_at).
/// An entry within ±kNear of its row's vertex holds the difference; a far one holds kIndexBase + k
/// for the k-th far entry of its chunk of rows (the first kIndexed of a chunk: one load finds the
/// neighbour), or kFar (the rest: a binary search among the chunk's far entries).
struct CompactNeighbors {
  static constexpr int16_t kNear = 30000;
  static constexpr int16_t kIndexBase = kNear + 1;
  static constexpr uint32_t kIndexed = uint32_t(INT16_MAX - kNear);  ///< 2767 a chunk
  static constexpr int16_t kFar = INT16_MIN;
  static constexpr uint32_t kChunkShift = 12;  ///< far entries are listed by chunks of 4096 rows
  const int16_t* delta;        ///< per entry: as above
  const uint32_t* far_entry;   ///< the far entries, ascending
  const uint32_t* far_vertex;  ///< their neighbours
  const uint32_t* chunk_far;   ///< per chunk of rows, its first index into far_entry (one past the last chunk too)

  /// The neighbour of far entry e of row i, which holds d.
  [[gnu::noinline, gnu::cold]] uint32_t far(uint32_t i, uint32_t e, int16_t d) const {
    const uint32_t q = i >> kChunkShift;
    if (d != kFar) return far_vertex[chunk_far[q] + uint32_t(d - kIndexBase)];
    const uint32_t* first = far_entry + chunk_far[q] + kIndexed;
    const uint32_t* last = far_entry + chunk_far[q + 1];
    return far_vertex[std::lower_bound(first, last, e) - far_entry];
  }
};

/// Entry e of row i.
inline uint32_t neighbor_at(const CompactNeighbors& c, uint32_t i, uint32_t e) {
  const int16_t d = c.delta[e];
  if (uint32_t(int32_t(d) + CompactNeighbors::kNear) <= uint32_t(2 * CompactNeighbors::kNear)) [[likely]]
    return uint32_t(int32_t(i) + d);
  return c.far(i, e, d);
}

/// The storage of CompactNeighbors.
struct CompactNeighborLists {
  UninitVector<int16_t> delta;
  std::vector<uint32_t> far_entry, far_vertex, chunk_far;

  bool empty() const { return chunk_far.empty(); }
  CompactNeighbors view() const { return {delta.data(), far_entry.data(), far_vertex.data(), chunk_far.data()}; }
  std::size_t memory_bytes() const {
    return delta.size() * sizeof(int16_t) + (far_entry.size() + far_vertex.size() + chunk_far.size()) * sizeof(uint32_t);
  }
};

/// The 16-bit form of the CSR rows (offsets, neighbors), row i being vertex i (parallel).
CompactNeighborLists compact_neighbor_lists(std::span<const uint32_t> offsets, std::span<const uint32_t> neighbors);

}  // namespace meniscus
