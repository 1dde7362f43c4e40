// meniscus — the uniform hashed grid on the device (Edespong 2010 §3.1; Green 2008): cell keys,
// a stable radix sort of (key, index) — the order of the CPU's sort of (key, index) pairs — and
// one [start, end) range per occupied cell.
#include "cuda/primitives.hpp"
#include "cuda/stages_cuda.hpp"

namespace meniscus::cuda {

namespace {

__global__ void cell_keys_kernel(const Vec3f* points, uint32_t n, float cell_size, uint64_t* keys, uint32_t* index) {
  MENISCUS_GRID_STRIDE(i, n) {
    const Vec3i c = grid_cell_of(points[i], cell_size);
    keys[i] = pack_coords(c.x, c.y, c.z);
    index[i] = uint32_t(i);
  }
}

__global__ void gather_points_kernel(const Vec3f* points, const uint32_t* order, const uint64_t* keys, uint32_t n,
                                     Vec3f* sorted, uint32_t* heads) {
  MENISCUS_GRID_STRIDE(i, n) {
    sorted[i] = points[order[i]];
    heads[i] = (i == 0 || keys[i] != keys[i - 1]) ? 1u : 0u;
  }
}

__global__ void cell_ranges_kernel(const uint64_t* keys, const uint32_t* heads, const uint32_t* cell_of_head,
                                   uint32_t n, uint64_t* cell_keys, uint32_t* starts) {
  MENISCUS_GRID_STRIDE(i, n)
    if (heads[i]) {
      cell_keys[cell_of_head[i]] = keys[i];
      starts[cell_of_head[i]] = uint32_t(i);
    }
}

}  // namespace

DeviceGrid build_grid(const DeviceBuffer<Vec3f>& points, uint32_t count, float cell_size, Vec3i lo, Vec3i hi) {
  DeviceGrid g;
  g.count = count;
  g.cell_size = cell_size;
  g.lo = lo;
  g.hi = hi;
  if (count == 0) return g;
  DeviceBuffer<uint64_t> keys(count);
  g.order.resize(count);
  MENISCUS_LAUNCH(cell_keys_kernel, blocks_for(count), 256)(points.data(), count, cell_size, keys.data(), g.order.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  sort_pairs(Device{}, keys.data(), g.order.data(), count, 0, 63);
  g.sorted.resize(count);
  DeviceBuffer<uint32_t> heads(count), cell_of_head(count + 1);
  MENISCUS_LAUNCH(gather_points_kernel, blocks_for(count), 256)(points.data(), g.order.data(), keys.data(), count, g.sorted.data(),
                                                   heads.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  exclusive_sum(Device{}, heads.data(), cell_of_head.data(), count);
  g.cells = cell_of_head.get(count);
  g.keys.resize(g.cells);
  g.starts.resize(std::size_t(g.cells) + 1);
  MENISCUS_LAUNCH(cell_ranges_kernel, blocks_for(count), 256)(keys.data(), heads.data(), cell_of_head.data(), count, g.keys.data(),
                                                 g.starts.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  MENISCUS_CUDA_CHECK(counted_memcpy(g.starts.data() + g.cells, &count, sizeof(uint32_t), cudaMemcpyHostToDevice));
  return g;
}

}  // namespace meniscus::cuda
