// meniscus bench — the OpenVDB baseline ("VDB from Particles" + "Convert VDB" in Houdini terms):
// ParticlesToLevelSet, optional mean-curvature LevelSetFilter passes, volumeToMesh.
#pragma once

#include <cstddef>
#include <span>

#include "meniscus/mesh.hpp"

namespace meniscus::bench {

struct VdbOptions {
  double voxel_size = 0;   ///< h (world units)
  double radius = 0;       ///< world-space particle radius (meniscus' r_outer)
  double half_width = 3;   ///< narrow band half width in voxels (OpenVDB's default)
  int filter_passes = 0;   ///< meanCurvature() passes
};

struct VdbResult {
  TriangleMesh mesh;  ///< quads split into 2 triangles along the shorter diagonal
  double rasterize_seconds = 0, filter_seconds = 0, mesh_seconds = 0;
  std::size_t active_voxels = 0;      ///< after rasterization (the narrow band)
  std::size_t quads = 0;
  std::size_t peak_delta_bytes = 0;   ///< peak RSS over the run minus RSS before it
  double total_seconds() const { return rasterize_seconds + filter_seconds + mesh_seconds; }
};

/// Runs the baseline on the particle positions. Parallel through OpenVDB's own TBB use.
VdbResult run_openvdb(std::span<const Vec3f> particles, const VdbOptions& options);

}  // namespace meniscus::bench
