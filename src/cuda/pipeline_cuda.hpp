// meniscus — the CUDA backend's stages (docs/gpu.md): one upload of the particles, every stage of the
// plan on the device — hash grid, field (distance or kernel, with particle smoothing and
// anisotropic kernels), extraction and weld, void and blob removal, adjacency, constrained
// smoothing, erosion, attribute transfer, normals — and one download of the mesh. The driver
// (pipeline/driver.cpp) runs them in the plan's order through make_device_stages
// (pipeline/stages.hpp), the same order as the CPU's; the per-element math is the CPU's
// (*_impl.hpp headers with MENISCUS_HD), in the same order, so the two backends agree.
//
// Stage times are device times (CUDA events); "upload", "adjacency" and "download" are stages of
// their own. A job that would not fit in device memory is refused (ResourceError) before the large
// allocations, a failed CUDA call is a CudaError (a ResourceError); device memory is released on
// every path.
#pragma once

#include "pipeline/stages.hpp"
