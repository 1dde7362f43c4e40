// meniscus — cutting the surface by a box (post/clip.hpp).
#include "post/clip.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "common/primitives.hpp"
#include "mesh/compact.hpp"

namespace meniscus {

namespace {

/// One face of the box: the inside is side·(x[axis] − value) ≥ 0.
struct Plane {
  int axis;
  float value;
  double side;
};

/// A vertex on edge (a, b), a < b, at parameter t from a: position, normal and attributes.
uint32_t add_crossing(TriangleMesh& mesh, uint32_t a, uint32_t b, double t, const Plane& plane) {
  Vec3f x;
  for (int c = 0; c < 3; ++c)
    x[c] = float(double(mesh.vertices[a][c]) + t * (double(mesh.vertices[b][c]) - double(mesh.vertices[a][c])));
  x[plane.axis] = plane.value;  // on the plane exactly
  mesh.vertices.push_back(x);
  if (!mesh.normals.empty()) {
    const Vec3f na = mesh.normals[a], nb = mesh.normals[b];
    mesh.normals.push_back(normalized(na + (nb - na) * float(t)));
  }
  for (Attribute& attribute : mesh.attributes) {
    const std::size_t k = std::size_t(attribute.components);
    for (std::size_t c = 0; c < k; ++c) {
      const float va = attribute.values[a * k + c], vb = attribute.values[b * k + c];
      attribute.values.push_back(attribute.integer ? (t < 0.5 ? va : vb) : float(double(va) + t * (double(vb) - double(va))));
    }
  }
  return uint32_t(mesh.vertices.size() - 1);
}

/// Cuts the mesh by one plane (clip_to_box).
void cut(TriangleMesh& mesh, const Plane& plane, ClipOutcome& outcome) {
  const std::size_t nv = mesh.vertices.size();
  std::vector<double> f(nv);
  const bool any_outside = reduce(
      nv, 1 << 14, false,
      [&](std::size_t begin, std::size_t end, bool found) {
        for (std::size_t v = begin; v != end; ++v) {
          f[v] = plane.side * (double(mesh.vertices[v][plane.axis]) - double(plane.value));
          found = found || f[v] < 0;
        }
        return found;
      },
      [](bool a, bool b) { return a || b; });
  if (!any_outside) return;
  std::unordered_map<uint64_t, uint32_t> crossings;  // edge (a < b) → its vertex
  const auto crossing = [&](uint32_t p, uint32_t q) {
    const uint32_t a = std::min(p, q), b = std::max(p, q);
    const auto [it, added] = crossings.try_emplace(uint64_t(a) << 32 | b, 0u);
    if (added) it->second = add_crossing(mesh, a, b, f[a] / (f[a] - f[b]), plane);
    return it->second;
  };
  std::vector<Triangle> kept;
  kept.reserve(mesh.triangles.size());
  for (const Triangle& t : mesh.triangles) {
    int inside = 0, outside = 0;
    for (uint32_t v : t) inside += f[v] > 0, outside += f[v] < 0;
    if (inside == 0) {  // outside, or in the plane: the neighbours' cut closes over it
      ++outcome.removed_triangles;
      continue;
    }
    if (outside == 0) {
      kept.push_back(t);
      continue;
    }
    ++outcome.cut_triangles;
    uint32_t polygon[4];
    int n = 0;
    for (int k = 0; k < 3; ++k) {
      const uint32_t p = t[std::size_t(k)], q = t[std::size_t((k + 1) % 3)];
      if (f[p] >= 0) polygon[n++] = p;
      if ((f[p] > 0 && f[q] < 0) || (f[p] < 0 && f[q] > 0)) polygon[n++] = crossing(p, q);
    }
    kept.push_back({polygon[0], polygon[1], polygon[2]});
    if (n == 4) kept.push_back({polygon[0], polygon[2], polygon[3]});
  }
  mesh.triangles.swap(kept);
}

}  // namespace

ClipOutcome clip_to_box(TriangleMesh& mesh, const ClipBox& box, bool cap) {
  ClipOutcome outcome;
  std::vector<Vec3f> uncut_vertices;
  std::vector<Triangle> uncut_triangles;
  if (cap) uncut_vertices = mesh.vertices, uncut_triangles = mesh.triangles;
  for (int axis = 0; axis < 3; ++axis) {
    cut(mesh, {axis, box[std::size_t(axis)], 1.0}, outcome);
    cut(mesh, {axis, box[std::size_t(axis) + 3], -1.0}, outcome);
  }
  drop_unused_vertices(mesh);
  if (cap) {
    const TriangleBvh inside(uncut_vertices, uncut_triangles);
    cap_box_faces(mesh, box, inside, outcome);
  }
  return outcome;
}

}  // namespace meniscus
