// meniscus — strays (post/strays.hpp): components weighed by the particles they enclose.
#include "post/strays.hpp"

#include <algorithm>
#include <atomic>
#include <vector>

#include "common/for_each.hpp"
#include "grid/hash_grid.hpp"
#include "mesh/components.hpp"
#include "mesh/normals.hpp"

namespace meniscus {

std::size_t remove_components_enclosing_few(TriangleMesh& mesh, std::span<const Vec3f> particles, float reach,
                                            std::size_t min_particles) {
  if (min_particles == 0 || mesh.triangles.empty()) return 0;
  const MeshComponents c = mesh_components(mesh);
  const std::vector<Vec3f> computed =
      mesh.normals.size() == mesh.vertices.size() ? std::vector<Vec3f>{} : vertex_normals(mesh.vertices, mesh.triangles);
  const std::vector<Vec3f>& normals = computed.empty() ? mesh.normals : computed;
  // Each particle belongs to the component of its nearest vertex within `reach` when it lies on
  // that vertex's inner side: the component that encloses it (a particle deep inside a large
  // component has no vertex near and is not counted; the large component has enough near its skin).
  const HashGrid vertices(mesh.vertices, reach);
  std::vector<std::atomic<uint32_t>> enclosed(c.components.size());
  for_each_index(particles.size(), 4096, [&](std::size_t i) {
    const HashGrid::Nearest n = vertices.nearest(particles[i], reach);
    if (n.index == kNotFound) return;
    const uint32_t v = vertices.order()[n.index];
    if (dot(particles[i] - mesh.vertices[v], normals[v]) > 0) return;  // outside its nearest surface
    const uint32_t root = c.root[v];
    const auto k = std::lower_bound(c.components.begin(), c.components.end(), root,
                                    [](const Component& a, uint32_t b) { return a.root < b; });
    if (k != c.components.end() && k->root == root)
      enclosed[std::size_t(k - c.components.begin())].fetch_add(1, std::memory_order_relaxed);
  });
  std::vector<uint32_t> strays;
  for (std::size_t k = 0; k < c.components.size(); ++k)
    if (c.components[k].volume > 0.0 && enclosed[k].load() < min_particles) strays.push_back(c.components[k].root);
  if (!strays.empty()) drop_components(mesh, c, strays);
  return strays.size();
}

}  // namespace meniscus
