// meniscus — attribute transfer on the device: the shared version (transfer_backend.hpp) run with
// cuda::Device.
#include "cuda/for_each.hpp"
#include "cuda/stages_cuda.hpp"
#include "transfer/transfer_backend.hpp"

namespace meniscus::cuda {

DeviceBuffer<float> transfer_attribute(const DeviceBuffer<float>& values, int components, const DeviceGrid& grid,
                                       const DeviceMesh& mesh, float radius) {
  return ::meniscus::transfer_attribute(Device{}, values, components, grid, mesh, radius);
}

}  // namespace meniscus::cuda
