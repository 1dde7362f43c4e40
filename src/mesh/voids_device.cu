// meniscus — components, small interior voids and unsupported blobs on the device: voids_backend.hpp's
// stages run with cuda::Device{}.
#include "cuda/primitives.hpp"
#include "cuda/stages_cuda.hpp"
#include "mesh/voids_backend.hpp"

namespace meniscus::cuda {

/// The device's blob tests: one thread per candidate, in small thread blocks (a candidate's ray
/// casts vary in length, so few threads wait on the slowest).
void blob_tests(Device, std::size_t candidates, const voids_backend::BlobTest& test) {
  for_each_index(Device{}, candidates, test, 64);
}

std::size_t remove_small_voids(DeviceMesh& mesh, double max_volume) {
  return ::meniscus::remove_small_voids(Device{}, mesh, max_volume);
}

std::size_t remove_unsupported_blobs(DeviceMesh& mesh, const DeviceGrid& grid, double max_volume, double min_volume) {
  return ::meniscus::remove_unsupported_blobs(Device{}, mesh, grid, max_volume, min_volume);
}

}  // namespace meniscus::cuda
