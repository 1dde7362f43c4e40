// meniscus — small interior voids and unsupported blobs on the device (mesh/voids.hpp): connected
// components by parallel hooking, their signed volumes, and the dropping of the small ones.
#include "cuda/primitives.hpp"
#include "cuda/relaxed.hpp"
#include "cuda/stages_cuda.hpp"
#include "grid/hash_grid_impl.hpp"
#include "mesh/ray_parity_impl.hpp"
#include "mesh/volume_impl.hpp"

namespace meniscus::cuda {

// --- small interior voids (mesh/voids.cpp) ---------------------------------------------------------

namespace {

__device__ uint32_t find_root(uint32_t* parent, uint32_t x) {
  for (uint32_t p = load_relaxed(parent + x); p != x; p = load_relaxed(parent + x)) x = p;  // others hook meanwhile
  return x;
}

/// Hooks the roots of each triangle's corners onto the smallest (min-label connected components).
__global__ void hook_kernel(const uint32_t* tris, uint64_t nt, uint32_t* parent, int* changed) {
  MENISCUS_GRID_STRIDE(t, nt) {
    uint32_t r[3];
    for (int k = 0; k < 3; ++k) r[k] = find_root(parent, tris[3 * t + k]);
    uint32_t m = r[0] < r[1] ? r[0] : r[1];
    m = m < r[2] ? m : r[2];
    for (int k = 0; k < 3; ++k)
      if (r[k] != m) {
        atomicMin(&parent[r[k]], m);
        store_relaxed(changed, 1);
      }
  }
}

__global__ void compress_kernel(uint32_t* parent, uint64_t nv) {
  MENISCUS_GRID_STRIDE(v, nv)
    store_relaxed(parent + v, find_root(parent, uint32_t(v)));
}

__global__ void init_parent_kernel(uint32_t* parent, uint64_t nv) {
  MENISCUS_GRID_STRIDE(v, nv)
    parent[v] = uint32_t(v);
}

__global__ void volume_kernel(const uint32_t* tris, uint64_t nt, const Vec3f* x, const uint32_t* root, double* volume,
                              uint32_t* has) {
  MENISCUS_GRID_STRIDE(t, nt) {
    const Vec3f a = x[tris[3 * t]], b = x[tris[3 * t + 1]], c = x[tris[3 * t + 2]];
    const uint32_t r = root[tris[3 * t]];
    const double v = signed_volume6(a, b, c) / 6.0;
    atomicAdd(&volume[r], v);
    store_relaxed(has + r, 1u);
  }
}

__global__ void drop_kernel(const uint32_t* root, const double* volume, const uint32_t* has, uint64_t nv,
                            double max_volume, uint8_t* drop, unsigned long long* removed) {
  MENISCUS_GRID_STRIDE(v, nv) {
    const bool d = root[v] == v && has[v] && volume[v] <= 0.0 && volume[v] > -max_volume;
    drop[v] = d ? 1 : 0;
    if (d) atomicAdd(removed, 1ull);
  }
}

__global__ void keep_flags_kernel(const uint32_t* tris, uint64_t nt, const uint32_t* root, const uint8_t* drop,
                                  uint32_t* keep, uint32_t* used) {
  MENISCUS_GRID_STRIDE(t, nt) {
    const bool k = !drop[root[tris[3 * t]]];
    keep[t] = k ? 1u : 0u;
    if (k)
      for (int j = 0; j < 3; ++j) store_relaxed(used + tris[3 * t + j], 1u);
  }
}

__global__ void compact_kernel(const uint32_t* tris, uint64_t nt, const uint32_t* keep, const uint32_t* tri_pos,
                               const uint32_t* used, const uint32_t* vertex_pos, const Vec3f* x, uint64_t nv,
                               uint32_t* new_tris, Vec3f* new_x) {
  for (uint64_t i = blockIdx.x * uint64_t(blockDim.x) + threadIdx.x; i < nt || i < nv;
       i += uint64_t(gridDim.x) * blockDim.x) {
    if (i < nt && keep[i])
      for (int j = 0; j < 3; ++j) new_tris[3 * uint64_t(tri_pos[i]) + j] = vertex_pos[tris[3 * i + j]];
    if (i < nv && used[i]) new_x[vertex_pos[i]] = x[i];
  }
}

}  // namespace

namespace {

/// The components of a device mesh (mesh/components.cpp's mesh_components): each vertex's root (the
/// component's smallest vertex), and per root the signed volume and whether it has triangles.
struct DeviceComponents {
  DeviceBuffer<uint32_t> root;
  DeviceBuffer<double> volume;
  DeviceBuffer<uint32_t> has;
};

DeviceComponents mesh_components(const DeviceMesh& mesh) {
  const uint64_t nv = mesh.vertex_count, nt = mesh.triangle_count;
  DeviceComponents c;
  c.root.resize(nv);
  MENISCUS_LAUNCH(init_parent_kernel, blocks_for(nv), 256)(c.root.data(), nv);
  MENISCUS_CUDA_CHECK_LAUNCH();
  DeviceBuffer<int> changed(1);
  for (;;) {
    changed.zero();
    MENISCUS_LAUNCH(hook_kernel, blocks_for(nt), 256)(mesh.triangles.data(), nt, c.root.data(), changed.data());
    MENISCUS_CUDA_CHECK_LAUNCH();
    MENISCUS_LAUNCH(compress_kernel, blocks_for(nv), 256)(c.root.data(), nv);
    MENISCUS_CUDA_CHECK_LAUNCH();
    if (changed.get(0) == 0) break;
  }
  c.volume.resize(nv);
  c.has.resize(nv);
  c.volume.zero();
  c.has.zero();
  MENISCUS_LAUNCH(volume_kernel, blocks_for(nt), 256)(mesh.triangles.data(), nt, mesh.vertices.data(), c.root.data(),
                                         c.volume.data(), c.has.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  return c;
}

/// Drops the triangles of the components whose root has drop[root] set, then the vertices no
/// triangle uses (order otherwise preserved), as the CPU's drop_components.
void drop_components(DeviceMesh& mesh, const DeviceBuffer<uint32_t>& root, const DeviceBuffer<uint8_t>& drop) {
  const uint64_t nv = mesh.vertex_count, nt = mesh.triangle_count;
  DeviceBuffer<uint32_t> keep(nt), tri_pos(nt + 1), used(nv), vertex_pos(nv + 1);
  used.zero();
  MENISCUS_LAUNCH(keep_flags_kernel, blocks_for(nt), 256)(mesh.triangles.data(), nt, root.data(), drop.data(), keep.data(),
                                             used.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  exclusive_sum(Device{}, keep.data(), tri_pos.data(), nt);
  exclusive_sum(Device{}, used.data(), vertex_pos.data(), nv);
  const uint32_t new_nt = tri_pos.get(nt), new_nv = vertex_pos.get(nv);
  DeviceBuffer<uint32_t> new_tris(3 * std::size_t(new_nt));
  DeviceBuffer<Vec3f> new_x(new_nv);
  MENISCUS_LAUNCH(compact_kernel, blocks_for(nt > nv ? nt : nv), 256)(mesh.triangles.data(), nt, keep.data(), tri_pos.data(),
                                                         used.data(), vertex_pos.data(), mesh.vertices.data(), nv,
                                                         new_tris.data(), new_x.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  mesh.triangles = std::move(new_tris);
  mesh.vertices = std::move(new_x);
  mesh.triangle_count = new_nt;
  mesh.vertex_count = new_nv;
}

// --- unsupported blobs (kernel fields) ---------------------------------------------------------------

/// Flags the small outward components' roots (volume in (0, max_volume]).
__global__ void blob_candidate_kernel(const uint32_t* root, const double* volume, const uint32_t* has, uint64_t nv,
                                      double max_volume, uint32_t* flag) {
  MENISCUS_GRID_STRIDE(v, nv)
    flag[v] = root[v] == v && has[v] && volume[v] > 0.0 && volume[v] <= max_volume ? 1u : 0u;
}

/// Counts the triangles of each candidate (slot[root]: the candidate's index, from the flags' scan).
__global__ void blob_count_kernel(const uint32_t* tris, uint64_t nt, const uint32_t* root, const uint32_t* flag,
                                  const uint32_t* slot, uint32_t* counts) {
  MENISCUS_GRID_STRIDE(t, nt) {
    const uint32_t r = root[tris[3 * t]];
    if (flag[r]) atomicAdd(&counts[slot[r]], 1u);
  }
}

/// Buckets the candidates' triangles (any order within a bucket: the blob test does not depend on it).
__global__ void blob_fill_kernel(const uint32_t* tris, uint64_t nt, const uint32_t* root, const uint32_t* flag,
                                 const uint32_t* slot, const uint32_t* start, uint32_t* cursor, uint32_t* ids) {
  MENISCUS_GRID_STRIDE(t, nt) {
    const uint32_t r = root[tris[3 * t]];
    if (flag[r]) ids[start[slot[r]] + atomicAdd(&cursor[slot[r]], 1u)] = uint32_t(t);
  }
}

/// One thread per candidate: dropped when smaller than the inner ball or enclosing no particle.
__global__ void blob_test_kernel(GridView grid, const uint32_t* tris, const Vec3f* x, const uint32_t* candidates,
                                 uint32_t count, const uint32_t* start, const uint32_t* ids, const double* volume,
                                 double min_volume, uint8_t* drop, unsigned long long* removed) {
  MENISCUS_GRID_STRIDE(k, count) {
    const uint32_t r = candidates[k];
    const bool empty = volume[r] <= min_volume || !encloses_a_point(grid, tris, ids + start[k], start[k + 1] - start[k], x);
    if (empty) {
      drop[r] = 1;
      atomicAdd(removed, 1ull);
    }
  }
}

__global__ void candidate_list_kernel(const uint32_t* flag, const uint32_t* slot, uint64_t nv, uint32_t* candidates) {
  MENISCUS_GRID_STRIDE(v, nv)
    if (flag[v]) candidates[slot[v]] = uint32_t(v);
}

}  // namespace

std::size_t remove_small_voids(DeviceMesh& mesh, double max_volume) {
  const uint64_t nv = mesh.vertex_count, nt = mesh.triangle_count;
  if (nv == 0 || nt == 0) return 0;
  const DeviceComponents c = mesh_components(mesh);
  DeviceBuffer<uint8_t> drop(nv);
  DeviceBuffer<unsigned long long> removed(1);
  removed.zero();
  MENISCUS_LAUNCH(drop_kernel, blocks_for(nv), 256)(c.root.data(), c.volume.data(), c.has.data(), nv, max_volume, drop.data(),
                                       removed.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  const std::size_t count = std::size_t(removed.get(0));
  if (count > 0) drop_components(mesh, c.root, drop);
  return count;
}

std::size_t remove_unsupported_blobs(DeviceMesh& mesh, const DeviceGrid& grid, double max_volume, double min_volume) {
  const uint64_t nv = mesh.vertex_count, nt = mesh.triangle_count;
  if (nv == 0 || nt == 0) return 0;
  const DeviceComponents c = mesh_components(mesh);
  DeviceBuffer<uint32_t> flag(nv), slot(nv + 1);
  MENISCUS_LAUNCH(blob_candidate_kernel, blocks_for(nv), 256)(c.root.data(), c.volume.data(), c.has.data(), nv, max_volume,
                                                 flag.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  exclusive_sum(Device{}, flag.data(), slot.data(), nv);
  const uint32_t candidates = slot.get(nv);
  if (candidates == 0) return 0;
  DeviceBuffer<uint32_t> list(candidates), counts(candidates), start(std::size_t(candidates) + 1), cursor(candidates);
  MENISCUS_LAUNCH(candidate_list_kernel, blocks_for(nv), 256)(flag.data(), slot.data(), nv, list.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  counts.zero();
  MENISCUS_LAUNCH(blob_count_kernel, blocks_for(nt), 256)(mesh.triangles.data(), nt, c.root.data(), flag.data(), slot.data(),
                                             counts.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  exclusive_sum(Device{}, counts.data(), start.data(), candidates);
  DeviceBuffer<uint32_t> ids(start.get(candidates));
  cursor.zero();
  MENISCUS_LAUNCH(blob_fill_kernel, blocks_for(nt), 256)(mesh.triangles.data(), nt, c.root.data(), flag.data(), slot.data(),
                                            start.data(), cursor.data(), ids.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  DeviceBuffer<uint8_t> drop(nv);
  drop.zero();
  DeviceBuffer<unsigned long long> removed(1);
  removed.zero();
  MENISCUS_LAUNCH(blob_test_kernel, blocks_for(candidates, 64), 64)(grid.view(), mesh.triangles.data(), mesh.vertices.data(),
                                                       list.data(), candidates, start.data(), ids.data(),
                                                       c.volume.data(), min_volume, drop.data(), removed.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  const std::size_t count = std::size_t(removed.get(0));
  if (count > 0) drop_components(mesh, c.root, drop);
  return count;
}

}  // namespace meniscus::cuda
