// meniscus — constrained smoothing on the device (Williams 2008 §4; Edespong 2010 §3.5): the mesh
// adjacency (CSR) and the W, D, diag(B) operators assembled from the triangle list, the
// Gauss–Seidel colouring, the A and B sweeps with the constraint projection, and the energy guard.
// Every per-vertex formula is the CPU's (operators_impl.hpp, constraint_impl.hpp). The colouring
// is the CPU's greedy colouring in vertex order, computed in parallel rounds: a vertex is coloured
// once all its lower-numbered neighbours (within the colouring distance) are, with the smallest
// colour none of them has — exactly what the sequential greedy pass gives it — so both backends
// sweep the same colour classes in the same order.
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

// --- colouring --------------------------------------------------------------------------------------

constexpr int kMaxColors = 256;

/// Calls f(j) for every entry of the CPU's colouring neighbourhood of i (with repeats, as the
/// CPU visits them): the ring, and for distance 2 the rings of the ring without i.
template <class F>
__device__ void for_each_colour_neighbour(const uint32_t* offsets, const uint32_t* neighbors, uint32_t i, int distance,
                                          F&& f) {
  for (uint32_t e = offsets[i]; e < offsets[i + 1]; ++e) {
    const uint32_t j = neighbors[e];
    f(j);
    if (distance >= 2)
      for (uint32_t e2 = offsets[j]; e2 < offsets[j + 1]; ++e2)
        if (neighbors[e2] != i) f(neighbors[e2]);
  }
}

__global__ void predecessor_kernel(const uint32_t* offsets, const uint32_t* neighbors, uint64_t nv, int distance,
                                   uint32_t* pending, uint32_t* frontier, uint32_t* frontier_size) {
  MENISCUS_GRID_STRIDE(i, nv) {
    uint32_t n = 0;
    for_each_colour_neighbour(offsets, neighbors, uint32_t(i), distance, [&](uint32_t j) { n += j < i ? 1u : 0u; });
    pending[i] = n;
    if (n == 0) frontier[atomicAdd(frontier_size, 1u)] = uint32_t(i);
  }
}

__global__ void colour_round_kernel(const uint32_t* offsets, const uint32_t* neighbors, int distance,
                                    const uint32_t* frontier, uint32_t size, uint16_t* color, uint32_t* pending,
                                    uint32_t* next, uint32_t* next_size, int* overflow) {
  MENISCUS_GRID_STRIDE(k, size) {
    const uint32_t i = frontier[k];
    uint64_t taken[kMaxColors / 64] = {};
    for_each_colour_neighbour(offsets, neighbors, i, distance, [&](uint32_t j) {
      if (j < i) taken[color[j] / 64] |= uint64_t(1) << (color[j] % 64);
    });
    int c = 0;
    while (c < kMaxColors && (taken[c / 64] >> (c % 64)) & 1) ++c;
    if (c == kMaxColors) {
      *overflow = 1;
      c = kMaxColors - 1;
    }
    color[i] = uint16_t(c);
    for_each_colour_neighbour(offsets, neighbors, i, distance, [&](uint32_t j) {
      if (j > i && atomicSub(&pending[j], 1u) == 1u) next[atomicAdd(next_size, 1u)] = j;
    });
  }
}

__global__ void colour_keys_kernel(const uint16_t* color, uint64_t nv, uint32_t* keys, uint32_t* ids) {
  MENISCUS_GRID_STRIDE(i, nv) {
    keys[i] = color[i];
    ids[i] = uint32_t(i);
  }
}

struct DeviceColoring {
  DeviceBuffer<uint32_t> vertices;
  std::vector<uint32_t> offsets;  ///< host: the class boundaries
};

DeviceColoring color_vertices(const DeviceAdjacency& adj, uint64_t nv, int distance) {
  DeviceColoring out;
  DeviceBuffer<uint32_t> pending(nv), frontier(nv), next(nv), size(2);
  DeviceBuffer<uint16_t> color(nv);
  DeviceBuffer<int> overflow(1);
  overflow.zero();
  size.zero();
  MENISCUS_LAUNCH(predecessor_kernel, blocks_for(nv), 256)(adj.offsets.data(), adj.neighbors.data(), nv, distance, pending.data(),
                                              frontier.data(), size.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  uint32_t count = size.get(0);
  while (count > 0) {
    MENISCUS_CUDA_CHECK(counted_memset(size.data() + 1, 0, sizeof(uint32_t)));
    MENISCUS_LAUNCH(colour_round_kernel, blocks_for(count), 256)(adj.offsets.data(), adj.neighbors.data(), distance,
                                                    frontier.data(), count, color.data(), pending.data(), next.data(),
                                                    size.data() + 1, overflow.data());
    MENISCUS_CUDA_CHECK_LAUNCH();
    count = size.get(1);
    std::swap(frontier, next);
  }
  if (overflow.get(0) != 0)
    throw ResourceError("smoothing (cuda): the Gauss-Seidel colouring needs more than 256 colours");
  // Classes in colour order, vertices ascending within a class (stable sort of ascending ids).
  DeviceBuffer<uint32_t> keys(nv);
  out.vertices.resize(nv);
  MENISCUS_LAUNCH(colour_keys_kernel, blocks_for(nv), 256)(color.data(), nv, keys.data(), out.vertices.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  sort_pairs(keys, out.vertices, nv, 0, 16);
  std::vector<uint32_t> sorted_colors(nv);  // class boundaries: one word per vertex, once per phase
  keys.download(sorted_colors.data(), nv);
  out.offsets.push_back(0);
  for (uint64_t i = 1; i <= nv; ++i)
    if (i == nv || sorted_colors[i] != sorted_colors[i - 1]) out.offsets.push_back(uint32_t(i));
  return out;
}

// --- operators ----------------------------------------------------------------------------------------

struct Operator {
  DeviceBuffer<float> w, diag, area, b_diag;
};

__global__ void cotan_kernel(MeshRows rows, const Vec3f* x, uint64_t nv, float* w, float* diag, float* area) {
  MENISCUS_GRID_STRIDE(i, nv) { cotan_row(rows, x, uint32_t(i), w, &diag[i], &area[i]); }
}

__global__ void floor_and_bdiag_kernel(const uint32_t* offsets, const uint32_t* neighbors, const float* w,
                                       const float* diag, float* area, uint64_t nv, const double* mean_area,
                                       float* b_diag, int phase) {
  MENISCUS_GRID_STRIDE(i, nv) {
    if (phase == 0) {
      const double m = *mean_area / double(nv > 1 ? nv : 1);
      const float floor = float(m * 1e-6 > 1e-30 ? m * 1e-6 : 1e-30);
      area[i] = area[i] < floor ? floor : area[i];  // std::max(a, floor)
    } else {
      b_diag[i] = bilaplacian_diagonal_row(offsets, neighbors, w, diag, area, uint32_t(i));
    }
  }
}

// --- the fixed-tree sums (operators_impl.hpp) -----------------------------------------------------------

__global__ void leaf_area_kernel(const float* area, const uint64_t* leaves, uint64_t count, double* sums) {
  MENISCUS_GRID_STRIDE(l, count) {
    double s = 0.0;
    for (uint64_t k = leaves[l]; k < leaves[l + 1]; ++k) s += double(area[k]);
    sums[l] = s;
  }
}

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

__global__ void apply_w_kernel(const uint32_t* offsets, const uint32_t* neighbors, const float* w, const float* diag,
                               const Vec3f* x, uint64_t nv, Vec3f* y) {
  MENISCUS_GRID_STRIDE(i, nv) { y[i] = apply_w_row(offsets, neighbors, w, diag, x, uint32_t(i)); }
}

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
  __device__ void project(Vec3f* x, uint32_t i) const {
    x[i] = shells != nullptr ? project_vertex_in_metric(grid, shells, x[i], r_inner, r_outer, max_axis)
                             : project_vertex_on(grid, x[i], r_inner, r_outer);
  }
};

/// A sweep on `count` vertices (a colour class, or all of them for Jacobi with x_in ≠ x_out).
__global__ void a_sweep_kernel(const uint32_t* offsets, const uint32_t* neighbors, const uint32_t* vertices,
                               uint64_t count, const Vec3f* x_in, Vec3f* x_out, float w, Constraint c,
                               bool project_now) {
  MENISCUS_GRID_STRIDE(k, count) {
    const uint32_t i = vertices != nullptr ? vertices[k] : uint32_t(k);
    x_out[i] = x_in[i] + (neighbour_mean_row(offsets, neighbors, x_in, i) - x_in[i]) * (w * c.factor(i));
    if (project_now) c.project(x_out, i);
  }
}

__global__ void project_kernel(Vec3f* x, uint64_t nv, Constraint c) {
  MENISCUS_GRID_STRIDE(i, nv) { c.project(x, uint32_t(i)); }
}

__global__ void b_gauss_seidel_kernel(const uint32_t* offsets, const uint32_t* neighbors, const uint32_t* vertices,
                                      uint64_t count, const float* w, const float* diag, const float* area,
                                      const float* b_diag, Vec3f* x, Vec3f* wx, float relax, bool constrained,
                                      Constraint c) {
  MENISCUS_GRID_STRIDE(k, count) {
    const uint32_t i = vertices[k];
    const Vec3f before = x[i];
    x[i] -= bilaplacian_row_from_wx(offsets, neighbors, w, diag, area, wx, i) * (relax * c.factor(i) / b_diag[i]);
    if (constrained) c.project(x, i);
    const Vec3f delta = x[i] - before;
    wx[i] += delta * diag[i];
    for (uint32_t e = offsets[i]; e < offsets[i + 1]; ++e) wx[neighbors[e]] += delta * w[e];
  }
}

__global__ void divide_area_kernel(const Vec3f* wx, const float* area, uint64_t nv, Vec3f* z) {
  MENISCUS_GRID_STRIDE(i, nv) { z[i] = wx[i] / area[i]; }
}

__global__ void b_jacobi_kernel(const Vec3f* bx, const float* b_diag, uint64_t nv, Vec3f* x, float relax,
                                bool constrained, Constraint c) {
  MENISCUS_GRID_STRIDE(i, nv) {
    x[i] -= bx[i] * (relax * c.factor(uint32_t(i)) / b_diag[i]);
    if (constrained) c.project(x, uint32_t(i));
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

SmoothReport smooth_surface(DeviceMesh& mesh, const DeviceAdjacency& adj, const DeviceGrid& grid,
                            const SmoothSettings& o) {
  SmoothReport report;
  const uint64_t nv = mesh.vertex_count;
  if (nv == 0 || o.steps_a + o.steps_b + o.steps_free == 0) return report;
  const bool gauss_seidel = o.solver == SmoothingSolver::gauss_seidel;
  Constraint g;
  g.grid = grid.view();
  g.r_inner = o.r_inner;
  g.r_outer = o.r_outer;
  g.shells = o.shells;
  g.max_axis = o.max_axis;
  g.vertex_relax = o.vertex_relax;
  const uint32_t* off = adj.offsets.data();
  const uint32_t* nb = adj.neighbors.data();
  Vec3f* x = mesh.vertices.data();
  DeviceBuffer<Vec3f> next(nv), scratch(nv), backup(nv);

  // --- A ---
  if (o.steps_a > 0) {
    if (gauss_seidel) {
      const DeviceColoring colors = color_vertices(adj, nv, 1);
      for (int s = 0; s < o.steps_a; ++s)
        for (std::size_t c = 0; c + 1 < colors.offsets.size(); ++c) {
          const uint32_t b = colors.offsets[c], e = colors.offsets[c + 1];
          MENISCUS_LAUNCH(a_sweep_kernel, blocks_for(e - b), 256)(off, nb, colors.vertices.data() + b, e - b, x, x, o.relax_a, g,
                                                     true);
          MENISCUS_CUDA_CHECK_LAUNCH();
        }
    } else {
      for (int s = 0; s < o.steps_a; ++s) {
        MENISCUS_LAUNCH(a_sweep_kernel, blocks_for(nv), 256)(off, nb, nullptr, nv, mesh.vertices.data(), next.data(), o.relax_a, g,
                                                false);
        MENISCUS_CUDA_CHECK_LAUNCH();
        std::swap(mesh.vertices, next);
        x = mesh.vertices.data();
        MENISCUS_LAUNCH(project_kernel, blocks_for(nv), 256)(x, nv, g);
        MENISCUS_CUDA_CHECK_LAUNCH();
      }
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
    op.b_diag.resize(nv);
    MENISCUS_LAUNCH(cotan_kernel, blocks_for(nv), 256)(rows, mesh.vertices.data(), nv, op.w.data(), op.diag.data(), op.area.data());
    MENISCUS_CUDA_CHECK_LAUNCH();
    MENISCUS_LAUNCH(leaf_area_kernel, blocks_for(tree.count), 256)(op.area.data(), tree.leaves.data(), tree.count, tree.sums.data());
    MENISCUS_CUDA_CHECK_LAUNCH();
    tree.finish();  // tree.total = Σ area, in the CPU's tree
    for (int phase = 0; phase < 2; ++phase) {
      MENISCUS_LAUNCH(floor_and_bdiag_kernel, blocks_for(nv), 256)(off, nb, op.w.data(), op.diag.data(), op.area.data(), nv,
                                                      tree.total.data(), op.b_diag.data(), phase);
      MENISCUS_CUDA_CHECK_LAUNCH();
    }
  };
  auto energy_of = [&] {  // scratch = W x; returns xᵀBx
    MENISCUS_LAUNCH(apply_w_kernel, blocks_for(nv), 256)(off, nb, op.w.data(), op.diag.data(), mesh.vertices.data(), nv,
                                            scratch.data());
    MENISCUS_CUDA_CHECK_LAUNCH();
    MENISCUS_LAUNCH(leaf_energy_kernel, blocks_for(tree.count), 256)(scratch.data(), op.area.data(), tree.leaves.data(), tree.count,
                                                        tree.sums.data());
    MENISCUS_CUDA_CHECK_LAUNCH();
    return tree.finish();
  };
  auto energy_from_wx = [&] {  // scratch already holds W x (kept current by the Gauss–Seidel sweep)
    MENISCUS_LAUNCH(leaf_energy_kernel, blocks_for(tree.count), 256)(scratch.data(), op.area.data(), tree.leaves.data(), tree.count,
                                                        tree.sums.data());
    MENISCUS_CUDA_CHECK_LAUNCH();
    return tree.finish();
  };
  build();
  DeviceColoring colors;
  if (gauss_seidel) colors = color_vertices(adj, nv, 2);
  float w = o.relax_b;
  double energy = energy_of();
  report.energy_start = energy;
  for (int s = 0; s < steps_b; ++s) {
    const bool constrained = s < o.steps_b;
    if (o.rebuild_b > 0 && s > 0 && s % o.rebuild_b == 0) {
      build();
      energy = energy_of();
    }
    backup.copy_from(mesh.vertices);
    x = mesh.vertices.data();
    if (gauss_seidel) {
      for (std::size_t c = 0; c + 1 < colors.offsets.size(); ++c) {
        const uint32_t b = colors.offsets[c], e = colors.offsets[c + 1];
        MENISCUS_LAUNCH(b_gauss_seidel_kernel, blocks_for(e - b), 256)(off, nb, colors.vertices.data() + b, e - b, op.w.data(),
                                                          op.diag.data(), op.area.data(), op.b_diag.data(), x,
                                                          scratch.data(), w, constrained, g);
        MENISCUS_CUDA_CHECK_LAUNCH();
      }
    } else {
      DeviceBuffer<Vec3f> z(nv);
      MENISCUS_LAUNCH(divide_area_kernel, blocks_for(nv), 256)(scratch.data(), op.area.data(), nv, z.data());
      MENISCUS_CUDA_CHECK_LAUNCH();
      MENISCUS_LAUNCH(apply_w_kernel, blocks_for(nv), 256)(off, nb, op.w.data(), op.diag.data(), z.data(), nv, next.data());
      MENISCUS_CUDA_CHECK_LAUNCH();
      MENISCUS_LAUNCH(b_jacobi_kernel, blocks_for(nv), 256)(next.data(), op.b_diag.data(), nv, x, w, constrained, g);
      MENISCUS_CUDA_CHECK_LAUNCH();
    }
    const double e = gauss_seidel ? energy_from_wx() : energy_of();
    const double tolerance = constrained ? 0.05 : 1e-4;
    if (e > energy * (1.0 + tolerance) && w > 1.0f / 64) {
      std::swap(mesh.vertices, backup);
      w *= 0.5f;
      ++report.relax_halvings;
      energy_of();
      --s;
      continue;
    }
    energy = e;
  }
  report.energy_final = energy;
  report.relax_b_final = w;
  return report;
}

}  // namespace meniscus::cuda
