// meniscus — the constrained smoothing schedule of Williams 2008 §4: constrained A sweeps
// (graph Laplacian, shrinks the bumpy extraction onto the particles), constrained B sweeps
// (bilaplacian: minimises curvature variation while every vertex stays between r_inner and
// r_outer of its nearest particle), then a few unconstrained B sweeps that smooth the normals.
#pragma once

#include <cstddef>
#include <functional>
#include <span>
#include <vector>

#include "meniscus/mesh.hpp"
#include "meniscus/params.hpp"
#include "smooth/constraints.hpp"
#include "smooth/schedule.hpp"

namespace meniscus {

struct SmoothOptions : SmoothSchedule {
  /// Per-vertex factor in (0, 1] on the damping of every sweep (velocity weighting); empty: 1.
  std::span<const float> vertex_relax;
  /// The sweeps read the neighbour lists in 16 bits an entry (smooth/compact_neighbors.hpp) — the
  /// same result, 12 bytes a vertex less; false only to test that it is the same.
  bool compact_neighbors = true;
  /// The sweeps run on groups of whole connected components, one group after another, each of
  /// about this many vertices (a component larger than that is a group of its own); 0: an eighth
  /// of the mesh, or the whole mesh at once where one component holds over 3/4 of it (groups then
  /// need more memory than the whole, see smooth.cpp). Components do not interact in the sweeps
  /// and every decision of the sweeps is a vertex's own, so the result is the same bit for bit;
  /// only one group's arrays are held at a time. SIZE_MAX: the whole mesh at once.
  std::size_t batch_vertices = 0;
};

/// Runs the schedule on `x` (in place). `constraint` may be null (no projection at all).
/// `progress` receives the completed fraction of all sweeps. Each group of components (above) is
/// smoothed on its own copy of its vertices and triangles, or, as one group, on `x` and
/// `triangles` themselves. Either way the triangles are held packed meanwhile (the vector is empty
/// during the call; a whole-mesh group with a vertex of over kMaxCornerRow neighbours keeps them).
SmoothingStats smooth_surface(std::vector<Vec3f>& x, std::vector<Triangle>& triangles,
                            const ShellConstraint* constraint, const SmoothOptions& options,
                            const std::function<void(double)>& progress = {});

/// No constraint at all.
inline SmoothingStats smooth_surface(std::vector<Vec3f>& x, std::vector<Triangle>& triangles, std::nullptr_t,
                                   const SmoothOptions& options, const std::function<void(double)>& progress = {}) {
  return smooth_surface(x, triangles, static_cast<const ShellConstraint*>(nullptr), options, progress);
}

/// The same schedule with ellipsoid constraints (anisotropic kernels); `constraint` may be null.
SmoothingStats smooth_surface(std::vector<Vec3f>& x, std::vector<Triangle>& triangles,
                            const EllipsoidConstraint* constraint, const SmoothOptions& options,
                            const std::function<void(double)>& progress = {});

}  // namespace meniscus
