// meniscus — mesh quality metrics (docs/cli.md "meniscus inspect"): topology, valence, angles, constraint residual,
// flatness, volume. Independent of the pipeline: they judge any mesh, ours or another tool's.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "meniscus/mesh.hpp"
#include "meniscus/particles.hpp"

namespace meniscus {

struct TopologyReport {
  std::size_t vertices = 0, triangles = 0, edges = 0;
  std::size_t boundary_edges = 0;        ///< edges with one incident triangle
  std::size_t nonmanifold_edges = 0;     ///< edges with more than two incident triangles
  std::size_t misoriented_edges = 0;     ///< edges whose two triangles traverse it the same way
  std::size_t nonmanifold_vertices = 0;  ///< vertices whose triangle fan is not a single disk
  std::size_t degenerate_triangles = 0;  ///< repeated index or zero area
  std::size_t unreferenced_vertices = 0;
  std::size_t components = 0;            ///< connected components (by shared edges)
  long long euler = 0;                   ///< V − E + F over referenced vertices

  bool closed() const { return boundary_edges == 0; }
  bool edge_manifold() const { return nonmanifold_edges == 0; }
  bool oriented() const { return misoriented_edges == 0; }
  /// Handles (holes and tunnels through the surface) summed over the components: C − χ/2.
  /// Meaningful for a watertight mesh.
  long long genus() const { return (long long)components - euler / 2; }
  bool watertight() const {
    return closed() && edge_manifold() && oriented() && nonmanifold_vertices == 0;
  }
};
TopologyReport analyze_topology(const TriangleMesh& mesh);

struct ValenceReport {
  int min = 0, max = 0;
  double mean = 0;
  std::size_t below_5 = 0;                  ///< vertices with valence < 5
  std::vector<std::size_t> histogram;       ///< histogram[v] = vertices of valence v
};
/// Valence = number of distinct neighbours over edges. Unreferenced vertices are ignored.
ValenceReport valence(const TriangleMesh& mesh);

struct AngleReport {
  double min_degrees = 0, max_degrees = 0;
  double share_below_10 = 0;  ///< fraction of angles under 10°
};
AngleReport triangle_angles(const TriangleMesh& mesh);

/// Signed volume enclosed by the mesh (positive when triangles face outwards).
double signed_volume(const TriangleMesh& mesh);

struct ConstraintReport {
  double max_violation = 0;   ///< max over vertices of the distance outside [r_inner, r_outer]
  double min_distance = 0;    ///< min over vertices of the distance to the nearest particle
  double max_distance = 0;    ///< max over vertices of the distance to the nearest particle
};
/// Distance of every vertex to its nearest particle against [r_inner, r_outer].
ConstraintReport constraint_residual(std::span<const Vec3f> vertices, std::span<const Vec3f> particles,
                                     double r_inner, double r_outer);

struct PlaneFit {
  Vec3f normal, centroid;
  double rms = 0;        ///< RMS distance of the points to the best-fit plane
  double max_abs = 0;    ///< largest distance
  std::size_t count = 0;
};
/// Least-squares plane through the points (smallest eigenvector of the covariance).
PlaneFit fit_plane(std::span<const Vec3f> points);

struct SurfaceDistanceReport {
  /// Over the points: distance to the closest point of the surface; a point with no surface
  /// within `cap` counts as `cap` (mean, p95 and max are then lower bounds).
  double mean = 0, p95 = 0, max = 0;
  std::size_t count = 0;
  std::size_t beyond_cap = 0;      ///< points with no surface within `cap`
  double cap = INFINITY;           ///< the search distance asked for
  std::size_t triangle_tests = 0;  ///< point–triangle distances evaluated: the measure's cost
};
/// Distance of every point to the closest point of the triangles of `surface`, through a BVH of
/// the triangles (Embree). The search of each point stops at `cap`: the work per point is then
/// bounded by the triangles within `cap` of it, whatever the two geometries are (two unrelated
/// frames, a frame far away, one droplet inside a hollow shell). The frame-to-frame flicker of a
/// sequence is distance_to_surface(frame t's vertices, frame t−1's mesh, flicker cap). An empty
/// surface gives count 0 and zeros. Parallel over the points.
SurfaceDistanceReport distance_to_surface(std::span<const Vec3f> points, const TriangleMesh& surface,
                                          double cap = INFINITY);

/// `count` points on the triangles of `mesh`, each triangle picked with a chance in proportion to
/// its area and the point uniform on it, from a generator seeded with `seed` (the same mesh and
/// seed give the same points): with the vertices, what the distance between two surfaces is
/// measured on (bench/compare.cpp, tests/e2e/test_decimate.cpp).
std::vector<Vec3f> random_surface_points(const TriangleMesh& mesh, std::size_t count, uint32_t seed);

/// The jitter of a frame of a sequence: the flicker without the motion. From points on frame t's
/// surface, s₋ and s₊ are the signed distances (negative inside) to frames t−1 and t+1; a surface
/// moving at a constant velocity v gives s₋ + s₊ = 0 to first order (a curvature 1/R leaves
/// |v_tangential|²/R), noise e_t gives 2e_t − e_{t−1} − e_{t+1}. The
/// jitter is |s₋ + s₊| / 2 over the points (in the meshes' units).
struct JitterReport {
  double median = 0, p90 = 0;
  std::size_t points = 0;      ///< points measured (those with both surfaces within the cap)
  std::size_t beyond_cap = 0;  ///< points left out: a surface farther than the cap (a droplet that
                               ///< appears, a cut: topology, not jitter)
};
/// The jitter of `current` between `previous` and `next`, on `count` random_surface_points of it
/// (seed `seed`), each surface searched up to `cap`. The sign: the side of the closest triangle.
JitterReport surface_jitter(const TriangleMesh& previous, const TriangleMesh& current, const TriangleMesh& next,
                            std::size_t count, uint32_t seed, double cap);
/// The points surface_jitter measures a frame on (its median to about 1.5 %).
inline constexpr std::size_t kJitterPoints = 10000;

/// The flicker's search distance in particle spacings: a vertex farther than this from the
/// previous frame's surface is not flicker (a fraction of d) but a cut, an emitter or a frame
/// out of order; it counts at the cap, and the search costs at most the triangles within it.
inline constexpr double kFlickerCapSpacings = 4;
/// The same distance in mean edge lengths, for meshes whose spacing is unknown: a meniscus
/// mesh's mean edge is about d/4 at the default voxel size d/2.
inline constexpr double kFlickerCapEdges = 16;

/// The fewest triangles any mesh within `bound` of `mesh` (both ways) can have, estimated from
/// its curved parts: where the surface bends the same way in every direction (Gaussian
/// curvature K > 0: droplets, crests), a plane stays within `bound` of it only over an area of
/// about 3√3·bound/√K (in coordinates where the surface is z = (x² + y²)/2, a triangle within
/// `bound` of it fits in a disk of radius 2√bound: at most 3√3·bound), so such a mesh needs at
/// least ∫_{K>0} √K dA / (3√3·bound) triangles there, whatever its flat and saddle parts take. K
/// is each vertex's angle defect over its share of area, both summed over its rings twice (a
/// filter about half a spacing wide on a meniscus mesh, wide enough that more rings hardly change
/// the estimate on the bundled frames); vertices on a border add nothing. A lower estimate for
/// small bounds, what a simplification at that bound is measured against (bench/compare.cpp).
double least_triangles_within(const TriangleMesh& mesh, double bound);

/// Mean length of the triangles' edges (each side of each triangle once); 0 without triangles.
double mean_edge_length(const TriangleMesh& mesh);

/// How many of `points` lie outside the closed mesh (ray parity along +x through a BVH of the
/// triangles; rays are nudged off exact edges). Meaningful for closed meshes.
std::size_t points_outside(const TriangleMesh& mesh, std::span<const Vec3f> points);

}  // namespace meniscus
