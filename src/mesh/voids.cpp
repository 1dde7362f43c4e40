// meniscus — small interior void removal.
#include "mesh/voids.hpp"

#include <numeric>
#include <vector>

namespace meniscus {

namespace {
uint32_t find_root(std::vector<uint32_t>& parent, uint32_t x) {
  while (parent[x] != x) x = parent[x] = parent[parent[x]];
  return x;
}
}  // namespace

std::size_t remove_small_voids(TriangleMesh& mesh, double max_volume) {
  const std::size_t nv = mesh.vertices.size();
  // Components over vertices: triangles of a watertight mesh that share a vertex share an
  // edge, except at non-manifold vertices, which the extraction does not produce.
  std::vector<uint32_t> parent(nv);
  std::iota(parent.begin(), parent.end(), 0u);
  for (const Triangle& t : mesh.triangles) {
    const uint32_t a = find_root(parent, t[0]);
    const uint32_t b = find_root(parent, t[1]);
    if (a != b) parent[a] = b;
    const uint32_t c = find_root(parent, t[1]), d = find_root(parent, t[2]);
    if (c != d) parent[c] = d;
  }
  std::vector<double> volume(nv, 0.0);
  std::vector<uint8_t> has_triangles(nv, 0);
  for (const Triangle& t : mesh.triangles) {
    const Vec3f a = mesh.vertices[t[0]], b = mesh.vertices[t[1]], c = mesh.vertices[t[2]];
    const uint32_t r = find_root(parent, t[0]);
    volume[r] += (double(a.x) * (double(b.y) * c.z - double(b.z) * c.y) - double(a.y) * (double(b.x) * c.z - double(b.z) * c.x) +
                  double(a.z) * (double(b.x) * c.y - double(b.y) * c.x)) / 6.0;
    has_triangles[r] = 1;
  }
  std::vector<uint8_t> drop(nv, 0);
  std::size_t removed = 0;
  for (uint32_t v = 0; v < nv; ++v)
    if (parent[v] == v && has_triangles[v] && volume[v] <= 0.0 && volume[v] > -max_volume) {
      drop[v] = 1;
      ++removed;
    }
  if (removed == 0) return 0;

  std::vector<Triangle> kept;
  kept.reserve(mesh.triangles.size());
  for (const Triangle& t : mesh.triangles)
    if (!drop[find_root(parent, t[0])]) kept.push_back(t);
  mesh.triangles = std::move(kept);

  // Compact the vertices (the attributes and normals are not filled yet at this stage, but
  // keep them consistent if they are).
  std::vector<uint32_t> remap(nv, ~0u);
  for (const Triangle& t : mesh.triangles)
    for (uint32_t v : t) remap[v] = 0;
  uint32_t next = 0;
  for (uint32_t v = 0; v < nv; ++v)
    if (remap[v] == 0) remap[v] = next++;
  auto compact = [&](auto& values, std::size_t per_vertex) {
    if (values.empty()) return;
    for (uint32_t v = 0; v < nv; ++v)
      if (remap[v] != ~0u)
        for (std::size_t k = 0; k < per_vertex; ++k) values[remap[v] * per_vertex + k] = values[v * per_vertex + k];
    values.resize(std::size_t(next) * per_vertex);
  };
  compact(mesh.vertices, 1);
  compact(mesh.normals, 1);
  for (Attribute& a : mesh.attributes) compact(a.values, std::size_t(a.components));
  for (Triangle& t : mesh.triangles)
    for (uint32_t& v : t) v = remap[v];
  return removed;
}

}  // namespace meniscus
