// meniscus — erosion, area-weighted vertex normals and attribute transfer on the device: the
// per-element work of mesh/normals_impl.hpp and transfer/transfer_impl.hpp, shared with the CPU, run
// by for_each_index. The normals are gathered per vertex (the CPU scatters them; the same sums).
#include "cuda/for_each.hpp"
#include "cuda/stages_cuda.hpp"
#include "mesh/normals_impl.hpp"
#include "transfer/transfer_impl.hpp"

namespace meniscus::cuda {

DeviceBuffer<Vec3f> vertex_normals(const DeviceMesh& mesh, const DeviceAdjacency& adj) {
  DeviceBuffer<Vec3f> n(mesh.vertex_count);
  for_each_index(Device{}, mesh.vertex_count,
                 GatherNormal<const uint32_t*>{mesh.vertices.data(), mesh.triangles.data(), adj.tri_offsets.data(),
                                               adj.tri_ids.data(), n.data()});
  return n;
}

std::size_t erode(DeviceMesh& mesh, const DeviceAdjacency& adj, float distance) {
  if (mesh.vertex_count == 0) return 0;
  const DeviceBuffer<Vec3f> n = vertex_normals(mesh, adj);
  DeviceBuffer<Vec3f> before(mesh.triangle_count);
  DeviceBuffer<unsigned long long> flipped(1);
  flipped.zero();
  erode_along(Device{}, mesh.vertices.data(), static_cast<const uint32_t*>(mesh.triangles.data()), mesh.vertex_count,
              mesh.triangle_count, n.data(), before.data(), distance, flipped.data());
  return std::size_t(flipped.get(0));
}

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
