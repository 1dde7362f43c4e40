// meniscus — the per-cell kernels of the three extractors, written once for the CPU and the CUDA
// backend (extract_backend.hpp): Marching Tiles (Williams 2008), Marching Cubes (Lorensen & Cline 1987) and
// Marching Tetrahedra on the Kuhn split (Doi & Koide 1991).
//
// Each kernel reads inside masks of a padded block (bit s of a cell's mask: sample s is inside,
// φ < iso; cells addressed as mask[dx + dy·stride_y + dz·stride_z] from the kernel's own cell) and
// returns the number of triangles of its cell. When `out` is not null it also writes 3 words per
// triangle there, in a fixed order (tetrahedron/case order), which makes the extraction
// deterministic: edge keys, where `cell_key` is edge_key(cell, 0) and an edge's key is cell_key +
// its key delta, or (the CPU's block kernels) the block's 16-bit edge codes, the same sum mod 2^16.
#pragma once

#include <cstdint>

#include "extract/cube_cases.hpp"
#include "extract/tetrahedron_cases.hpp"
#include "extract/tile_table.hpp"
#include "meniscus/vec.hpp"

namespace meniscus {

/// Where the kernel finds each tile vertex's inside bit: the offset of its cell in a padded mask
/// array with strides (1, stride_y, stride_z) and the bit of its sample. Built once per layout, so
/// the inner loop does no index arithmetic (it dominated the profile).
struct TileVertexLookup {
  int16_t offset[kA15TetCount][4];
  uint8_t bit[kA15TetCount][4];
};

MENISCUS_HD constexpr TileVertexLookup make_tile_vertex_lookup(int stride_y, int stride_z) {
  TileVertexLookup lookup{};
  for (int t = 0; t < kA15TetCount; ++t)
    for (int v = 0; v < 4; ++v) {
      const LatticeSample& p = kA15Tets[t][v];
      lookup.offset[t][v] = int16_t(p.dx + p.dy * stride_y + p.dz * stride_z);
      lookup.bit[t][v] = uint8_t(1u << p.s);
    }
  return lookup;
}

/// The tables the kernels read, as one struct: the CPU passes the constexpr tables of the headers,
/// the CUDA backend a copy in device memory (device code cannot index host constexpr arrays).
struct MarchingTables {
  TetCaseTable tet_cases;
  TileEdgeTable<kA15TetCount> a15_edges;
  TileEdgeTable<kKuhnTetCount> kuhn_edges;
  CubeCaseTable cube_cases;
  uint64_t cube_edge_deltas[12];
  LatticeSample kuhn_tets[kKuhnTetCount][4];
};

/// The tables of the headers, gathered (host side; the CUDA backend copies this to the device).
inline MarchingTables host_marching_tables() {
  MarchingTables t{kTetCases, kA15EdgeTable, kKuhnEdgeTable, kCubeCases, {}, {}};
  for (int e = 0; e < 12; ++e) t.cube_edge_deltas[e] = kCubeEdgeKeyDeltas.v[e];
  for (int k = 0; k < kKuhnTetCount; ++k)
    for (int v = 0; v < 4; ++v) t.kuhn_tets[k][v] = kKuhnTets[k][v];
  return t;
}

/// Whether any of the 46 tetrahedra of the tile cell at `mask` can hold surface: they read only
/// the 27 cells around it, so a cell whose 27 masks all agree (all samples inside or all outside,
/// as almost everywhere in a band) is skipped.
MENISCUS_HD inline bool tile_cell_may_cross(const uint8_t* mask, int stride_y, int stride_z) {
  unsigned any = 0, all = 0xFF;
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const unsigned v = mask[dx + dy * stride_y + dz * stride_z];
        any |= v;
        all &= v;
      }
  return !(any == 0 || all == 0xFF);
}

/// An edge's word is its owning cell's word plus the edge's delta, in the word's modular
/// arithmetic: edge keys (uint64_t, edge_key_delta) or a block's edge codes (uint16_t,
/// BlockEdgeCodes::delta, block_marching.hpp). These give a kernel its deltas from the key tables.
template <int TetCount>
struct TileKeyDeltas {
  const TileEdgeTable<TetCount>* table;
  MENISCUS_HD uint64_t operator()(int tet, int edge) const { return table->tet_edges[tet][edge].key_delta; }
};
struct CubeKeyDeltas {
  const uint64_t* deltas;
  MENISCUS_HD uint64_t operator()(int edge) const { return deltas[edge]; }
};

/// Marching Tiles: the 46 A15 tetrahedra owned by one cell, `mask` pointing at the cell's own
/// mask in a layout described by `lookup`; `delta(t, e)`: what edge e of tetrahedron t adds to
/// the cell's word `cell`. The caller skips cells whose neighbourhood is all inside or all outside;
/// the kernel is still correct for them (0).
template <class Word, class Deltas>
MENISCUS_HD inline uint32_t march_tile_words(const uint8_t* mask, const TileVertexLookup& lookup,
                                             const TetCaseTable& tet_cases, const Deltas& delta, Word cell, Word* out) {
  uint32_t n = 0;
  for (int t = 0; t < kA15TetCount; ++t) {
    const int16_t* o = lookup.offset[t];
    const uint8_t* b = lookup.bit[t];
    const int c = ((mask[o[0]] & b[0]) ? 1 : 0) | ((mask[o[1]] & b[1]) ? 2 : 0) | ((mask[o[2]] & b[2]) ? 4 : 0) |
                  ((mask[o[3]] & b[3]) ? 8 : 0);
    const TetCase& tc = tet_cases.cases[c];
    if (out != nullptr) {
      for (int k = 0; k < tc.count; ++k)
        for (int j = 0; j < 3; ++j) out[3 * (n + k) + j] = Word(cell + delta(t, tc.edges[k][j]));
    }
    n += tc.count;
  }
  return n;
}

MENISCUS_HD inline uint32_t march_tile_cell(const uint8_t* mask, const TileVertexLookup& lookup,
                                            const TetCaseTable& tet_cases, const TileEdgeTable<kA15TetCount>& edges,
                                            uint64_t cell_key, uint64_t* out) {
  return march_tile_words(mask, lookup, tet_cases, TileKeyDeltas<kA15TetCount>{&edges}, cell_key, out);
}

/// Inside pattern of the cube whose lowest corner is the kernel's cell (cubic lattice, sample 0).
MENISCUS_HD inline int cube_case(const uint8_t* mask, int stride_y, int stride_z) {
  int c = 0;
  for (int k = 0; k < 8; ++k)
    c |= (mask[cube_corner_coord(k, 0) + cube_corner_coord(k, 1) * stride_y + cube_corner_coord(k, 2) * stride_z] & 1)
         << k;
  return c;
}

/// Marching Cubes: the cube whose lowest corner is the kernel's cell; `delta(e)`: what cube edge
/// e adds to the cell's word.
template <class Word, class Deltas>
MENISCUS_HD inline uint32_t march_cube_words(const uint8_t* mask, int stride_y, int stride_z,
                                             const CubeCaseTable& cube_cases, const Deltas& delta, Word cell,
                                             Word* out) {
  const CubeCase& cc = cube_cases.cases[cube_case(mask, stride_y, stride_z)];
  if (out != nullptr) {
    for (int k = 0; k < cc.count; ++k)
      for (int j = 0; j < 3; ++j) out[3 * k + j] = Word(cell + delta(cc.edges[k][j]));
  }
  return cc.count;
}

MENISCUS_HD inline uint32_t march_cube_cell(const uint8_t* mask, int stride_y, int stride_z, const MarchingTables& tables,
                                            uint64_t cell_key, uint64_t* out) {
  return march_cube_words(mask, stride_y, stride_z, tables.cube_cases, CubeKeyDeltas{tables.cube_edge_deltas},
                          cell_key, out);
}

/// Marching Tetrahedra: the 6 Kuhn tetrahedra of the cube whose lowest corner is the kernel's
/// cell; `delta(t, e)` as for march_tile_words.
template <class Word, class Deltas>
MENISCUS_HD inline uint32_t march_kuhn_words(const uint8_t* mask, int stride_y, int stride_z,
                                             const TetCaseTable& tet_cases,
                                             const LatticeSample (&kuhn_tets)[kKuhnTetCount][4], const Deltas& delta,
                                             Word cell, Word* out) {
  const int corners = cube_case(mask, stride_y, stride_z);
  if (corners == 0 || corners == 255) return 0;
  uint32_t n = 0;
  for (int t = 0; t < kKuhnTetCount; ++t) {
    int c = 0;
    for (int v = 0; v < 4; ++v) {
      const LatticeSample& p = kuhn_tets[t][v];
      c |= ((corners >> (p.dx + 2 * p.dy + 4 * p.dz)) & 1) << v;
    }
    const TetCase& tc = tet_cases.cases[c];
    if (out != nullptr) {
      for (int k = 0; k < tc.count; ++k)
        for (int j = 0; j < 3; ++j) out[3 * (n + k) + j] = Word(cell + delta(t, tc.edges[k][j]));
    }
    n += tc.count;
  }
  return n;
}

MENISCUS_HD inline uint32_t march_kuhn_cell(const uint8_t* mask, int stride_y, int stride_z, const MarchingTables& tables,
                                            uint64_t cell_key, uint64_t* out) {
  return march_kuhn_words(mask, stride_y, stride_z, tables.tet_cases, tables.kuhn_tets,
                          TileKeyDeltas<kKuhnTetCount>{&tables.kuhn_edges}, cell_key, out);
}

// --- the CPU's entry points: the kernels above with the constexpr tables (host only) -------------

inline uint32_t march_tile_cell(const uint8_t* mask, const TileVertexLookup& lookup, uint64_t cell_key, uint64_t* out) {
  return march_tile_cell(mask, lookup, kTetCases, kA15EdgeTable, cell_key, out);
}
inline const MarchingTables& cpu_marching_tables() {
  static const MarchingTables tables = host_marching_tables();
  return tables;
}
inline uint32_t march_cube_cell(const uint8_t* mask, int stride_y, int stride_z, uint64_t cell_key, uint64_t* out) {
  return march_cube_cell(mask, stride_y, stride_z, cpu_marching_tables(), cell_key, out);
}
inline uint32_t march_kuhn_cell(const uint8_t* mask, int stride_y, int stride_z, uint64_t cell_key, uint64_t* out) {
  return march_kuhn_cell(mask, stride_y, stride_z, cpu_marching_tables(), cell_key, out);
}

}  // namespace meniscus
