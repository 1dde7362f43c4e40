// meniscus — closest-point and inside queries on a triangle mesh through a bounding-volume
// hierarchy: Embree's BVH builder and traversal (Wald et al., "Embree: A Kernel Framework for
// Efficient CPU Ray Tracing", SIGGRAPH 2014), with our own exact per-triangle tests.
#pragma once

#include <cstdint>
#include <memory>
#include <span>

#include "meniscus/mesh.hpp"
#include "meniscus/vec.hpp"

namespace meniscus {

/// A BVH over the triangles of a mesh. The triangles are Embree user primitives: Embree builds
/// the hierarchy over their bounding boxes (padded by a few ulps so the traversal is
/// conservative) and prunes the traversal; each candidate is tested by closest_point_on_triangle
/// (Ericson 2005) or ray_crosses (double precision), so the answers do not depend on Embree's
/// float arithmetic.
///
/// The vertex and triangle arrays are borrowed: they must outlive the BVH and stay unchanged.
/// Building is parallel (Embree on oneTBB); the queries are const and thread-safe. Throws
/// ResourceError when Embree cannot build the hierarchy (out of memory).
class TriangleBvh {
 public:
  TriangleBvh(std::span<const Vec3f> vertices, std::span<const Triangle> triangles);
  ~TriangleBvh();
  TriangleBvh(const TriangleBvh&) = delete;
  TriangleBvh& operator=(const TriangleBvh&) = delete;

  bool empty() const { return triangles_.empty(); }

  struct Closest {
    float distance = INFINITY;  ///< to the closest point of the surface; INFINITY when none within reach
    uint32_t triangle = UINT32_MAX;
    uint32_t triangle_tests = 0;  ///< point–triangle distances evaluated (the query's cost)
  };
  /// The closest point of the surface to p among the triangles within `max_distance` of it.
  /// The traversal visits only nodes whose boxes lie within the best distance found so far
  /// (and within max_distance), so a finite max_distance bounds the work by the number of
  /// triangles within that distance of p, whatever the rest of the mesh looks like.
  Closest closest(Vec3f p, float max_distance = INFINITY) const;

  /// Whether p lies inside the closed surface: the parity of the crossings of a ray from p
  /// along +x, nudged off the lattice the vertices may share with p (mesh/ray_parity_impl.hpp).
  /// Meaningful for closed meshes. The ray visits only the nodes its line passes through.
  bool inside(Vec3f p) const;

 private:
  struct Impl;
  std::span<const Vec3f> vertices_;
  std::span<const Triangle> triangles_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace meniscus
