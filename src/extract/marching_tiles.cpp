// meniscus — Marching Tiles (Williams 2008): the A15 acute tetrahedral tile, 46 per cell.
#include <stdexcept>

#include "extract/block_marching.hpp"
#include "extract/marching.hpp"
#include "extract/marching_impl.hpp"

namespace meniscus {

namespace {

// The A15 block is 4³ cells, padded to 6³.
constexpr int kPadded = 4 + 2;
constexpr TileVertexLookup kLookup = make_tile_vertex_lookup(kPadded, kPadded* kPadded);
constexpr BlockEdgeCodes kCodes = BlockEdgeCodes::of(4, true);
constexpr TileCodeDeltas<kA15TetCount> kCodeDeltas = tile_code_deltas(kA15EdgeTable, kCodes);

uint32_t march_tile_block(const PaddedMasks& masks, uint16_t* out) {
  const int n = masks.cells;
  constexpr int sy = kPadded, sz = kPadded * kPadded;
  if (masks.padded != kPadded) throw std::logic_error("march_tiles: the A15 block must be 4³ cells");
  uint32_t count = 0;
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const uint8_t* m = masks.at(x, y, z);
        if (!tile_cell_may_cross(m, sy, sz)) continue;
        const uint16_t cell_code = kCodes.encode({x + 2, y + 2, z + 2}, 0);
        count += march_tile_words(m, kLookup, kTetCases, kCodeDeltas, cell_code,
                                  out != nullptr ? out + 3 * std::size_t(count) : nullptr);
      }
  return count;
}

}  // namespace

MarchedCorners march_tiles(const SparseField& field, float iso) {
  return march_blocks(field, iso, /*full_stencil=*/true, march_tile_block, 2 * kA15TetCount,
                      (uint64_t(1) << kA15EdgeTypeCount) - 1);
}

}  // namespace meniscus
