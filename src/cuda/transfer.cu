// meniscus — attribute transfer on the device: the per-vertex work of transfer/transfer_impl.hpp,
// shared with the CPU, run by for_each_index.
#include "cuda/for_each.hpp"
#include "cuda/stages_cuda.hpp"
#include "transfer/transfer_impl.hpp"

namespace meniscus::cuda {

namespace {

/// transfer_vertex over the device's view of the grid.
struct TransferKernel {
  GridView grid;
  TransferData d;
  MENISCUS_HD void operator()(uint64_t v) const { transfer_vertex(grid, d, v); }
};

}  // namespace

DeviceBuffer<float> transfer_attribute(const DeviceBuffer<float>& values, int components, const DeviceGrid& grid,
                                       const DeviceMesh& mesh, float radius) {
  DeviceBuffer<float> out(mesh.vertex_count * std::size_t(components));
  if (components == 0) return out;
  const TransferData d{values.data(), components, grid.order.data(), mesh.vertices.data(), radius, out.data()};
  for_each_index(Device{}, mesh.vertex_count, TransferKernel{grid.view(), d}, 128);
  return out;
}

}  // namespace meniscus::cuda
