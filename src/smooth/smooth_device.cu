// meniscus — constrained smoothing on the device (Williams 2008 §4; Edespong 2010 §3.5): the
// schedule of smooth/schedule.hpp over the shared sweeps (sweeps_backend.hpp) run with
// cuda::Device, against the device's hash grid. Every per-vertex formula is the CPU's, in the same
// order of float operations, so both backends give the same mesh.
#include "cuda/primitives.hpp"
#include "cuda/stages_cuda.hpp"
#include "smooth/sweeps_backend.hpp"

namespace meniscus::cuda {

SmoothingStats smooth_surface(DeviceMesh& mesh, const DeviceAdjacency& adj, const DeviceGrid& grid,
                              const SmoothSettings& o) {
  return smooth_mesh(Device{}, mesh, adj, o, ShellProjection<GridView>{grid.view(), o.r_inner, o.r_outer, o.shells, o.max_axis},
                     o.vertex_relax);
}

}  // namespace meniscus::cuda
