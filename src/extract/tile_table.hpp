// meniscus — the tetrahedral tilings marched by the extractors: the A15 acute tile of Marching
// Tiles (Williams 2008; the 46-tetrahedra Delaunay tile of marching-tiles.md) and the Kuhn
// (Freudenthal) 6-tetrahedra split of a cube for Marching Tetrahedra (Doi & Koide 1991), with
// the lattice edge types their vertices are keyed by. Plain constexpr arrays and MENISCUS_HD
// functions so a CUDA backend can share them.
//
// Edge types. An edge between samples (c1, s1) and (c2, s2) is canonicalised by ordering its
// endpoints by (cell z, y, x, sample) and translating so the first lies in cell (0,0,0); its type
// is its index in the sorted list of distinct canonical edges. Every tetrahedron edge is then a
// (base cell offset, type) pair, and edge_key(cell + offset, type) (edge_key.hpp) is the same
// integer for every tetrahedron, in any cell, that shares the edge — the weld key.
#pragma once

#include <cstdint>

#include "extract/edge_key.hpp"
#include "meniscus/vec.hpp"

namespace meniscus {

/// Sample `s` of cell (i+dx, j+dy, k+dz), relative to a cell (i, j, k).
struct LatticeSample {
  int8_t dx, dy, dz, s;
};

/// A canonical lattice edge: from sample s0 of the base cell to sample s1 of cell base + d.
struct LatticeEdge {
  int8_t s0;
  int8_t dx, dy, dz;
  int8_t s1;
};

/// One edge of a tetrahedron owned by some cell: based at cell + (dx, dy, dz), of type `type`;
/// `key_delta` = edge_key_delta(dx, dy, dz, type), what its key adds to the owning cell's key.
struct TetEdge {
  int8_t dx, dy, dz;
  uint8_t type;
  uint64_t key_delta;
};

/// The 6 edges of a tetrahedron as pairs of its vertex slots. Shared by every table below.
inline constexpr int kTetEdgeVertices[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};

// --- A15 tile ---------------------------------------------------------------------------------

/// The 8 A15 sample offsets in quarters of the cell edge (kA15Samples × 4, exact in integers).
inline constexpr int kA15SampleQuarters[8][3] = {{0, 0, 0}, {2, 2, 2}, {1, 2, 0}, {3, 2, 0},
                                                 {0, 1, 2}, {0, 3, 2}, {2, 0, 1}, {2, 0, 3}};

inline constexpr int kA15TetCount = 46;

/// The 46 tetrahedra owned by a cell (marching-tiles.md, from tools-a15_tile.py), each vertex a
/// sample of the cell or of a face/edge/corner neighbour; vertex order gives positive volume.
inline constexpr LatticeSample kA15Tets[kA15TetCount][4] = {
    {{0, 0, 0, 4}, {0, 0, 0, 2}, {0, 0, 0, 0}, {-1, 0, 0, 3}},
    {{0, 0, 0, 4}, {0, 0, 0, 2}, {0, 0, 0, 6}, {0, 0, 0, 0}},
    {{0, 0, -1, 7}, {0, 0, 0, 2}, {0, 0, 0, 0}, {0, 0, 0, 6}},
    {{0, 0, 0, 3}, {0, 0, -1, 7}, {0, 0, 0, 6}, {0, 0, 0, 2}},
    {{0, 0, 0, 3}, {0, 0, -1, 7}, {1, 0, 0, 0}, {0, 0, 0, 6}},
    {{0, -1, 0, 5}, {0, 0, 0, 7}, {0, 0, 0, 6}, {0, 0, 0, 4}},
    {{0, -1, 0, 5}, {0, 0, 0, 4}, {0, 0, 0, 6}, {0, 0, 0, 0}},
    {{0, 0, 0, 1}, {0, 0, 0, 4}, {0, 0, 0, 2}, {0, 0, 0, 6}},
    {{0, 0, 0, 1}, {0, 0, 0, 3}, {0, 0, 0, 6}, {0, 0, 0, 2}},
    {{0, 0, 0, 1}, {0, 0, 0, 7}, {0, 0, 0, 4}, {0, 0, 0, 6}},
    {{0, 0, 1, 2}, {0, 0, 0, 1}, {0, 0, 1, 3}, {0, 0, 0, 7}},
    {{0, 0, 1, 2}, {0, 0, 0, 1}, {0, 0, 0, 7}, {0, 0, 0, 4}},
    {{0, 0, 0, 5}, {0, 0, 0, 4}, {-1, 0, 0, 3}, {0, 0, 0, 2}},
    {{0, 0, 0, 5}, {0, 0, 0, 1}, {0, 0, 0, 4}, {0, 0, 0, 2}},
    {{0, 0, 0, 5}, {0, 0, 1, 2}, {0, 0, 0, 4}, {0, 0, 0, 1}},
    {{0, 1, 0, 6}, {0, 0, 0, 5}, {0, 0, 0, 2}, {0, 0, 0, 1}},
    {{0, 1, 0, 6}, {1, 0, 0, 5}, {0, 0, 0, 1}, {0, 0, 0, 3}},
    {{0, 1, 0, 6}, {0, 0, 0, 3}, {0, 0, 0, 2}, {0, 1, -1, 7}},
    {{0, 1, 0, 6}, {0, 0, 0, 1}, {0, 0, 0, 2}, {0, 0, 0, 3}},
    {{1, 0, 0, 4}, {0, 0, 0, 1}, {0, 0, 0, 6}, {0, 0, 0, 7}},
    {{1, 0, 0, 4}, {1, -1, 0, 5}, {0, 0, 0, 7}, {0, 0, 0, 6}},
    {{1, 0, 0, 4}, {1, -1, 0, 5}, {0, 0, 0, 6}, {1, 0, 0, 0}},
    {{1, 0, 0, 4}, {1, -1, 0, 5}, {1, 0, 1, 0}, {0, 0, 0, 7}},
    {{1, 0, 0, 4}, {0, 0, 0, 3}, {1, 0, 0, 0}, {0, 0, 0, 6}},
    {{1, 0, 0, 4}, {0, 0, 0, 1}, {0, 0, 0, 3}, {0, 0, 0, 6}},
    {{1, 0, 0, 4}, {1, 0, 1, 0}, {0, 0, 1, 3}, {0, 0, 0, 7}},
    {{1, 0, 0, 4}, {0, 0, 0, 1}, {0, 0, 0, 7}, {0, 0, 1, 3}},
    {{1, 0, 0, 4}, {1, 0, 0, 5}, {0, 0, 0, 3}, {0, 0, 0, 1}},
    {{1, 0, 0, 4}, {1, 0, 0, 5}, {0, 0, 0, 1}, {0, 0, 1, 3}},
    {{0, 1, 0, 7}, {0, 0, 1, 2}, {0, 0, 0, 1}, {0, 0, 1, 3}},
    {{0, 1, 0, 7}, {0, 1, 0, 6}, {1, 0, 0, 5}, {0, 0, 0, 1}},
    {{0, 1, 0, 7}, {0, 1, 0, 6}, {0, 0, 0, 1}, {0, 0, 0, 5}},
    {{0, 1, 0, 7}, {1, 0, 0, 5}, {1, 1, 1, 0}, {0, 0, 1, 3}},
    {{0, 1, 0, 7}, {1, 0, 0, 5}, {0, 0, 1, 3}, {0, 0, 0, 1}},
    {{0, 1, 0, 7}, {0, 0, 0, 5}, {0, 0, 0, 1}, {0, 0, 1, 2}},
    {{0, 1, 0, 7}, {0, 1, 1, 0}, {0, 0, 0, 5}, {0, 0, 1, 2}},
    {{0, 1, 0, 0}, {0, 0, 0, 5}, {-1, 0, 0, 3}, {0, 0, 0, 2}},
    {{0, 1, 0, 0}, {0, 1, 0, 6}, {0, 0, 0, 5}, {0, 0, 0, 2}},
    {{0, 1, 0, 0}, {0, 1, 0, 6}, {0, 0, 0, 2}, {0, 1, -1, 7}},
    {{0, 0, 1, 0}, {0, -1, 0, 5}, {0, 0, 0, 4}, {0, 0, 0, 7}},
    {{0, 0, 1, 0}, {0, 0, 1, 2}, {0, 0, 0, 7}, {0, 0, 0, 4}},
    {{1, 1, 0, 0}, {0, 1, 0, 6}, {0, 0, 0, 3}, {1, 0, 0, 5}},
    {{1, 1, 0, 0}, {0, 1, 0, 6}, {0, 1, -1, 7}, {0, 0, 0, 3}},
    {{-1, 0, 1, 3}, {0, 1, 1, 0}, {0, 0, 1, 2}, {0, 0, 0, 5}},
    {{-1, 0, 1, 3}, {0, 0, 0, 5}, {0, 0, 1, 2}, {0, 0, 0, 4}},
    {{-1, 0, 1, 3}, {0, 0, 1, 0}, {0, 0, 0, 4}, {0, 0, 1, 2}},
};

/// Strict weak order on samples by (cell z, y, x, sample): the canonical endpoint order.
MENISCUS_HD constexpr bool sample_less(LatticeSample a, LatticeSample b) {
  if (a.dz != b.dz) return a.dz < b.dz;
  if (a.dy != b.dy) return a.dy < b.dy;
  if (a.dx != b.dx) return a.dx < b.dx;
  return a.s < b.s;
}

/// The canonical edge (first endpoint translated to cell 0) through samples a and b, and in
/// `base` the cell offset of its first endpoint.
MENISCUS_HD constexpr LatticeEdge canonical_edge(LatticeSample a, LatticeSample b, LatticeSample* base) {
  if (sample_less(b, a)) {
    const LatticeSample t = a;
    a = b;
    b = t;
  }
  *base = a;
  return {a.s, int8_t(b.dx - a.dx), int8_t(b.dy - a.dy), int8_t(b.dz - a.dz), b.s};
}

MENISCUS_HD constexpr bool edge_less(LatticeEdge a, LatticeEdge b) {
  if (a.s0 != b.s0) return a.s0 < b.s0;
  if (a.dz != b.dz) return a.dz < b.dz;
  if (a.dy != b.dy) return a.dy < b.dy;
  if (a.dx != b.dx) return a.dx < b.dx;
  return a.s1 < b.s1;
}
MENISCUS_HD constexpr bool edge_equal(LatticeEdge a, LatticeEdge b) { return !edge_less(a, b) && !edge_less(b, a); }

/// Edge types of a lattice (at most 64, the key's type field) and the (base, type) of every edge
/// of every tetrahedron of a tile of `TetCount` tetrahedra.
template <int TetCount>
struct TileEdgeTable {
  int type_count = 0;
  LatticeEdge types[64] = {};
  TetEdge tet_edges[TetCount][6] = {};
};

/// Derives the edge types from the tetrahedra, so the table cannot disagree with the tile.
/// Evaluated at compile time; an impossible tile (more than 64 types) fails to compile.
template <int TetCount>
constexpr TileEdgeTable<TetCount> build_tile_edge_table(const LatticeSample (&tets)[TetCount][4]) {
  TileEdgeTable<TetCount> table;
  for (int t = 0; t < TetCount; ++t) {
    for (const auto& pair : kTetEdgeVertices) {
      LatticeSample base{};
      const LatticeEdge e = canonical_edge(tets[t][pair[0]], tets[t][pair[1]], &base);
      int pos = 0;  // insertion into the sorted list of distinct types
      while (pos < table.type_count && edge_less(table.types[pos], e)) ++pos;
      if (pos < table.type_count && edge_equal(table.types[pos], e)) continue;
      if (table.type_count == 64) throw "more than 64 edge types";  // compile-time error
      for (int k = table.type_count; k > pos; --k) table.types[k] = table.types[k - 1];
      table.types[pos] = e;
      ++table.type_count;
    }
  }
  for (int t = 0; t < TetCount; ++t) {
    for (int k = 0; k < 6; ++k) {
      LatticeSample base{};
      const LatticeEdge e = canonical_edge(tets[t][kTetEdgeVertices[k][0]], tets[t][kTetEdgeVertices[k][1]], &base);
      int type = 0;
      while (!edge_equal(table.types[type], e)) ++type;
      table.tet_edges[t][k] = {base.dx, base.dy, base.dz, uint8_t(type),
                               edge_key_delta(base.dx, base.dy, base.dz, type)};
    }
  }
  return table;
}

inline constexpr TileEdgeTable<kA15TetCount> kA15EdgeTable = build_tile_edge_table(kA15Tets);
/// marching-tiles.md: 54 distinct edges per cell (48 with 5 incident tetrahedra, 6 with 6).
inline constexpr int kA15EdgeTypeCount = kA15EdgeTable.type_count;
static_assert(kA15EdgeTypeCount == 54, "the A15 tile must have 54 edge types");

// --- Kuhn split of the cube (cubic lattice) ------------------------------------------------------

inline constexpr int kKuhnTetCount = 6;

/// The 6 tetrahedra of the Kuhn split of the cube owned by a cell, as samples (s = 0) of the
/// cube's corners: one per axis permutation p, the monotone path 0 → e_p0 → e_p0 + e_p1 →
/// (1,1,1) along cube edges, so all share the main diagonal. The split is the same in every cube
/// (face diagonals all run from the face's lowest corner), so neighbouring cubes agree on their
/// shared faces. The last two vertices are swapped where that makes the volume positive.
inline constexpr LatticeSample kKuhnTets[kKuhnTetCount][4] = {
    {{0, 0, 0, 0}, {1, 0, 0, 0}, {1, 1, 0, 0}, {1, 1, 1, 0}},  // x, y, z
    {{0, 0, 0, 0}, {1, 0, 0, 0}, {1, 1, 1, 0}, {1, 0, 1, 0}},  // x, z, y
    {{0, 0, 0, 0}, {0, 1, 0, 0}, {1, 1, 1, 0}, {1, 1, 0, 0}},  // y, x, z
    {{0, 0, 0, 0}, {0, 1, 0, 0}, {0, 1, 1, 0}, {1, 1, 1, 0}},  // y, z, x
    {{0, 0, 0, 0}, {0, 0, 1, 0}, {1, 0, 1, 0}, {1, 1, 1, 0}},  // z, x, y
    {{0, 0, 0, 0}, {0, 0, 1, 0}, {1, 1, 1, 0}, {0, 1, 1, 0}},  // z, y, x
};

/// 6 × the signed volume of a tetrahedron of the cubic lattice (integer, exact).
constexpr int kuhn_tet_volume6(const LatticeSample (&t)[4]) {
  const int a[3] = {t[1].dx - t[0].dx, t[1].dy - t[0].dy, t[1].dz - t[0].dz};
  const int b[3] = {t[2].dx - t[0].dx, t[2].dy - t[0].dy, t[2].dz - t[0].dz};
  const int c[3] = {t[3].dx - t[0].dx, t[3].dy - t[0].dy, t[3].dz - t[0].dz};
  return a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0]);
}
static_assert([] {
  for (const auto& t : kKuhnTets)
    if (kuhn_tet_volume6(t) != 1) return false;  // positive, and 6 × 1/6 fills the cube
  return true;
}());

/// Edge types of the cubic lattice: the 7 offsets d ∈ {0,1}³ ∖ 0, type = (dx + 2dy + 4dz) − 1.
/// Kuhn tetrahedra use all 7 (axes, face diagonals, main diagonal); Marching Cubes the 3 axes
/// (types 0, 1 and 3). Derived from the Kuhn tetrahedra like the A15 types, and checked.
inline constexpr TileEdgeTable<kKuhnTetCount> kKuhnEdgeTable = build_tile_edge_table(kKuhnTets);
inline constexpr int kCubicEdgeTypeCount = 7;
static_assert(kKuhnEdgeTable.type_count == kCubicEdgeTypeCount);
MENISCUS_HD constexpr int cubic_edge_type(int dx, int dy, int dz) { return dx + 2 * dy + 4 * dz - 1; }
static_assert([] {
  for (int t = 0; t < kCubicEdgeTypeCount; ++t) {
    const LatticeEdge e = kKuhnEdgeTable.types[t];
    if (e.s0 != 0 || e.s1 != 0 || cubic_edge_type(e.dx, e.dy, e.dz) != t) return false;
  }
  return true;
}());

// --- decoding a key ---------------------------------------------------------------------------------

/// The two end samples of the edge with `key`, given the lattice's table of edge types
/// (kA15EdgeTable.types or kKuhnEdgeTable.types, or a device copy of one).
MENISCUS_HD constexpr void edge_key_samples(uint64_t key, const LatticeEdge* types, Vec3i* cell0, int* s0, Vec3i* cell1,
                                            int* s1) {
  const Vec3i base = edge_key_cell(key);
  const LatticeEdge e = types[edge_key_type(key)];
  *cell0 = base;
  *s0 = e.s0;
  *cell1 = Vec3i{base.x + e.dx, base.y + e.dy, base.z + e.dz};
  *s1 = e.s1;
}

/// The two end samples of the edge with `key` on the A15 (a15 = true) or cubic lattice (host).
constexpr void edge_key_samples(uint64_t key, bool a15, Vec3i* cell0, int* s0, Vec3i* cell1, int* s1) {
  edge_key_samples(key, a15 ? kA15EdgeTable.types : kKuhnEdgeTable.types, cell0, s0, cell1, s1);
}

}  // namespace meniscus
