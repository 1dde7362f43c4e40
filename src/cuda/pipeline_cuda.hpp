// meniscus — the CUDA backend's pipeline (DESIGN §1, every stage on the device): one upload of
// the particles, hash grid → sparse distance field → extraction → weld → void removal →
// constrained smoothing → erosion → attribute transfer → normals, one download of the mesh.
// The per-element math is the CPU's (*_impl.hpp headers with MENISCUS_HD), in the same order,
// so the two backends agree (README "GPU (CUDA)": parity).
#pragma once

#include "meniscus/mesh.hpp"
#include "meniscus/params.hpp"
#include "meniscus/particles.hpp"
#include "meniscus/reconstruct.hpp"

namespace meniscus::cuda {

/// Runs the stages after parameter resolution on CUDA device 0 with the resolved parameters
/// `p` (Params after resolve_params). Appends the stage times (device time of each stage,
/// measured with CUDA events; "upload" and "download" are stages of their own) and the counts
/// to `stats`, and fills `mesh`. Throws ResourceError when the job would not fit in device
/// memory (checked before the large allocations), CudaError (a ResourceError) when a CUDA call
/// fails, InvalidParameter like the CPU stages. Device memory is released on every path.
void reconstruct(const ParticleSet& particles, const Params& p, Stats& stats, TriangleMesh& mesh,
                 const ProgressFn& progress);

}  // namespace meniscus::cuda
