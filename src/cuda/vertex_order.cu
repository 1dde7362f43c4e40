// meniscus — reorder_vertices_spatially() on the device (mesh/vertex_order.cpp): the same Z-order
// keys (vertex_order_impl.hpp), the same stable sorts, so both backends number the vertices and
// order the triangles identically.
#include <algorithm>

#include "cuda/primitives.hpp"
#include "cuda/stages_cuda.hpp"
#include "mesh/vertex_order_impl.hpp"

namespace meniscus::cuda {

namespace {

__global__ void morton_kernel(const Vec3f* x, uint64_t n, float inv_cell, uint32_t* keys, uint32_t* ids) {
  MENISCUS_GRID_STRIDE(i, n) {
    keys[i] = morton_key(x[i], inv_cell);
    ids[i] = uint32_t(i);
  }
}

__global__ void permute_vertices_kernel(const Vec3f* x, const uint32_t* old_of_new, uint64_t n, Vec3f* out,
                                        uint32_t* new_of_old) {
  MENISCUS_GRID_STRIDE(i, n) {
    out[i] = x[old_of_new[i]];
    new_of_old[old_of_new[i]] = uint32_t(i);
  }
}

__global__ void remap_triangles_kernel(uint32_t* tris, const uint32_t* new_of_old, uint64_t nt, uint32_t* keys,
                                       uint32_t* ids) {
  MENISCUS_GRID_STRIDE(t, nt) {
    uint32_t* tri = tris + 3 * t;
    const uint32_t a = new_of_old[tri[0]], b = new_of_old[tri[1]], c = new_of_old[tri[2]];
    tri[0] = a;
    tri[1] = b;
    tri[2] = c;
    const uint32_t ab = a < b ? a : b;
    keys[t] = ab < c ? ab : c;
    ids[t] = uint32_t(t);
  }
}

__global__ void gather_triangles_kernel(const uint32_t* tris, const uint32_t* order, uint64_t nt, uint32_t* out) {
  MENISCUS_GRID_STRIDE(t, nt) {
    const uint32_t* src = tris + 3 * uint64_t(order[t]);
    out[3 * t] = src[0];
    out[3 * t + 1] = src[1];
    out[3 * t + 2] = src[2];
  }
}

}  // namespace

void reorder_vertices_spatially(DeviceMesh& mesh, float cell) {
  const std::size_t nv = mesh.vertex_count, nt = mesh.triangle_count;
  if (nv < 2) return;

  DeviceBuffer<uint32_t> keys(std::max(nv, nt)), ids(std::max(nv, nt)), new_of_old(nv);
  MENISCUS_LAUNCH(morton_kernel, blocks_for(nv), 256)(mesh.vertices.data(), nv, 1.0f / cell, keys.data(), ids.data());
  MENISCUS_CUDA_CHECK(cudaGetLastError());
  sort_pairs(Device{}, keys.data(), ids.data(), nv, 0, 30);  // stable: ties keep the old order, as on the CPU
  DeviceBuffer<Vec3f> sorted(nv);
  MENISCUS_LAUNCH(permute_vertices_kernel, blocks_for(nv), 256)(mesh.vertices.data(), ids.data(), nv, sorted.data(),
                                                   new_of_old.data());
  MENISCUS_CUDA_CHECK(cudaGetLastError());
  mesh.vertices = std::move(sorted);
  if (nt == 0) return;

  MENISCUS_LAUNCH(remap_triangles_kernel, blocks_for(nt), 256)(mesh.triangles.data(), new_of_old.data(), nt, keys.data(),
                                                  ids.data());
  MENISCUS_CUDA_CHECK(cudaGetLastError());
  sort_pairs(Device{}, keys.data(), ids.data(), nt, 0, 32);
  DeviceBuffer<uint32_t> tris(3 * nt);
  MENISCUS_LAUNCH(gather_triangles_kernel, blocks_for(nt), 256)(mesh.triangles.data(), ids.data(), nt, tris.data());
  MENISCUS_CUDA_CHECK(cudaGetLastError());
  mesh.triangles = std::move(tris);
}

}  // namespace meniscus::cuda
