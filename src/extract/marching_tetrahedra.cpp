// meniscus — Marching Tetrahedra (Doi & Koide 1991) on the Kuhn 6-tetrahedra split of each cube.
#include "extract/block_marching.hpp"
#include "extract/marching.hpp"
#include "extract/marching_impl.hpp"

namespace meniscus {

MarchedCorners march_tetrahedra(const SparseField& field, float iso) {
  return march_blocks(field, iso, /*full_stencil=*/false, march_cubic_block<march_kuhn_codes>, 12,
                      (uint64_t(1) << kCubicEdgeTypeCount) - 1);
}

}  // namespace meniscus
