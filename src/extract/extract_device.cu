// meniscus — iso-surface extraction on the device: extract_backend.hpp's stage run with
// cuda::Device{}, its march as one thread block per march block with the padded masks in shared
// memory, and the marching tables in device memory.
#include <mutex>

#include "cuda/primitives.hpp"
#include "cuda/stages_cuda.hpp"
#include "extract/extract_backend.hpp"

namespace meniscus::cuda {

namespace {

/// One thread block per march block: MarchBlocks' three steps, each over the block's threads,
/// with the scratch in shared memory between them.
__global__ void march_kernel(extract_backend::MarchBlocks m) {
  __shared__ uint32_t neighbours[27];
  __shared__ uint8_t padded[extract_backend::kMaxPadded];
  const uint64_t b = blockIdx.x;
  for (unsigned k = threadIdx.x; k < 27; k += blockDim.x) neighbours[k] = m.neighbour(b, k);  // whatever the block size
  __syncthreads();
  for (int i = int(threadIdx.x), p = m.padded_size(); i < p; i += int(blockDim.x)) padded[i] = m.padded_mask(i, neighbours);
  __syncthreads();
  for (int c = int(threadIdx.x), cells = m.n * m.n * m.n; c < cells; c += int(blockDim.x)) m.cell(b, c, padded);
}

/// The tables, uploaded once per process and kept for its life: the same constants for every run,
/// so concurrent reconstructions share them (the first one uploads, the others wait for it).
struct DeviceTables {
  DeviceBuffer<MarchingTables> tables;
  DeviceBuffer<TileVertexLookup> lookup;
};
const DeviceTables& device_tables() {
  static DeviceTables t;
  static std::once_flag once;
  std::call_once(once, [] {
    static const MarchingTables tables = host_marching_tables();
    static constexpr TileVertexLookup lookup = make_tile_vertex_lookup(6, 36);
    t.tables.upload(&tables, 1);
    t.lookup.upload(&lookup, 1);
  });
  return t;
}

}  // namespace

/// The device's march (extract_backend.hpp): a thread block per march block.
void march_blocks(Device, std::size_t blocks, const extract_backend::MarchBlocks& m) {
  if (blocks == 0) return;
  const int cells = m.n * m.n * m.n;
  MENISCUS_LAUNCH(march_kernel, unsigned(blocks), unsigned(cells < 128 ? cells : 128))(m);
  MENISCUS_CUDA_CHECK_LAUNCH();
}
const MarchingTables* marching_tables(Device) { return device_tables().tables.data(); }
const TileVertexLookup* tile_vertex_lookup(Device) { return device_tables().lookup.data(); }

DeviceMesh extract_surface(const DeviceField& field, float iso, Extractor extractor) {
  return ::meniscus::extract_surface(Device{}, field, iso, extractor);
}

}  // namespace meniscus::cuda
