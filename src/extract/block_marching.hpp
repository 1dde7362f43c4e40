// meniscus — the block-parallel driver shared by the extractors (Williams 2008; Edespong 2010
// §4.3 counts, scans and writes; the CPU marches each block once, each thread into its own pages,
// see MarchedCorners): each block first gathers the inside masks of its cells plus a one-cell halo from up to 26 neighbour blocks,
// so the per-cell kernels (marching_impl.hpp) never touch the field's hash index.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <vector>

#include "extract/edge_key.hpp"
#include "extract/marching.hpp"
#include "extract/marching_impl.hpp"
#include "field/sparse_field.hpp"

namespace meniscus {

/// Inside masks of one block's cells and a one-cell halo: bit s of a cell's mask is set when its
/// sample s is inside (φ < iso). Samples of unallocated blocks read as background, i.e. outside.
struct PaddedMasks {
  static constexpr int kMaxPaddedCells = 10 * 10 * 10;  // (8 + 2)³ on the cubic lattice
  int cells = 0;                                        ///< cells per block edge
  int padded = 0;                                       ///< cells + 2
  Vec3i origin;                                         ///< first cell of the block
  std::array<uint8_t, kMaxPaddedCells> mask;

  /// Mask of local cell (x, y, z), each coordinate in [-1, cells].
  const uint8_t* at(int x, int y, int z) const { return mask.data() + ((z + 1) * padded + (y + 1)) * padded + (x + 1); }
  uint8_t* at(int x, int y, int z) { return mask.data() + ((z + 1) * padded + (y + 1)) * padded + (x + 1); }
};

/// Inside masks of the cells of every allocated block, one byte per cell (bit s: sample s is
/// inside), block b's cells at [b · cells³, (b + 1) · cells³) in the field's cell order. Computed
/// once, so the up to 27 gathers that read a block compare no floats.
std::vector<uint8_t> cell_inside_masks(const SparseField& field, float iso);

/// The blocks the extractor must march, sorted by block key: every allocated block, plus every
/// unallocated ("ghost") block some of whose cells own tetrahedra or cubes that reach into an
/// allocated block with an inside sample. Without the ghosts the surface would have a hole wherever
/// an inside sample touches the band's edge. `full_stencil`: cells read neighbours on both sides
/// (the A15 tile); otherwise only on the upper side (a cube from its lowest corner).
/// Throws ResourceError when an allocated block, widened by one block and 2 cells on each side
/// (its ghosts, halo and edge ends), does not fit the edge key (|cell| ≤ kEdgeKeyMaxCoord).
std::vector<Vec3i> blocks_to_march(const SparseField& field, std::span<const uint8_t> cell_masks, bool full_stencil);

/// Fills `masks` for the block with block coordinates `block` (allocated or not) from
/// cell_inside_masks. Returns false when the padded block is entirely inside or entirely outside
/// (it has no triangles).
bool gather_inside_masks(const SparseField& field, std::span<const uint8_t> cell_masks, Vec3i block,
                         PaddedMasks& masks);

/// Marches the cells of one padded block: returns its triangle count and, when `out` is not null,
/// writes 3 edge codes per triangle there (BlockEdgeCodes of the block's lattice; cell order z, y,
/// x, then the kernel's order). Codes, not keys: the kernel adds a 16-bit delta instead of a 64-bit
/// one, and the block's weld indexes its table with the code as it comes, without decoding a key
/// (decoding keys would be a large share of the weld's time).
using BlockKernel = uint32_t (*)(const PaddedMasks& masks, uint16_t* out);

/// Which edges of a padded block's cells cross the surface, from the inside masks alone: for each
/// edge type in `used` (of the lattice's `types`), whether its end samples' bits differ. One
/// table lookup for the cell's own samples and one per distinct far-cell offset (at most 14), each
/// giving the bits of all the types with that offset at once, instead of a test per type.
class CrossingTable {
 public:
  CrossingTable(const LatticeEdge* types, uint64_t used, int padded);
  /// The crossing mask (bit t: the edge of type t based at this cell crosses) of the cell whose
  /// mask is at `m` in a PaddedMasks with `padded` cells a side.
  uint64_t operator()(const uint8_t* m) const {
    uint64_t bits = near_[*m];
    for (int k = 0; k < count_; ++k) bits ^= far_[k][m[offset_[k]]];  // disjoint types: ^ is |
    return bits;
  }

 private:
  static constexpr int kMaxOffsets = 14;  // d ∈ {-1, 0, 1}³ after (z, y, x, s) canonical order
  int count_ = 0;
  int offset_[kMaxOffsets] = {};
  uint64_t near_[256] = {};            // per own mask: the used types whose first sample is inside
  uint64_t far_[kMaxOffsets][256] = {};  // per offset and far mask: those whose second sample is
};

/// Runs `kernel` over blocks_to_march in one pass (each thread into its own pages, see
/// MarchedCorners) and returns the corners of all triangles, 3 per triangle, with the blocks'
/// triangle offsets and cell origins, and the crossing edges (of the types in `used_types`) of
/// every block's own cells — the same for any number of threads. A cell yields at most
/// `max_triangles_per_cell` triangles.
MarchedCorners march_blocks(const SparseField& field, float iso, bool full_stencil, BlockKernel kernel,
                            uint32_t max_triangles_per_cell, uint64_t used_types);

/// The code deltas of a tile's tetrahedron edges (TileEdgeTable), for blocks coded by `codes`:
/// the word tables of the CPU's block kernels (marching_impl.hpp takes them as `delta(t, e)`).
template <int TetCount>
struct TileCodeDeltas {
  uint16_t d[TetCount][6] = {};
  constexpr uint16_t operator()(int tet, int edge) const { return d[tet][edge]; }
};
template <int TetCount>
constexpr TileCodeDeltas<TetCount> tile_code_deltas(const TileEdgeTable<TetCount>& table, BlockEdgeCodes codes) {
  TileCodeDeltas<TetCount> deltas;
  for (int t = 0; t < TetCount; ++t)
    for (int e = 0; e < 6; ++e) {
      const TetEdge& te = table.tet_edges[t][e];
      deltas.d[t][e] = codes.delta(te.dx, te.dy, te.dz, te.type);
    }
  return deltas;
}
/// Whether every edge of the table is based within [lo, hi] cells of its owning cell on each axis:
/// a block's cells then code all their edges in range when lo ≥ −2 and hi ≤ 1 (BlockEdgeCodes).
template <int TetCount>
constexpr bool edge_bases_within(const TileEdgeTable<TetCount>& table, int lo, int hi) {
  for (int t = 0; t < TetCount; ++t)
    for (int e = 0; e < 6; ++e) {
      const TetEdge& te = table.tet_edges[t][e];
      for (const int d : {te.dx, te.dy, te.dz})
        if (d < lo || d > hi) return false;
    }
  return true;
}
static_assert(edge_bases_within(kA15EdgeTable, -2, 1), "an A15 edge would leave its block's codes");
static_assert(edge_bases_within(kKuhnEdgeTable, 0, 1), "a cube edge would leave its block's codes");

/// The cubic lattice's block codes (8-cell blocks) and the deltas of its cube and Kuhn edges.
inline constexpr BlockEdgeCodes kCubicBlockCodes = BlockEdgeCodes::of(8, false);
inline constexpr TileCodeDeltas<kKuhnTetCount> kKuhnCodeDeltas = tile_code_deltas(kKuhnEdgeTable, kCubicBlockCodes);
struct CubeCodeDeltas {
  uint16_t d[12] = {};
  constexpr uint16_t operator()(int edge) const { return d[edge]; }
};
inline constexpr CubeCodeDeltas kCubeCodeDeltas = [] {
  CubeCodeDeltas deltas;
  for (int e = 0; e < 12; ++e) {
    const int c = kCubeEdgeCorners[e][0], a = cube_edge_axis(e);
    deltas.d[e] = kCubicBlockCodes.delta(cube_corner_coord(c, 0), cube_corner_coord(c, 1), cube_corner_coord(c, 2),
                                         cubic_edge_type(a == 0, a == 1, a == 2));
  }
  return deltas;
}();

/// The cell kernels of the cubic-lattice extractors in block codes (kCubicBlockCodes).
inline uint32_t march_cube_codes(const uint8_t* mask, int stride_y, int stride_z, uint16_t cell, uint16_t* out) {
  return march_cube_words(mask, stride_y, stride_z, kCubeCases, kCubeCodeDeltas, cell, out);
}
inline uint32_t march_kuhn_codes(const uint8_t* mask, int stride_y, int stride_z, uint16_t cell, uint16_t* out) {
  return march_kuhn_words(mask, stride_y, stride_z, kTetCases, kKuhnTets, kKuhnCodeDeltas, cell, out);
}

/// The BlockKernel of a cubic-lattice extractor: runs `cell` (march_cube_codes, march_kuhn_codes)
/// on every cell of the block, in x-fastest order, appending its triangles' corner codes.
template <uint32_t (*cell)(const uint8_t*, int, int, uint16_t, uint16_t*)>
uint32_t march_cubic_block(const PaddedMasks& masks, uint16_t* out) {
  const int n = masks.cells, sy = masks.padded, sz = masks.padded * masks.padded;
  if (n + 4 != kCubicBlockCodes.span) throw std::logic_error("march_cubic_block: a cubic block must be 8³ cells");
  uint32_t count = 0;
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const uint16_t cell_code = kCubicBlockCodes.encode({x + 2, y + 2, z + 2}, 0);
        count += cell(masks.at(x, y, z), sy, sz, cell_code, out != nullptr ? out + 3 * std::size_t(count) : nullptr);
      }
  return count;
}

}  // namespace meniscus
