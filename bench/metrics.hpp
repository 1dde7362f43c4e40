// meniscus bench — quality of any triangle mesh (ours or OpenVDB's) against the particles it
// should enclose: the quality metrics of `meniscus inspect` plus "particles left outside" and top-face flatness.
#pragma once

#include <cstddef>
#include <span>

#include "meniscus/mesh.hpp"
#include "scenes.hpp"

namespace meniscus::bench {

struct MeshQuality {
  std::size_t vertices = 0, triangles = 0, components = 0;
  bool watertight = false;
  long long genus = -1;         ///< holes and tunnels through the surface (−1: not watertight)
  double volume_over_nd3 = 0;   ///< enclosed volume / (particles · d³)
  int min_valence = 0;
  double share_valence_below_5 = 0;
  double min_angle_degrees = 0, share_angles_below_10 = 0;
  std::size_t sampled = 0, outside = 0;  ///< particles tested / found not enclosed by the mesh
  double flatness_rms_over_d = -1;       ///< top-face RMS plane distance / d; < 0: not applicable
  std::size_t flatness_vertices = 0;
};

/// How many of (a deterministic sample of at most `max_samples` of) `points` the mesh does not
/// enclose (meniscus::points_outside: parity of crossings of a ray). Orientation-independent, so it judges
/// OpenVDB's quads the same way as our triangles; meaningful for closed meshes.
std::size_t points_outside(const TriangleMesh& mesh, std::span<const Vec3f> points, std::size_t max_samples,
                           std::size_t* sampled = nullptr);

/// All metrics of `mesh` for `scene` (flatness only when scene.has_flat_top).
MeshQuality measure_quality(const TriangleMesh& mesh, const Scene& scene, std::size_t max_samples = 2000);

}  // namespace meniscus::bench
