// meniscus — vertex adjacency of a triangle mesh in CSR form (neighbours distinct, no self),
// plus vertex → incident-triangle lists and independent-set colourings for Gauss–Seidel.
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
  UninitVector<uint32_t> neighbors;    ///< ascending within each row (renumber_adjacency: see there)
  UninitVector<uint32_t> tri_offsets;  ///< #V+1: incident triangles of i are tri_ids[tri_offsets[i] ..)
  UninitVector<uint32_t> tri_ids;
  /// Empty, or the list of vertex i is list tri_row[i] (renumber_adjacency keeps the lists of the
  /// original numbering instead of permuting them: tri_row = the permutation).
  std::vector<uint32_t> tri_row;
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

/// The adjacency of the same mesh with its vertices renumbered: new vertex n is old vertex
/// order[n] (a permutation). Row n holds the relabelled entries of old row order[n] *in their old
/// order*, so that a sum over a row adds the same values in the same order as before the
/// renumbering (bit-identical results). The triangle lists (ids unchanged) are taken over as they
/// are, with tri_row = order (composed with the adjacency's own tri_row, if any): permuting them
/// would write a third of a gigabyte on splash 1M for the one pass that reads them
/// (build_cotan_operator). Much cheaper than build_adjacency of the relabelled triangles, which it
/// equals up to the order within rows. Corner lists (adopt_corner_lists) move with their rows: their
/// slots stay valid, as the rows keep their order. Compact neighbour lists come out compact again,
/// in the new numbering.
Adjacency renumber_adjacency(Adjacency&& adjacency, std::vector<uint32_t> order);

/// Replaces the triangle lists (tri_offsets, tri_ids, tri_row: freed) by corner lists, in the same
/// order: for each incident triangle of a vertex, the slots of its other two corners in the
/// vertex's row. The operator's build then needs neither the triangles nor a search of the row per
/// corner, and the lists take 2 bytes a triangle corner instead of 4 plus the triangle's 12.
/// `triangles` are the ones the lists index, in their own numbering; `rank` maps that numbering to
/// the adjacency's (empty: the same). Returns false, changing nothing, when a row is longer than
/// kMaxCornerRow (a slot must fit a byte).
bool adopt_corner_lists(Adjacency& adjacency, std::span<const Triangle> triangles, std::span<const uint32_t> rank);
/// Whether every row is short enough for corner lists (kMaxCornerRow).
bool corner_lists_fit(const Adjacency& adjacency);

/// Vertices grouped into colour classes such that no two vertices of a class are within
/// `distance` (1 or 2) edges of each other: vertices[offsets[c] .. offsets[c+1]) have colour c.
struct Coloring {
  std::vector<uint32_t> offsets;
  std::vector<uint32_t> vertices;
  std::size_t colors() const { return offsets.empty() ? 0 : offsets.size() - 1; }
};
/// Greedy colouring (deterministic: vertices in index order, smallest free colour).
Coloring color_vertices(const Adjacency& adjacency, int distance);
/// The colour of every vertex in color_vertices' colouring.
std::vector<uint16_t> greedy_colors(const Adjacency& adjacency, int distance);
/// The classes of per-vertex colours: vertices of each colour in ascending index order.
Coloring group_by_color(std::span<const uint16_t> color);

}  // namespace meniscus
