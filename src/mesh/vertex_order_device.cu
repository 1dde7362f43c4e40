// meniscus — reorder_vertices_spatially() on the device: the shared version
// (vertex_order_backend.hpp) run with cuda::Device, so both backends number the vertices and order
// the triangles identically.
#include "cuda/primitives.hpp"
#include "cuda/stages_cuda.hpp"
#include "mesh/vertex_order_backend.hpp"

namespace meniscus::cuda {

void reorder_vertices_spatially(DeviceMesh& mesh, float cell) {
  ::meniscus::reorder_vertices_spatially(Device{}, mesh, cell);
}

}  // namespace meniscus::cuda
