// meniscus — area-weighted vertex normals, erosion along them.
#pragma once

#include <span>
#include <vector>

#include "meniscus/mesh.hpp"

namespace meniscus {

/// Unit area-weighted vertex normals (sum of the incident triangles' cross products).
/// Vertices without triangles get (0,0,0).
std::vector<Vec3f> vertex_normals(std::span<const Vec3f> x, std::span<const Triangle> triangles);

/// Moves every vertex inwards by `distance` along its area-weighted normal (x ← x − e·n).
/// Returns the number of triangles whose orientation flipped (a sign of self-intersection).
std::size_t erode(std::vector<Vec3f>& x, std::span<const Triangle> triangles, float distance);

}  // namespace meniscus
