// meniscus — the mesh adjacency on the device: the shared version (adjacency_backend.hpp) run with
// cuda::Device.
#include "cuda/primitives.hpp"
#include "cuda/stages_cuda.hpp"
#include "mesh/adjacency_backend.hpp"

namespace meniscus::cuda {

DeviceAdjacency build_adjacency(const DeviceMesh& mesh) { return ::meniscus::build_adjacency(Device{}, mesh); }

}  // namespace meniscus::cuda
