// meniscus — small interior void removal.
#include "mesh/voids.hpp"

#include "mesh/volume_impl.hpp"

#include "common/prefetch.hpp"
#include "mesh/compact.hpp"
#include "mesh/components.hpp"
#include "mesh/ray_parity_impl.hpp"
#include "mesh/normals.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <span>
#include <vector>

namespace meniscus {

namespace {

/// A connected component that has triangles: its root (smallest vertex) and signed enclosed volume.
struct Component {
  uint32_t root;
  double volume;
};

/// A run of consecutive triangles of one component: [first, end) and their volume.
struct Run {
  uint32_t root, first, end;
  double volume;
};

/// Connected components by shared vertices: each vertex's root, the components with triangles in
/// root order (a list, not a per-vertex array: a splash frame has millions of vertices and a few
/// thousand components), and the runs of triangles of each component, by root and then in
/// triangle order (a component's triangles, for dropping it without reading the others).
struct MeshComponents {
  std::vector<uint32_t> root;
  std::vector<Component> components;
  std::vector<Run> runs;
};

MeshComponents mesh_components(const TriangleMesh& mesh) {
  const std::size_t nv = mesh.vertices.size();
  const std::size_t nt = mesh.triangles.size();
  MeshComponents c;
  c.root = component_roots(nv, mesh.triangles);

  // Signed volume per component. Fixed chunks of triangles (in the extraction's spatial order, so
  // a chunk holds long runs of one component) sum runs locally; the runs, in chunk order, are
  // stably sorted by root and added up, so each sum takes its terms in triangle order and does
  // not depend on the thread count.
  constexpr std::size_t kChunk = std::size_t(1) << 16;
  constexpr std::size_t kAhead = 64;  // as in vertex_normals: the corners of a triangle ahead,
  // and the triangles themselves 2 KB ahead (common/prefetch.hpp)
  const std::size_t chunks = (nt + kChunk - 1) / kChunk;
  std::vector<std::vector<Run>> runs(chunks);
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t k) {
    auto& out = runs[k];
    for (std::size_t i = k * kChunk, end = std::min(nt, i + kChunk); i < end; ++i) {
      prefetch_stream(mesh.triangles.data(), i, end);
      if (i + kAhead < end) {
        const Triangle& ahead = mesh.triangles[i + kAhead];
        for (const uint32_t v : ahead) __builtin_prefetch(&mesh.vertices[v]);
        __builtin_prefetch(&c.root[ahead[0]]);
      }
      const Triangle& t = mesh.triangles[i];
      const Vec3f a = mesh.vertices[t[0]], b = mesh.vertices[t[1]], cc = mesh.vertices[t[2]];
      const double v = signed_volume6(a, b, cc) / 6.0;
      const uint32_t r = c.root[t[0]];
      if (out.empty() || out.back().root != r) {
        out.push_back({r, uint32_t(i), uint32_t(i + 1), v});
      } else {
        out.back().end = uint32_t(i + 1);
        out.back().volume += v;
      }
    }
  });
  for (const auto& chunk : runs) c.runs.insert(c.runs.end(), chunk.begin(), chunk.end());
  std::vector<std::vector<Run>>().swap(runs);
  std::stable_sort(c.runs.begin(), c.runs.end(), [](const Run& a, const Run& b) { return a.root < b.root; });
  for (const Run& run : c.runs)
    if (c.components.empty() || c.components.back().root != run.root)
      c.components.push_back({run.root, 0.0 + run.volume});  // from 0.0, as the per-vertex sums were
    else
      c.components.back().volume += run.volume;
  return c;
}

/// The triangles of the components whose roots `roots` lists (in root order), from their runs:
/// component k's, in triangle order, are triangles[start[k], start[k + 1]).
struct ComponentTriangles {
  std::vector<uint32_t> start{0};
  std::vector<uint32_t> triangles;
};

ComponentTriangles triangles_of(const MeshComponents& c, std::span<const uint32_t> roots) {
  ComponentTriangles out;
  auto run = c.runs.begin();
  for (const uint32_t r : roots) {
    run = std::lower_bound(run, c.runs.end(), r, [](const Run& a, uint32_t root) { return a.root < root; });
    for (; run != c.runs.end() && run->root == r; ++run)
      for (uint32_t t = run->first; t < run->end; ++t) out.triangles.push_back(t);
    out.start.push_back(uint32_t(out.triangles.size()));
  }
  return out;
}

/// Removes the components whose roots `roots` lists (in root order) with their triangles and
/// vertices (order otherwise preserved; normals and attributes follow if present): the triangles
/// from the components' runs, the vertices as their corners, and one pass over what is kept
/// (drop_sorted) instead of flags over the whole mesh (keep_triangles): the removed components are
/// few and small next to the mesh.
void drop_components(TriangleMesh& mesh, const MeshComponents& c, const std::vector<uint32_t>& roots) {
  std::vector<uint32_t> triangles = triangles_of(c, roots).triangles;
  std::sort(triangles.begin(), triangles.end());
  std::vector<uint32_t> vertices;
  vertices.reserve(3 * triangles.size());
  for (const uint32_t t : triangles)
    for (const uint32_t v : mesh.triangles[t]) vertices.push_back(v);
  std::sort(vertices.begin(), vertices.end());
  vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
  drop_sorted(mesh, triangles, vertices);
}

}  // namespace

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
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, candidates.size(), 16), [&](const auto& r) {
    for (std::size_t k = r.begin(); k != r.end(); ++k)
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
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, particles.size(), 4096), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      const HashGrid::Nearest n = vertices.nearest(particles[i], reach);
      if (n.index == kNotFound) continue;
      const uint32_t v = vertices.order()[n.index];
      if (dot(particles[i] - mesh.vertices[v], normals[v]) > 0) continue;  // outside its nearest surface
      const uint32_t root = c.root[v];
      const auto k = std::lower_bound(c.components.begin(), c.components.end(), root,
                                      [](const Component& a, uint32_t b) { return a.root < b; });
      if (k != c.components.end() && k->root == root) enclosed[std::size_t(k - c.components.begin())].fetch_add(1, std::memory_order_relaxed);
    }
  });
  std::vector<uint32_t> strays;
  for (std::size_t k = 0; k < c.components.size(); ++k)
    if (c.components[k].volume > 0.0 && enclosed[k].load() < min_particles) strays.push_back(c.components[k].root);
  if (!strays.empty()) drop_components(mesh, c, strays);
  return strays.size();
}

}  // namespace meniscus
