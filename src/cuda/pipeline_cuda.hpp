// meniscus — the CUDA backend's pipeline (docs/gpu.md: every stage on the device): one upload of
// the particles, hash grid → sparse distance field → extraction → weld → void removal →
// constrained smoothing → erosion → attribute transfer → normals, one download of the mesh; with
// the field methods of issue #7 (kernel fields, particle smoothing, anisotropic kernels and
// ellipsoid constraints, velocity weighting) as on the CPU.
// The per-element math is the CPU's (*_impl.hpp headers with MENISCUS_HD), in the same order,
// so the two backends agree (docs/gpu.md).
#pragma once

#include "meniscus/mesh.hpp"
#include "meniscus/params.hpp"
#include "meniscus/particles.hpp"
#include "meniscus/reconstruct.hpp"
#include "stage_plan.hpp"

#include <vector>

namespace meniscus::cuda {

/// Runs the stages of `in.plan` (the CPU pipeline's plan) on CUDA device 0 with the resolved
/// parameters `in.params` (Params after resolve_params). Appends the stage times (device time of each stage,
/// measured with CUDA events; "upload" and "download" are stages of their own) and the counts
/// to `stats`, and fills `mesh`. Throws ResourceError when the job would not fit in device
/// memory (checked before the large allocations), CudaError (a ResourceError) when a CUDA call
/// fails, InvalidParameter like the CPU stages. Device memory is released on every path.
/// `in.volumes`: the SPH volumes m/ρ per original particle for --field sph|anisotropic;
/// `in.velocity`: the particles' velocity attribute for --velocity-weighted (with
/// velocity_reference resolved).
void reconstruct(const PipelineInput& in, Stats& stats, TriangleMesh& mesh, const ProgressFn& progress);

}  // namespace meniscus::cuda
