// meniscus — Marching Cubes (Lorensen & Cline 1987) with the watertight table of cube_cases.hpp.
#include "extract/block_marching.hpp"
#include "extract/marching.hpp"
#include "extract/marching_impl.hpp"

namespace meniscus {

namespace {

uint32_t march_cube_block(const PaddedMasks& masks, uint64_t* out) {
  const int n = masks.cells, sy = masks.padded, sz = masks.padded * masks.padded;
  uint32_t count = 0;
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const uint8_t* m = masks.at(x, y, z);
        const uint64_t cell_key = edge_key(masks.origin + Vec3i{x, y, z}, 0);
        count += march_cube_cell(m, sy, sz, cell_key, out != nullptr ? out + 3 * std::size_t(count) : nullptr);
      }
  return count;
}

}  // namespace

std::vector<uint64_t> march_cubes(const SparseField& field, float iso) {
  return march_blocks(field, iso, /*full_stencil=*/false, march_cube_block);
}

}  // namespace meniscus
