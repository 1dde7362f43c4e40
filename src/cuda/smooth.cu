// meniscus — constrained smoothing on the device (Williams 2008 §4; Edespong 2010 §3.5): the mesh
// adjacency (CSR) and the W, D operators assembled from the triangle list, and the schedule of
// smooth/schedule.hpp: Jacobi sweeps (the A sweeps Chebyshev-accelerated, the B sweeps damped per
// vertex), one kernel a sweep for A and two for B, with nothing read back between them. Every
// per-vertex formula is the CPU's (schedule.hpp, operators_impl.hpp, constraint_impl.hpp), in the
// same order of float operations, so both backends give the same mesh.
#include <algorithm>
#include <optional>
#include <vector>

#include "cuda/for_each.hpp"
#include "cuda/primitives.hpp"
#include "cuda/stages_cuda.hpp"
#include "smooth/constraint_impl.hpp"
#include "smooth/operators_impl.hpp"
#include "smooth/sweeps_impl.hpp"

namespace meniscus::cuda {

namespace {

// --- adjacency ----------------------------------------------------------------------------------

__global__ void corner_keys_kernel(const uint32_t* tris, uint64_t corners, uint32_t* keys, uint32_t* tri_of,
                                   uint32_t* counts) {
  MENISCUS_GRID_STRIDE(c, corners) {
    keys[c] = tris[c];
    tri_of[c] = uint32_t(c / 3);
    atomicAdd(&counts[tris[c]], 1u);
  }
}

/// Sorted, distinct neighbours of i gathered from its triangles into scratch (2 per triangle);
/// returns their count.
__device__ uint32_t gather_neighbours(const uint32_t* tris, const uint32_t* tri_offsets, const uint32_t* tri_ids,
                                      uint32_t i, uint32_t* out) {
  uint32_t n = 0;
  for (uint32_t k = tri_offsets[i]; k < tri_offsets[i + 1]; ++k) {
    const uint32_t* t = tris + 3 * uint64_t(tri_ids[k]);
    for (int j = 0; j < 3; ++j)
      if (t[j] != i) out[n++] = t[j];
  }
  for (uint32_t a = 1; a < n; ++a) {  // insertion sort: rows are short
    const uint32_t v = out[a];
    uint32_t b = a;
    while (b > 0 && out[b - 1] > v) out[b] = out[b - 1], --b;
    out[b] = v;
  }
  uint32_t m = 0;
  for (uint32_t a = 0; a < n; ++a)
    if (m == 0 || out[a] != out[m - 1]) out[m++] = out[a];
  return m;
}

__global__ void neighbour_count_kernel(const uint32_t* tris, const uint32_t* tri_offsets, const uint32_t* tri_ids,
                                       uint64_t nv, uint32_t* scratch, uint32_t* counts) {
  MENISCUS_GRID_STRIDE(i, nv) {
    counts[i] = gather_neighbours(tris, tri_offsets, tri_ids, uint32_t(i), scratch + 2 * uint64_t(tri_offsets[i]));
  }
}

__global__ void neighbour_write_kernel(const uint32_t* tri_offsets, const uint32_t* scratch, const uint32_t* offsets,
                                       uint64_t nv, uint32_t* neighbors) {
  MENISCUS_GRID_STRIDE(i, nv) {
    const uint32_t* s = scratch + 2 * uint64_t(tri_offsets[i]);
    for (uint32_t k = 0; k < offsets[i + 1] - offsets[i]; ++k) neighbors[offsets[i] + k] = s[k];
  }
}

// --- operators ----------------------------------------------------------------------------------------

struct Operator {
  DeviceBuffer<float> w, diag, area;
};

__global__ void cotan_kernel(MeshRows rows, const Vec3f* x, uint64_t nv, float* w, float* diag, float* area) {
  MENISCUS_GRID_STRIDE(i, nv) { cotan_row(rows, x, uint32_t(i), w, &diag[i], &area[i]); }
}

__global__ void area_floor_kernel(float* area, uint64_t nv, float floor) {
  MENISCUS_GRID_STRIDE(i, nv) { area[i] = area[i] < floor ? floor : area[i]; }  // std::max(a, floor)
}

// --- the fixed-tree sums (operators_impl.hpp) -----------------------------------------------------------

__global__ void leaf_energy_kernel(const Vec3f* wx, const float* area, const uint64_t* leaves, uint64_t count,
                                   double* sums) {
  MENISCUS_GRID_STRIDE(l, count) {
    double e = 0.0;
    for (uint64_t k = leaves[l]; k < leaves[l + 1]; ++k) e += energy_term(wx[k], area[k]);
    sums[l] = e;
  }
}

__global__ void combine_kernel(const double* sums, uint64_t n, double* out) {
  if (blockIdx.x == 0 && threadIdx.x == 0) {
    std::size_t next = 0;
    *out = sum_tree_combine(0, n, kSumTreeGrain, sums, &next);
  }
}

struct TreeSum {
  DeviceBuffer<uint64_t> leaves;
  DeviceBuffer<double> sums, total;
  uint64_t n = 0, count = 0;
  explicit TreeSum(uint64_t items) : n(items) {
    const std::vector<std::size_t> b = sum_tree_leaves(items);
    std::vector<uint64_t> b64(b.begin(), b.end());
    leaves.upload(b64.data(), b64.size());
    count = b64.size() - 1;
    sums.resize(count);
    total.resize(1);
  }
  double finish() {
    MENISCUS_LAUNCH(combine_kernel, 1, 1)(sums.data(), n, total.data());
    MENISCUS_CUDA_CHECK_LAUNCH();
    return total.get(0);
  }
};

// --- sweeps ---------------------------------------------------------------------------------------------

/// The constraint of the sweeps: Williams' spherical shells, or with `shells` the ellipsoid shells
/// of the anisotropic field (constraint_impl.hpp, as on the CPU).
struct DeviceProjection {
  GridView grid;
  float r_inner = 0, r_outer = 0;
  const Ellipsoid* shells = nullptr;
  float max_axis = 1;

  /// Vertex i, moved from `from` (where the previous projection left it) to `moved` by the sweep.
  __device__ Vec3f operator()(uint32_t /*i*/, Vec3f moved, Vec3f from) const {
    return shells != nullptr ? project_vertex_in_metric(grid, shells, moved, from, r_inner, r_outer, max_axis)
                             : project_vertex_on(grid, moved, r_inner, r_outer);
  }
};

/// The sweeps of the schedule (run_schedule, smooth/schedule.hpp) on the device: the shared
/// per-vertex work (smooth/sweeps_impl.hpp), a kernel each, nothing read back between sweeps.
struct DeviceSweeps {
  static constexpr bool kHostTimed = false;
  using Rows = SweepRows<const uint32_t*>;

  DeviceMesh& mesh;
  const DeviceAdjacency& adj;
  const SmoothSettings& o;
  DeviceProjection project;
  uint64_t nv = mesh.vertex_count;
  DeviceBuffer<Vec3f> other{};
  Operator op{};
  DeviceBuffer<Vec3f> wx{};
  DeviceBuffer<float> omega{};
  DeviceBuffer<unsigned long long> damped{1};
  std::optional<TreeSum> tree{};

  Rows rows() const {
    return {adj.offsets.data(), adj.neighbors.data(), op.w.data(), op.diag.data(), op.area.data(), o.vertex_relax};
  }
  void swept() {}

  void a_begin() { other.copy_from(mesh.vertices); }
  void a_sweep(float weight) {
    for_each_index(Device{}, nv, ASweep<const uint32_t*, DeviceProjection>{rows(), mesh.vertices.data(), other.data(),
                                                                           o.relax_a, weight, true, project});
    std::swap(mesh.vertices, other);
  }
  void a_end() { other = {}; }

  void build_operator() {
    const MeshRows mesh_rows{adj.offsets.data(), adj.neighbors.data(), adj.tri_offsets.data(), adj.tri_ids.data(),
                             mesh.triangles.data()};
    op.w.resize(adj.neighbors.size());  // cotan_row writes its row whole
    op.diag.resize(nv);
    op.area.resize(nv);
    MENISCUS_LAUNCH(cotan_kernel, blocks_for(nv), 256)(mesh_rows, mesh.vertices.data(), nv, op.w.data(), op.diag.data(),
                                                       op.area.data());
    MENISCUS_CUDA_CHECK_LAUNCH();
    MENISCUS_LAUNCH(area_floor_kernel, blocks_for(nv), 256)(op.area.data(), nv, o.area_floor);
    MENISCUS_CUDA_CHECK_LAUNCH();
    if (!tree) {
      tree.emplace(nv);
      wx.resize(nv);
      omega.resize(nv);
    }
  }
  void set_damping() {
    damped.zero();
    for_each_index(Device{}, nv, BDamping<const uint32_t*>{rows(), o.relax_b, omega.data(), damped.data()});
  }
  void update_wx() { for_each_index(Device{}, nv, ApplyW<const uint32_t*>{rows(), mesh.vertices.data(), wx.data()}); }
  double energy() {  // xᵀBx from wx, in the CPU's tree (reported, it decides nothing)
    MENISCUS_LAUNCH(leaf_energy_kernel, blocks_for(tree->count), 256)(wx.data(), op.area.data(), tree->leaves.data(),
                                                                      tree->count, tree->sums.data());
    MENISCUS_CUDA_CHECK_LAUNCH();
    return tree->finish();
  }
  void b_sweep(bool constrained) {
    for_each_index(Device{}, nv, BSweep<const uint32_t*, DeviceProjection>{rows(), wx.data(), omega.data(),
                                                                           mesh.vertices.data(), constrained, project});
  }
  std::size_t damped_vertices() { return std::size_t(damped.get(0)); }
  double least_damping() {
    std::vector<float> w(nv);
    omega.download(w.data(), nv);
    float least = o.relax_b;
    for (float v : w) least = v < least ? v : least;
    return least;
  }
};

}  // namespace

DeviceAdjacency build_adjacency(const DeviceMesh& mesh) {
  DeviceAdjacency adj;
  const uint64_t nv = mesh.vertex_count, corners = 3 * uint64_t(mesh.triangle_count);
  DeviceBuffer<uint32_t> counts(nv), keys(corners);
  counts.zero();
  adj.tri_ids.resize(corners);
  adj.tri_offsets.resize(nv + 1);
  MENISCUS_LAUNCH(corner_keys_kernel, blocks_for(corners), 256)(mesh.triangles.data(), corners, keys.data(), adj.tri_ids.data(),
                                                   counts.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  exclusive_sum(Device{}, counts.data(), adj.tri_offsets.data(), nv);
  sort_pairs(Device{}, keys.data(), adj.tri_ids.data(), corners, 0, 32);  // stable: each vertex's triangles ascending
  DeviceBuffer<uint32_t> scratch(2 * corners);
  MENISCUS_LAUNCH(neighbour_count_kernel, blocks_for(nv), 256)(mesh.triangles.data(), adj.tri_offsets.data(), adj.tri_ids.data(), nv,
                                                  scratch.data(), counts.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  adj.offsets.resize(nv + 1);
  exclusive_sum(Device{}, counts.data(), adj.offsets.data(), nv);
  adj.neighbors.resize(nv == 0 ? 0 : adj.offsets.get(nv));
  MENISCUS_LAUNCH(neighbour_write_kernel, blocks_for(nv), 256)(adj.tri_offsets.data(), scratch.data(), adj.offsets.data(), nv,
                                                  adj.neighbors.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  return adj;
}

SmoothingStats smooth_surface(DeviceMesh& mesh, const DeviceAdjacency& adj, const DeviceGrid& grid,
                              const SmoothSettings& o) {
  if (mesh.vertex_count == 0 || o.steps_a + o.steps_b + o.steps_free == 0) return {};
  DeviceSweeps sweeps{mesh, adj, o, DeviceProjection{grid.view(), o.r_inner, o.r_outer, o.shells, o.max_axis}};
  return run_schedule(o, sweeps);
}

}  // namespace meniscus::cuda
