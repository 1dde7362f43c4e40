// meniscus — the sparse distance field on the device (Williams 2008 §3; Edespong 2010 §3.2): the
// band's blocks from the occupied hash cells (count, scan, write, sort, unique), then one thread
// block per field block and one thread per sample gathering the particles of the nearby hash cells
// (no atomics). The sample/particle arithmetic is distance_field_impl.hpp, as on the CPU. The
// kernel-sum fields (--field metaball|sph|zhu-bridson|anisotropic) the same way, each sample
// gathering kernel_field_sample (kernel_impl.hpp), which sums the CPU scatter's terms in its order.
#include "cuda/primitives.hpp"
#include "cuda/stages_cuda.hpp"
#include "field/distance_field_impl.hpp"

namespace meniscus::cuda {

namespace {

__global__ void band_block_count_kernel(const uint64_t* cells, uint32_t n, float cell_size, float band,
                                        float block_size, uint64_t* counts) {
  MENISCUS_GRID_STRIDE(i, n) {
    const Vec3i c = unpack_coords(cells[i]);
    uint64_t count = 1;
    for (int a = 0; a < 3; ++a) {
      int32_t lo, hi;
      band_block_range(c[a], cell_size, band, block_size, &lo, &hi);
      count *= uint64_t(int64_t(hi) - lo + 1);
    }
    counts[i] = count;
  }
}

__global__ void band_block_write_kernel(const uint64_t* cells, uint32_t n, float cell_size, float band,
                                        float block_size, const uint64_t* offsets, uint64_t* keys) {
  MENISCUS_GRID_STRIDE(i, n) {
    const Vec3i c = unpack_coords(cells[i]);
    int32_t lo[3], hi[3];
    for (int a = 0; a < 3; ++a) band_block_range(c[a], cell_size, band, block_size, &lo[a], &hi[a]);
    uint64_t out = offsets[i];
    for (int32_t z = lo[2]; z <= hi[2]; ++z)
      for (int32_t y = lo[1]; y <= hi[1]; ++y)
        for (int32_t x = lo[0]; x <= hi[0]; ++x) keys[out++] = pack_coords(x, y, z);
  }
}

/// One thread block per field block; thread t handles samples t, t + blockDim, ….
__global__ void distance_kernel(GridView grid, const uint64_t* block_keys, int n, int spc, float a, float band,
                                SampleOffsets offsets, float* values) {
  const uint64_t b = blockIdx.x;
  const Vec3i bc = unpack_coords(block_keys[b]);
  const Vec3i origin{bc.x * n, bc.y * n, bc.z * n};
  const float inv_a = 1.0f / a;
  const float band2 = band * band;
  const Vec3f box_lo = Vec3f{float(origin.x), float(origin.y), float(origin.z)} * a;
  const Vec3f box_hi = box_lo + Vec3f{1, 1, 1} * (a * float(n));
  for (int idx = threadIdx.x; idx < kBlockSamples; idx += blockDim.x) {
    const int cell = idx / spc, s = idx % spc;
    const Vec3i l{cell % n, (cell / n) % n, cell / (n * n)};
    const Vec3i g{origin.x + l.x, origin.y + l.y, origin.z + l.z};
    const float off[3] = {offsets.o[s][0], offsets.o[s][1], offsets.o[s][2]};
    float d2 = band2;
    grid_for_each_in_cells_of_box(grid, box_lo - Vec3f{band, band, band}, box_hi + Vec3f{band, band, band},
                                  [&](uint32_t pi) {
                                    const Vec3f p = grid.sorted[pi];
                                    // The same reach test as the CPU's scatter: is this sample in p's band box?
                                    if (!sample_in_reach(p, band, inv_a, off, g)) return;
                                    const float dx = sample_delta(g.x, off[0], a, p.x);
                                    const float dy = sample_delta(g.y, off[1], a, p.y);
                                    const float dz = sample_delta(g.z, off[2], a, p.z);
                                    const float d = sample_dist2(dx, dy, dz);
                                    d2 = d < d2 ? d : d2;
                                  });
    values[b * kBlockSamples + uint64_t(idx)] = sqrtf(d2 < band2 ? d2 : band2);
  }
}

/// One thread block per field block; thread t handles samples t, t + blockDim, ….
__global__ void kernel_field_kernel(GridView grid, KernelParticles k, const uint64_t* block_keys, int n, int spc,
                                    float a, float support, float iso, float background, SampleOffsets offsets,
                                    float* values) {
  const uint64_t b = blockIdx.x;
  const Vec3i bc = unpack_coords(block_keys[b]);
  const Vec3i origin{bc.x * n, bc.y * n, bc.z * n};
  for (int idx = threadIdx.x; idx < kBlockSamples; idx += blockDim.x) {
    const int cell = idx / spc, s = idx % spc;
    const Vec3i g{origin.x + cell % n, origin.y + (cell / n) % n, origin.z + cell / (n * n)};
    const float off[3] = {offsets.o[s][0], offsets.o[s][1], offsets.o[s][2]};
    values[b * kBlockSamples + uint64_t(idx)] = kernel_field_sample(grid, k, support, iso, background, origin, n, a, g, off);
  }
}

/// A field of `block_count` blocks (values not yet written).
DeviceField new_field(const SampleLattice& lattice, float background, std::size_t block_count) {
  DeviceField f;
  f.lattice = lattice;
  f.background = background;
  f.blocks = uint32_t(block_count);
  f.values.resize(block_count * kBlockSamples);
  return f;
}

}  // namespace

DeviceBuffer<uint64_t> band_blocks(const DeviceGrid& grid, const SampleLattice& lattice, float band,
                                   std::size_t* block_count) {
  const float block_size = lattice.cell_size * float(lattice.block_cells());
  DeviceBuffer<uint64_t> counts(std::size_t(grid.cells) + 1), offsets(std::size_t(grid.cells) + 1);
  MENISCUS_LAUNCH(band_block_count_kernel, blocks_for(grid.cells), 256)(grid.keys.data(), grid.cells, grid.cell_size, band,
                                                           block_size, counts.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  exclusive_sum(Device{}, counts.data(), offsets.data(), grid.cells);
  const uint64_t total = offsets.get(grid.cells);
  DeviceBuffer<uint64_t> keys(total);
  MENISCUS_LAUNCH(band_block_write_kernel, blocks_for(grid.cells), 256)(grid.keys.data(), grid.cells, grid.cell_size, band,
                                                           block_size, offsets.data(), keys.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  sort_keys(Device{}, keys.data(), total);
  *block_count = unique_sorted(Device{}, keys.data(), total);
  return keys;
}

DeviceField distance_field(const DeviceGrid& grid, const SampleLattice& lattice, float band,
                           DeviceBuffer<uint64_t> keys, std::size_t block_count) {
  DeviceField f = new_field(lattice, band, block_count);
  if (block_count > 0) {
    MENISCUS_LAUNCH(distance_kernel, unsigned(block_count), 128)(grid.view(), keys.data(), lattice.block_cells(),
                                                    lattice.samples_per_cell(), lattice.cell_size, band,
                                                    SampleOffsets(lattice), f.values.data());
    MENISCUS_CUDA_CHECK_LAUNCH();
  }
  f.keys = std::move(keys);
  return f;
}

DeviceField kernel_field(const DeviceGrid& grid, const SampleLattice& lattice, const KernelParticles& k, float support,
                         float iso, float background, DeviceBuffer<uint64_t> keys, std::size_t block_count) {
  DeviceField f = new_field(lattice, background, block_count);
  if (block_count > 0) {
    MENISCUS_LAUNCH(kernel_field_kernel, unsigned(block_count), 128)(grid.view(), k, keys.data(), lattice.block_cells(),
                                                        lattice.samples_per_cell(), lattice.cell_size, support, iso,
                                                        background, SampleOffsets(lattice), f.values.data());
    MENISCUS_CUDA_CHECK_LAUNCH();
  }
  f.keys = std::move(keys);
  return f;
}

}  // namespace meniscus::cuda
