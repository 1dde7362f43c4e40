// meniscus — vertex adjacency of a triangle mesh in CSR form (neighbours distinct, no self), plus
// vertex → incident-triangle lists. Rows and lists are ascending: a sum over a row adds its values
// in the order of the vertex numbering, which is the same for every frame around a vertex
// (reorder_vertices_spatially keys it on positions alone), so the sums are local too.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "common/huge_pages.hpp"
#include "meniscus/mesh.hpp"
#include "smooth/compact_neighbors.hpp"
#include "smooth/operators_impl.hpp"

namespace meniscus {

struct Adjacency {
  // Filled in parallel, hence UninitVector (no serial zeroing first).
  UninitVector<uint32_t> offsets;      ///< #V+1: neighbours of i are neighbors[offsets[i] .. offsets[i+1])
  UninitVector<uint32_t> neighbors;    ///< ascending within each row
  UninitVector<uint32_t> tri_offsets;  ///< #V+1: incident triangles of i are tri_ids[tri_offsets[i] ..)
  UninitVector<uint32_t> tri_ids;
  /// Empty, or (adopt_corner_lists) the triangle lists instead as the row slots of each incident
  /// triangle's other two corners: corners[corner_offsets[i] .. corner_offsets[i+1]) for vertex i.
  UninitVector<uint32_t> corner_offsets;
  UninitVector<CornerSlots> corners;
  /// Empty, or (compact_neighbors) the neighbours in 16-bit form, `neighbors` then freed.
  CompactNeighborLists compact;

  std::size_t vertex_count() const { return offsets.empty() ? 0 : offsets.size() - 1; }
  std::size_t entry_count() const { return offsets.empty() ? 0 : offsets.back(); }
  /// Row i (not once compacted).
  std::span<const uint32_t> row(uint32_t i) const {
    return {neighbors.data() + offsets[i], offsets[i + 1] - offsets[i]};
  }
  /// Replaces `neighbors` by their 16-bit form for good (compact_neighbor_lists: 2 bytes an entry
  /// instead of 4); the row functions of operators_impl.hpp read either (with_neighbors).
  void compact_neighbors() {
    compact = compact_neighbor_lists(offsets, neighbors);
    UninitVector<uint32_t>().swap(neighbors);
  }
  /// f(neighbours) with the neighbour lists in the form the row functions of operators_impl.hpp
  /// take (neighbor_at): the CSR array, or its compact view. f is instantiated for both.
  template <class F>
  decltype(auto) with_neighbors(F&& f) const {
    if (!compact.empty()) return f(compact.view());
    return f(static_cast<const uint32_t*>(neighbors.data()));
  }
};

/// Builds the adjacency of `vertex_count` vertices from the triangles (parallel).
Adjacency build_adjacency(std::size_t vertex_count, std::span<const Triangle> triangles);

/// Replaces the triangle lists (tri_offsets, tri_ids: freed) by corner lists, in the same order: for
/// each incident triangle of a vertex, the slots of its other two corners in the vertex's row. The
/// operator's build then needs neither the triangles nor a search of the row per corner, and the
/// lists take 2 bytes a triangle corner instead of 4 plus the triangle's 12. `triangles` are the
/// ones the lists index. Returns false, changing nothing, when a row is longer than kMaxCornerRow
/// (a slot must fit a byte).
bool adopt_corner_lists(Adjacency& adjacency, std::span<const Triangle> triangles);
/// Whether every row is short enough for corner lists (kMaxCornerRow).
bool corner_lists_fit(const Adjacency& adjacency);

}  // namespace meniscus
