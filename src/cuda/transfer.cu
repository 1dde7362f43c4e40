// meniscus — erosion, area-weighted vertex normals and attribute transfer on the device
// (docs/method.md; Zhu & Bridson 2005 weights). Normals gather each vertex's triangles in ascending
// order — the order in which the CPU's serial scatter adds them — so the sums are identical.
#include "cuda/stages_cuda.hpp"

namespace meniscus::cuda {

namespace {

__device__ Vec3f face_cross(const Vec3f* x, const uint32_t* t) { return cross(x[t[1]] - x[t[0]], x[t[2]] - x[t[0]]); }

__global__ void normals_kernel(const Vec3f* x, const uint32_t* tris, const uint32_t* tri_offsets,
                               const uint32_t* tri_ids, uint64_t nv, Vec3f* n) {
  MENISCUS_GRID_STRIDE(i, nv) {
    Vec3f sum{0, 0, 0};
    for (uint32_t k = tri_offsets[i]; k < tri_offsets[i + 1]; ++k) sum += face_cross(x, tris + 3 * uint64_t(tri_ids[k]));
    n[i] = normalized(sum);
  }
}

__global__ void face_normals_kernel(const Vec3f* x, const uint32_t* tris, uint64_t nt, Vec3f* out) {
  MENISCUS_GRID_STRIDE(f, nt) { out[f] = face_cross(x, tris + 3 * f); }
}

__global__ void move_kernel(Vec3f* x, const Vec3f* n, uint64_t nv, float distance) {
  MENISCUS_GRID_STRIDE(i, nv) { x[i] -= n[i] * distance; }
}

__global__ void flipped_kernel(const Vec3f* x, const uint32_t* tris, const Vec3f* before, uint64_t nt,
                               unsigned long long* flipped) {
  MENISCUS_GRID_STRIDE(f, nt) {
    if (dot(face_cross(x, tris + 3 * f), before[f]) < 0.0f) atomicAdd(flipped, 1ull);
  }
}

__global__ void transfer_kernel(const float* values, int nc, const uint32_t* order, GridView grid, const Vec3f* x,
                                uint64_t nv, float radius, float* out) {
  const float inv_r2 = 1.0f / (radius * radius);
  MENISCUS_GRID_STRIDE(v, nv) {
    // One component at a time: the same sums, in the same particle order, as the CPU's vector.
    bool any = false;
    for (int c = 0; c < nc; ++c) {
      double acc = 0, wsum = 0;
      grid_for_each_within(grid, x[v], radius, [&](uint32_t i, float d2) {
        const double q = 1.0 - double(d2 * inv_r2);
        const double w = q * q * q;
        if (w <= 0) return;
        acc += w * values[uint64_t(order[i]) * nc + c];
        wsum += w;
      });
      if (wsum > 0) {
        out[v * nc + c] = float(acc / wsum);
        any = true;
      }
    }
    if (!any) {
      const NearestPoint n = grid_nearest(grid, x[v]);
      for (int c = 0; c < nc; ++c)
        out[v * nc + c] = n.index == kNotFound ? 0.0f : values[uint64_t(order[n.index]) * nc + c];
    }
  }
}

}  // namespace

DeviceBuffer<Vec3f> vertex_normals(const DeviceMesh& mesh, const DeviceAdjacency& adj) {
  DeviceBuffer<Vec3f> n(mesh.vertex_count);
  if (mesh.vertex_count == 0) return n;
  MENISCUS_LAUNCH(normals_kernel, blocks_for(mesh.vertex_count), 256)(mesh.vertices.data(), mesh.triangles.data(),
                                                         adj.tri_offsets.data(), adj.tri_ids.data(), mesh.vertex_count,
                                                         n.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  return n;
}

std::size_t erode(DeviceMesh& mesh, const DeviceAdjacency& adj, float distance) {
  const uint64_t nv = mesh.vertex_count, nt = mesh.triangle_count;
  if (nv == 0) return 0;
  const DeviceBuffer<Vec3f> n = vertex_normals(mesh, adj);
  DeviceBuffer<Vec3f> before(nt);
  MENISCUS_LAUNCH(face_normals_kernel, blocks_for(nt), 256)(mesh.vertices.data(), mesh.triangles.data(), nt, before.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  MENISCUS_LAUNCH(move_kernel, blocks_for(nv), 256)(mesh.vertices.data(), n.data(), nv, distance);
  MENISCUS_CUDA_CHECK_LAUNCH();
  DeviceBuffer<unsigned long long> flipped(1);
  flipped.zero();
  MENISCUS_LAUNCH(flipped_kernel, blocks_for(nt), 256)(mesh.vertices.data(), mesh.triangles.data(), before.data(), nt,
                                          flipped.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  return std::size_t(flipped.get(0));
}

DeviceBuffer<float> transfer_attribute(const DeviceBuffer<float>& values, int components, const DeviceGrid& grid,
                                       const DeviceMesh& mesh, float radius) {
  DeviceBuffer<float> out(mesh.vertex_count * std::size_t(components));
  if (mesh.vertex_count == 0 || components == 0) return out;
  MENISCUS_LAUNCH(transfer_kernel, blocks_for(mesh.vertex_count), 128)(values.data(), components, grid.order.data(), grid.view(),
                                                          mesh.vertices.data(), mesh.vertex_count, radius, out.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  return out;
}

}  // namespace meniscus::cuda
