// meniscus — the sparse field's band and samples (Williams 2008 §3; Edespong 2010 §3.2), written
// once for either backend over its primitives: the band's blocks from the occupied hash cells
// (count, scan, write, sort, unique), then one pass over every sample of every block gathering the
// particles of the nearby hash cells (no atomics, no scatter): the distance to the nearest
// particle (distance_field_impl.hpp) or the kernel sums (kernel_field_sample, kernel_impl.hpp,
// which adds the CPU scatter's terms in its order). The backend is a tag (Host or cuda::Device)
// whose primitives are found by argument-dependent lookup; a file that instantiates these for the
// device includes cuda/primitives.hpp first. The CPU pipeline fills its SparseField by scatter
// (distance_field.cpp, kernel_field.cpp); tests/unit/test_distance_field.cpp holds those to the
// versions here run with Host{} bit for bit.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <utility>

#include "common/buffer.hpp"
#include "common/primitives.hpp"
#include "field/distance_field_impl.hpp"
#include "field/field_buffers.hpp"
#include "field/kernel_impl.hpp"
#include "field/sparse_field.hpp"
#include "grid/grid_buffers.hpp"
#include "grid/key_index.hpp"

namespace meniscus {

namespace band_field {

/// counts[i]: how many blocks hash cell i's box, widened by the band, touches.
struct BlockCounts {
  const uint64_t* cells;
  float cell_size, band, block_size;
  uint64_t* counts;
  MENISCUS_HD void operator()(uint64_t i) const {
    const Vec3i c = unpack_coords(cells[i]);
    uint64_t count = 1;
    for (int a = 0; a < 3; ++a) {
      int32_t lo, hi;
      band_block_range(c[a], cell_size, band, block_size, &lo, &hi);
      count *= uint64_t(int64_t(hi) - lo + 1);
    }
    counts[i] = count;
  }
};

/// Writes hash cell i's blocks' keys at offsets[i] (z, y, x order).
struct BlockKeys {
  const uint64_t* cells;
  float cell_size, band, block_size;
  const uint64_t* offsets;
  uint64_t* keys;
  MENISCUS_HD void operator()(uint64_t i) const {
    const Vec3i c = unpack_coords(cells[i]);
    int32_t lo[3], hi[3];
    for (int a = 0; a < 3; ++a) band_block_range(c[a], cell_size, band, block_size, &lo[a], &hi[a]);
    uint64_t out = offsets[i];
    for (int32_t z = lo[2]; z <= hi[2]; ++z)
      for (int32_t y = lo[1]; y <= hi[1]; ++y)
        for (int32_t x = lo[0]; x <= hi[0]; ++x) keys[out++] = pack_coords(x, y, z);
  }
};

/// Sample j of a field whose blocks are keyed by block_keys (block j / kBlockSamples, index
/// j % kBlockSamples in it, cells of n³ a block, spc samples a cell): its block's first cell, its
/// own cell and its offset in that cell.
struct BlockSample {
  Vec3i origin, g;
  float off[3];
  MENISCUS_HD BlockSample(uint64_t j, const uint64_t* block_keys, int n, int spc, const SampleOffsets& offsets) {
    const uint64_t b = j / uint64_t(kBlockSamples);
    const int idx = int(j % uint64_t(kBlockSamples));
    const Vec3i bc = unpack_coords(block_keys[b]);
    origin = Vec3i{bc.x * n, bc.y * n, bc.z * n};
    const int cell = idx / spc, s = idx % spc;
    g = Vec3i{origin.x + cell % n, origin.y + (cell / n) % n, origin.z + cell / (n * n)};
    for (int a = 0; a < 3; ++a) off[a] = offsets.o[s][a];
  }
};

/// Sample j (block j / kBlockSamples, index j % kBlockSamples in it) of the distance field: the
/// distance to the nearest particle whose band box holds the sample (sample_in_reach, the CPU
/// scatter's test), clamped to the band.
struct DistanceSamples {
  GridView grid;
  const uint64_t* block_keys;
  int n, spc;
  float a, band;
  SampleOffsets offsets;
  float* values;
  MENISCUS_HD void operator()(uint64_t j) const {
    const BlockSample sample(j, block_keys, n, spc, offsets);
    const Vec3i& origin = sample.origin;
    const Vec3i& g = sample.g;
    const float (&off)[3] = sample.off;
    const float inv_a = 1.0f / a;
    const float band2 = band * band;
    const Vec3f box_lo = Vec3f{float(origin.x), float(origin.y), float(origin.z)} * a;
    const Vec3f box_hi = box_lo + Vec3f{1, 1, 1} * (a * float(n));
    float d2 = band2;
    grid_for_each_in_cells_of_box(grid, box_lo - Vec3f{band, band, band}, box_hi + Vec3f{band, band, band},
                                  [&](uint32_t pi) {
                                    const Vec3f p = grid.sorted[pi];
                                    if (!sample_in_reach(p, band, inv_a, off, g)) return;
                                    const float dx = sample_delta(g.x, off[0], a, p.x);
                                    const float dy = sample_delta(g.y, off[1], a, p.y);
                                    const float dz = sample_delta(g.z, off[2], a, p.z);
                                    const float d = sample_dist2(dx, dy, dz);
                                    d2 = d < d2 ? d : d2;
                                  });
    values[j] = sqrtf(d2 < band2 ? d2 : band2);
  }
};

/// Sample j of a kernel-sum field: kernel_field_sample over the particles within `support`.
struct KernelSamples {
  GridView grid;
  KernelParticles k;
  const uint64_t* block_keys;
  int n, spc;
  float a, support, iso, background;
  SampleOffsets offsets;
  float* values;
  MENISCUS_HD void operator()(uint64_t j) const {
    const BlockSample p(j, block_keys, n, spc, offsets);
    values[j] = kernel_field_sample(grid, k, support, iso, background, p.origin, n, a, p.g, p.off);
  }
};

/// A field of `block_count` blocks over `keys` (values not yet written).
template <class B>
FieldBuffers<B> new_field(const SampleLattice& lattice, float background, BufferOf<B, uint64_t> keys,
                          std::size_t block_count) {
  FieldBuffers<B> f;
  f.lattice = lattice;
  f.background = background;
  f.blocks = uint32_t(block_count);
  f.values.resize(block_count * kBlockSamples);
  f.keys = std::move(keys);
  return f;
}

}  // namespace band_field

/// Keys (pack_coords of block coordinates) of the blocks whose cell box comes within `band` of
/// some point of `grid`: sorted and unique in the first *block_count entries of the buffer.
template <class B>
BufferOf<B, uint64_t> band_blocks(B b, const GridBuffers<B>& grid, const SampleLattice& lattice, float band,
                                  std::size_t* block_count) {
  const float block_size = lattice.cell_size * float(lattice.block_cells());
  BufferOf<B, uint64_t> offsets(std::size_t(grid.cells) + 1);
  for_each_index(b, grid.cells, band_field::BlockCounts{grid.keys.data(), grid.cell_size, band, block_size, offsets.data()});
  exclusive_sum(b, offsets.data(), offsets.data(), grid.cells);
  const uint64_t total = offsets.get(grid.cells);
  BufferOf<B, uint64_t> keys(total);
  for_each_index(b, grid.cells,
                 band_field::BlockKeys{grid.keys.data(), grid.cell_size, band, block_size, offsets.data(), keys.data()});
  sort_keys(b, keys.data(), total);
  *block_count = unique_sorted(b, keys.data(), total);
  return keys;
}

/// φ over the blocks `keys` (from band_blocks, moved in): each sample the distance to its nearest
/// point of `grid`, clamped to `band`; unallocated space reads as `band`.
template <class B>
FieldBuffers<B> distance_field(B b, const GridBuffers<B>& grid, const SampleLattice& lattice, float band,
                               BufferOf<B, uint64_t> keys, std::size_t block_count) {
  FieldBuffers<B> f = band_field::new_field<B>(lattice, band, std::move(keys), block_count);
  for_each_index(b, block_count * kBlockSamples,
                 band_field::DistanceSamples{grid.view(), f.keys.data(), lattice.block_cells(),
                                             lattice.samples_per_cell(), lattice.cell_size, band,
                                             SampleOffsets(lattice), f.values.data()});
  return f;
}

/// The kernel-sum field over the blocks `keys` (moved in): each sample kernel_field_sample
/// (kernel_impl.hpp; `k` points at per-sorted-particle data of backend B).
template <class B>
FieldBuffers<B> kernel_field(B b, const GridBuffers<B>& grid, const SampleLattice& lattice, const KernelParticles& k,
                             float support, float iso, float background, BufferOf<B, uint64_t> keys,
                             std::size_t block_count) {
  FieldBuffers<B> f = band_field::new_field<B>(lattice, background, std::move(keys), block_count);
  for_each_index(b, block_count * kBlockSamples,
                 band_field::KernelSamples{grid.view(), k, f.keys.data(), lattice.block_cells(),
                                           lattice.samples_per_cell(), lattice.cell_size, support, iso, background,
                                           SampleOffsets(lattice), f.values.data()});
  return f;
}

}  // namespace meniscus
