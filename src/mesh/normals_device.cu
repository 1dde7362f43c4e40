// meniscus — vertex normals and erosion on the device: the shared versions (normals_backend.hpp)
// run with cuda::Device. The normals are gathered per vertex (the CPU scatters them; the same sums).
#include "cuda/for_each.hpp"
#include "cuda/stages_cuda.hpp"
#include "mesh/normals_backend.hpp"

namespace meniscus::cuda {

DeviceBuffer<Vec3f> vertex_normals(const DeviceMesh& mesh, const DeviceAdjacency& adj) {
  return ::meniscus::vertex_normals(Device{}, mesh, adj);
}

std::size_t erode(DeviceMesh& mesh, const DeviceAdjacency& adj, float distance) {
  return ::meniscus::erode(Device{}, mesh, adj, distance);
}

}  // namespace meniscus::cuda
