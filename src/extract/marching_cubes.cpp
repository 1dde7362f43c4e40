// meniscus — Marching Cubes (Lorensen & Cline 1987) with the watertight table of cube_cases.hpp.
#include "extract/block_marching.hpp"
#include "extract/marching.hpp"
#include "extract/marching_impl.hpp"

namespace meniscus {

MarchedCorners march_cubes(const SparseField& field, float iso) {
  return march_blocks(field, iso, /*full_stencil=*/false, march_cubic_block<march_cube_codes>, kCubeMaxTriangles,
                      kCubeEdgeTypes);
}

}  // namespace meniscus
