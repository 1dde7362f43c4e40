// meniscus — the sweeps of the smoothing schedule (run_schedule, smooth/schedule.hpp) written once
// over the backend tag (Host or cuda::Device) and the mesh arrays of mesh_buffers.hpp: W and D
// assembled per vertex from the triangle lists (operators_impl.hpp), the sweeps of sweeps_impl.hpp,
// one pass each, nothing read back between sweeps; the energy summed in deterministic_sum's fixed
// tree, the least damping by reduce_index. The device runs it (smooth/smooth_device.cu). The CPU
// runs its own sweeps (smooth.cpp: 16-bit neighbour lists, corner lists instead of triangle lists,
// no stored diagonal, the particles near each vertex cached for the projection), which
// tests/unit/test_smooth_schedule.cpp holds to this one, run with Host{}, bit for bit.
#pragma once

#include <cstdint>
#include <optional>
#include <type_traits>
#include <utility>

#include "common/buffer.hpp"
#include "meniscus/reconstruct.hpp"
#include "meniscus/vec.hpp"
#include "mesh/mesh_buffers.hpp"
#include "smooth/constraint_impl.hpp"
#include "smooth/operators_impl.hpp"
#include "smooth/schedule.hpp"
#include "smooth/sweeps_impl.hpp"

namespace meniscus {

/// Williams' spherical shells around the particles of `grid` (a Grid of hash_grid_impl.hpp: the
/// device's GridView, the CPU's HashGrid), or with `shells` the ellipsoid shells of the anisotropic
/// field (constraint_impl.hpp).
template <class Grid>
struct ShellProjection {
  Grid grid;
  float r_inner = 0, r_outer = 0;
  const Ellipsoid* shells = nullptr;
  float max_axis = 1;

  /// Vertex i, moved from `from` (where the previous projection left it) to `moved` by the sweep.
  MENISCUS_HD Vec3f operator()(uint32_t /*i*/, Vec3f moved, Vec3f from) const {
    return shells != nullptr ? project_vertex_in_metric(grid, shells, moved, from, r_inner, r_outer, max_axis)
                             : project_vertex_on(grid, moved, r_inner, r_outer);
  }
};

namespace sweeps {

/// Row i of W and D from i's triangle lists (cotan_row).
struct CotanRows {
  MeshRows rows;
  const Vec3f* x;
  float* w;
  float* diag;
  float* area;
  MENISCUS_HD void operator()(uint64_t i) const { cotan_row(rows, x, uint32_t(i), w, &diag[i], &area[i]); }
};

/// D_i at least `floor` (collapsed vertices), as std::max(D_i, floor).
struct AreaFloor {
  float* area;
  float floor;
  MENISCUS_HD void operator()(uint64_t i) const { area[i] = area[i] < floor ? floor : area[i]; }
};

/// Vertex k's term of xᵀBx.
struct EnergyTerm {
  const Vec3f* wx;
  const float* area;
  MENISCUS_HD double operator()(uint64_t k) const { return energy_term(wx[k], area[k]); }
};

/// ω_i, and the least of them.
struct OmegaAt {
  const float* omega;
  MENISCUS_HD float operator()(uint64_t i) const { return omega[i]; }
};
struct Least {
  MENISCUS_HD float operator()(float a, float b) const { return b < a ? b : a; }
};

}  // namespace sweeps

/// The sweeps of run_schedule on backend B over `mesh` (its vertices are the iterate) and its
/// adjacency `adj` (with triangle lists), constrained by `project` (a MENISCUS_HD callable as
/// ShellProjection; NoProjection for none). B's primitives (common/primitives.hpp or
/// cuda/primitives.hpp) must be declared before it is instantiated.
template <class B, class Project>
struct BackendSweeps {
  using Rows = SweepRows<const uint32_t*>;
  /// The host's clock measures the CPU's sweeps; the device's launches return at once.
  static constexpr bool kHostTimed = std::is_same_v<B, Host>;

  MeshBuffers<B>& mesh;
  const AdjacencyBuffers<B>& adj;
  const SmoothSchedule& o;
  Project project;
  const float* vertex_relax = nullptr;  ///< per-vertex factor on the damping (velocity weighting); null: 1
  uint64_t nv = mesh.vertex_count;
  BufferOf<B, Vec3f> other{};
  BufferOf<B, float> w{}, diag{}, area{};
  BufferOf<B, Vec3f> wx{};
  BufferOf<B, float> omega{};
  BufferOf<B, unsigned long long> damped{1};

  Rows rows() const { return {adj.offsets.data(), adj.neighbors.data(), w.data(), diag.data(), area.data(), vertex_relax}; }
  void swept() {}

  void a_begin() { other.copy_from(mesh.vertices); }
  void a_sweep(float weight) {
    for_each_index(B{}, nv, ASweep<const uint32_t*, Project>{rows(), mesh.vertices.data(), other.data(), o.relax_a,
                                                             weight, true, project});
    std::swap(mesh.vertices, other);
  }
  void a_end() { other = {}; }

  void build_operator() {
    const MeshRows mesh_rows{adj.offsets.data(), adj.neighbors.data(), adj.tri_offsets.data(), adj.tri_ids.data(),
                             mesh.triangles.data()};
    w.resize(adj.neighbors.size());  // cotan_row writes its row whole
    diag.resize(nv);
    area.resize(nv);
    for_each_index(B{}, nv, sweeps::CotanRows{mesh_rows, mesh.vertices.data(), w.data(), diag.data(), area.data()});
    for_each_index(B{}, nv, sweeps::AreaFloor{area.data(), o.area_floor});
    wx.resize(nv);
    omega.resize(nv);
  }
  void set_damping() {
    damped.zero();
    for_each_index(B{}, nv, BDamping<const uint32_t*>{rows(), o.relax_b, omega.data(), damped.data()});
  }
  void update_wx() { for_each_index(B{}, nv, ApplyW<const uint32_t*>{rows(), mesh.vertices.data(), wx.data()}); }
  /// xᵀBx from W x, in the fixed tree of deterministic_sum (reported; it decides nothing).
  double energy() { return deterministic_sum(B{}, nv, kSumTreeGrain, sweeps::EnergyTerm{wx.data(), area.data()}); }
  void b_sweep(bool constrained) {
    for_each_index(B{}, nv, BSweep<const uint32_t*, Project>{rows(), wx.data(), omega.data(), mesh.vertices.data(),
                                                             constrained, project});
  }
  std::size_t damped_vertices() { return std::size_t(damped.get(0)); }
  double least_damping() { return reduce_index(B{}, nv, o.relax_b, sweeps::OmegaAt{omega.data()}, sweeps::Least{}); }
};

/// The schedule `o` over `mesh` on backend B (smooth_surface's sweeps; see BackendSweeps).
template <class B, class Project>
SmoothingStats smooth_mesh(B, MeshBuffers<B>& mesh, const AdjacencyBuffers<B>& adj, const SmoothSchedule& o,
                           Project project, const float* vertex_relax = nullptr) {
  if (mesh.vertex_count == 0 || o.steps_a + o.steps_b + o.steps_free == 0) return {};
  BackendSweeps<B, Project> s{mesh, adj, o, project, vertex_relax};
  return run_schedule(o, s);
}

}  // namespace meniscus
