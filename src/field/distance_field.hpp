// meniscus — the sparse distance-to-nearest-particle field (Williams 2008 §3; Edespong 2010
// §3.2): φ(x) = min_i |x − P_i| inside a band around the particles, the band limit elsewhere.
// The CPU's fast paths of band_blocks and distance_field of band_field.hpp (shared with the
// device, each sample gathering its particles): here each block scatters its particles, rows of
// samples at a time; test_distance_field.cpp holds the two to the same bits.
#pragma once

#include <cstddef>

#include "field/sparse_field.hpp"
#include "grid/hash_grid.hpp"

namespace meniscus {

/// Keys (pack_coords of block coordinates, sorted, unique) of the blocks whose cell box comes
/// within `band` of some point of the grid.
std::vector<uint64_t> band_blocks(const HashGrid& grid, const SampleLattice& lattice, float band);

/// Computes φ over the blocks `block_keys` (from band_blocks): each sample holds the distance
/// to its nearest point of `grid`, clamped to `band`; unallocated space reads as `band`.
/// Parallel over blocks; each block gathers the particles of the hash cells near it.
SparseField distance_field(const HashGrid& grid, const SampleLattice& lattice, float band,
                           std::vector<uint64_t> block_keys);

}  // namespace meniscus
