// meniscus — the block-parallel two-pass driver shared by the extractors (Williams 2008;
// Edespong 2010 §4.3: count the triangles of each block, prefix sum, then write): each block
// first gathers the inside masks of its cells plus a one-cell halo from up to 26 neighbour blocks,
// so the per-cell kernels (marching_impl.hpp) never touch the field's hash index.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "extract/edge_key.hpp"
#include "extract/marching.hpp"
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
/// writes 3 edge keys per triangle there (cell order z, y, x, then the kernel's order).
using BlockKernel = uint32_t (*)(const PaddedMasks& masks, uint64_t* out);

/// Runs `kernel` over blocks_to_march in one pass (each thread into its own pages, see
/// MarchedCorners) and returns the corner keys of all triangles, 3 per triangle, with the blocks'
/// triangle offsets and cell origins — the same for any number of threads. A cell yields at most
/// `max_triangles_per_cell` triangles.
MarchedCorners march_blocks(const SparseField& field, float iso, bool full_stencil, BlockKernel kernel,
                            uint32_t max_triangles_per_cell);

/// The BlockKernel of a cubic-lattice extractor: runs `cell` (march_cube_cell, march_kuhn_cell)
/// on every cell of the block, in x-fastest order, appending its triangles' corner keys.
template <uint32_t (*cell)(const uint8_t*, int, int, uint64_t, uint64_t*)>
uint32_t march_cubic_block(const PaddedMasks& masks, uint64_t* out) {
  const int n = masks.cells, sy = masks.padded, sz = masks.padded * masks.padded;
  uint32_t count = 0;
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const uint64_t cell_key = edge_key(masks.origin + Vec3i{x, y, z}, 0);
        count += cell(masks.at(x, y, z), sy, sz, cell_key, out != nullptr ? out + 3 * std::size_t(count) : nullptr);
      }
  return count;
}

}  // namespace meniscus
