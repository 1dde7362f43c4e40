// meniscus — small interior void removal.
#include "mesh/voids.hpp"

#include "common/for_each.hpp"
#include "mesh/components.hpp"
#include "mesh/ray_parity_impl.hpp"

#include <algorithm>
#include <span>
#include <vector>

namespace meniscus {

std::size_t remove_small_voids(TriangleMesh& mesh, double max_volume) {
  const MeshComponents c = mesh_components(mesh);
  std::vector<uint32_t> voids;
  for (const Component& k : c.components)
    if (k.volume <= 0.0 && k.volume > -max_volume) voids.push_back(k.root);
  if (!voids.empty()) drop_components(mesh, c, voids);
  return voids.size();
}

std::size_t remove_unsupported_blobs(TriangleMesh& mesh, const HashGrid& particles, double max_volume,
                                     double min_volume) {
  const MeshComponents c = mesh_components(mesh);
  // The small outward components, and their triangles (from their runs).
  std::vector<const Component*> candidates;
  std::vector<uint32_t> roots;
  for (const Component& k : c.components)
    if (k.volume > 0.0 && k.volume <= max_volume) {
      candidates.push_back(&k);
      roots.push_back(k.root);
    }
  if (candidates.empty()) return 0;
  const ComponentTriangles own = triangles_of(c, roots);
  const std::vector<uint32_t>& start = own.start;
  const std::vector<uint32_t>& triangles = own.triangles;

  std::vector<uint8_t> empty(candidates.size(), 0);
  for_each_chunk(candidates.size(), 16, [&](std::size_t begin, std::size_t end) {
    for (std::size_t k = begin; k != end; ++k)
      empty[k] = candidates[k]->volume <= min_volume ||
                 !encloses_a_point(particles, mesh.triangles.data()->data(), triangles.data() + start[k],
                                   start[k + 1] - start[k], mesh.vertices.data());
  });
  std::vector<uint32_t> blobs;
  for (std::size_t k = 0; k < candidates.size(); ++k)
    if (empty[k]) blobs.push_back(candidates[k]->root);
  if (!blobs.empty()) drop_components(mesh, c, blobs);
  return blobs.size();
}

}  // namespace meniscus
