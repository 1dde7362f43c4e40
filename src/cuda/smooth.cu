// meniscus — constrained smoothing on the device (Williams 2008 §4; Edespong 2010 §3.5): the mesh
// adjacency (CSR) and the W, D operators assembled from the triangle list, and the schedule of
// smooth/schedule.hpp: Jacobi sweeps (the A sweeps Chebyshev-accelerated, the B sweeps damped per
// vertex), one kernel a sweep for A and two for B, with nothing read back between them. Every
// per-vertex formula is the CPU's (schedule.hpp, operators_impl.hpp, constraint_impl.hpp), in the
// same order of float operations, so both backends give the same mesh.
#include <algorithm>
#include <vector>

#include "cuda/primitives.hpp"
#include "cuda/stages_cuda.hpp"
#include "smooth/constraint_impl.hpp"
#include "smooth/operators_impl.hpp"

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

/// The constraint of the sweeps: Williams' spherical shells, or with `shells` the ellipsoid
/// shells of the anisotropic field (constraint_impl.hpp, as on the CPU); and the per-vertex
/// factor on the damping (velocity weighting; 1 without).
struct Constraint {
  GridView grid;
  float r_inner = 0, r_outer = 0;
  const Ellipsoid* shells = nullptr;
  float max_axis = 1;
  const float* vertex_relax = nullptr;

  __device__ float factor(uint32_t i) const { return vertex_relax != nullptr ? vertex_relax[i] : 1.0f; }
  /// x, moved from `from` (where the previous projection left the vertex) by the sweep.
  __device__ Vec3f project(Vec3f x, Vec3f from) const {
    return shells != nullptr ? project_vertex_in_metric(grid, shells, x, from, r_inner, r_outer, max_axis)
                             : project_vertex_on(grid, x, r_inner, r_outer);
  }
};

/// A sweep, Chebyshev-weighted: x⁽ˢ⁺¹⁾ into `other`, which holds x⁽ˢ⁻¹⁾ (only its own vertex reads it).
__global__ void a_sweep_kernel(const uint32_t* offsets, const uint32_t* neighbors, uint64_t nv, const Vec3f* x,
                               Vec3f* other, float relax, float weight, bool constrained, Constraint c) {
  MENISCUS_GRID_STRIDE(k, nv) {
    const uint32_t i = uint32_t(k);
    const Vec3f y = a_sweep_position(x[i], neighbour_mean_row(offsets, neighbors, x, i), other[i], relax, c.factor(i),
                                     weight);
    other[i] = constrained ? c.project(y, x[i]) : y;
  }
}

/// Each vertex's B damping (b_stable_damping); the count of those below relax_b.
__global__ void b_damping_kernel(const uint32_t* offsets, const uint32_t* neighbors, const float* w, const float* diag,
                                 const float* area, uint64_t nv, float relax_b, float* omega,
                                 unsigned long long* damped) {
  MENISCUS_GRID_STRIDE(k, nv) {
    const uint32_t i = uint32_t(k);
    omega[i] = b_stable_damping(offsets, neighbors, w, diag, area, i, relax_b);
    if (omega[i] < relax_b) atomicAdd(damped, 1ull);
  }
}

/// W x of the current iterate.
__global__ void b_wx_kernel(const uint32_t* offsets, const uint32_t* neighbors, const float* w, const float* diag,
                            const Vec3f* x, uint64_t nv, Vec3f* wx) {
  MENISCUS_GRID_STRIDE(k, nv) { wx[k] = apply_w_row(offsets, neighbors, w, diag, x, uint32_t(k)); }
}

/// A B sweep: every vertex moves from the W x of its ring (which no move of the sweep changes).
__global__ void b_sweep_kernel(const uint32_t* offsets, const uint32_t* neighbors, const float* w, const float* diag,
                               const float* area, const Vec3f* wx, const float* omega, uint64_t nv, Vec3f* x,
                               bool constrained, Constraint c) {
  MENISCUS_GRID_STRIDE(k, nv) {
    const uint32_t i = uint32_t(k);
    float b_ii;
    const Vec3f bx = bilaplacian_row_and_diagonal(offsets, neighbors, w, diag[i], area, wx, i, &b_ii);
    const Vec3f moved = b_sweep_position(x[i], bx, b_ii, omega[i], c.factor(i));
    x[i] = constrained ? c.project(moved, x[i]) : moved;
  }
}

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
  exclusive_sum(counts.data(), adj.tri_offsets.data(), nv);
  sort_pairs(keys, adj.tri_ids, corners, 0, 32);  // stable: each vertex's triangles ascending
  DeviceBuffer<uint32_t> scratch(2 * corners);
  MENISCUS_LAUNCH(neighbour_count_kernel, blocks_for(nv), 256)(mesh.triangles.data(), adj.tri_offsets.data(), adj.tri_ids.data(), nv,
                                                  scratch.data(), counts.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  adj.offsets.resize(nv + 1);
  exclusive_sum(counts.data(), adj.offsets.data(), nv);
  adj.neighbors.resize(nv == 0 ? 0 : adj.offsets.get(nv));
  MENISCUS_LAUNCH(neighbour_write_kernel, blocks_for(nv), 256)(adj.tri_offsets.data(), scratch.data(), adj.offsets.data(), nv,
                                                  adj.neighbors.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  return adj;
}

SmoothingStats smooth_surface(DeviceMesh& mesh, const DeviceAdjacency& adj, const DeviceGrid& grid,
                            const SmoothSettings& o) {
  SmoothingStats report;
  const uint64_t nv = mesh.vertex_count;
  if (nv == 0 || o.steps_a + o.steps_b + o.steps_free == 0) return report;
  Constraint g;
  g.grid = grid.view();
  g.r_inner = o.r_inner;
  g.r_outer = o.r_outer;
  g.shells = o.shells;
  g.max_axis = o.max_axis;
  g.vertex_relax = o.vertex_relax;
  const uint32_t* off = adj.offsets.data();
  const uint32_t* nb = adj.neighbors.data();

  // --- A ---
  if (o.steps_a > 0) {
    DeviceBuffer<Vec3f> other;
    other.copy_from(mesh.vertices);
    float weight = 1.0f;
    for (int s = 0; s < o.steps_a; ++s) {
      weight = chebyshev_weight(s, o.steps_a, weight, o.solver, o.chebyshev_rho);
      MENISCUS_LAUNCH(a_sweep_kernel, blocks_for(nv), 256)(off, nb, nv, mesh.vertices.data(), other.data(), o.relax_a,
                                                           weight, true, g);
      MENISCUS_CUDA_CHECK_LAUNCH();
      std::swap(mesh.vertices, other);
    }
  }

  // --- B ---
  const int steps_b = o.steps_b + o.steps_free;
  if (steps_b <= 0) return report;
  TreeSum tree(nv);
  Operator op;
  const MeshRows rows{off, nb, adj.tri_offsets.data(), adj.tri_ids.data(), mesh.triangles.data()};
  auto build = [&] {
    op.w.resize(adj.neighbors.size());  // cotan_row writes its row whole
    op.diag.resize(nv);
    op.area.resize(nv);
    MENISCUS_LAUNCH(cotan_kernel, blocks_for(nv), 256)(rows, mesh.vertices.data(), nv, op.w.data(), op.diag.data(),
                                                       op.area.data());
    MENISCUS_CUDA_CHECK_LAUNCH();
    MENISCUS_LAUNCH(area_floor_kernel, blocks_for(nv), 256)(op.area.data(), nv, o.area_floor);
    MENISCUS_CUDA_CHECK_LAUNCH();
  };
  DeviceBuffer<Vec3f> wx(nv);
  DeviceBuffer<float> omega(nv);
  DeviceBuffer<unsigned long long> damped(1);
  auto set_damping = [&] {
    damped.zero();
    MENISCUS_LAUNCH(b_damping_kernel, blocks_for(nv), 256)(off, nb, op.w.data(), op.diag.data(), op.area.data(), nv,
                                                           o.relax_b, omega.data(), damped.data());
    MENISCUS_CUDA_CHECK_LAUNCH();
  };
  auto update_wx = [&] {
    MENISCUS_LAUNCH(b_wx_kernel, blocks_for(nv), 256)(off, nb, op.w.data(), op.diag.data(), mesh.vertices.data(), nv,
                                                      wx.data());
    MENISCUS_CUDA_CHECK_LAUNCH();
  };
  auto energy = [&] {  // xᵀBx from wx, in the CPU's tree (reported, it decides nothing)
    MENISCUS_LAUNCH(leaf_energy_kernel, blocks_for(tree.count), 256)(wx.data(), op.area.data(), tree.leaves.data(),
                                                                     tree.count, tree.sums.data());
    MENISCUS_CUDA_CHECK_LAUNCH();
    return tree.finish();
  };
  build();
  set_damping();
  update_wx();
  report.energy_start = energy();
  for (int s = 0; s < steps_b; ++s) {
    if (o.rebuild_b > 0 && s > 0 && s % o.rebuild_b == 0) {
      build();
      set_damping();
      update_wx();
    }
    MENISCUS_LAUNCH(b_sweep_kernel, blocks_for(nv), 256)(off, nb, op.w.data(), op.diag.data(), op.area.data(), wx.data(),
                                                         omega.data(), nv, mesh.vertices.data(), s < o.steps_b, g);
    MENISCUS_CUDA_CHECK_LAUNCH();
    update_wx();
  }
  report.energy_final = energy();
  report.damped_vertices = std::size_t(damped.get(0));
  std::vector<float> w(nv);
  omega.download(w.data(), nv);
  float least = o.relax_b;
  for (float v : w) least = v < least ? v : least;
  report.relax_b_min = least;
  return report;
}

}  // namespace meniscus::cuda
