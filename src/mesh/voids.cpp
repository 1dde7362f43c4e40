// meniscus — small interior void removal.
#include "mesh/voids.hpp"

#include "mesh/compact.hpp"
#include "mesh/ray_parity_impl.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <memory>
#include <utility>
#include <vector>

namespace meniscus {

namespace {

/// Lock-free union-find over vertex indices (as in ECL-CC, Jaiganesh & Burtscher 2018): a root
/// is hooked under the smaller root by compare-and-swap, finds halve their paths with plain
/// stores (a vertex that is not a root only ever points to an ancestor, so a lost store is
/// harmless). Whatever the interleaving, each component ends with its smallest vertex as root.
class ConcurrentForest {
 public:
  explicit ConcurrentForest(std::size_t n) : parent_(new std::atomic<uint32_t>[n]) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n), [&](const auto& r) {
      for (std::size_t i = r.begin(); i != r.end(); ++i) parent_[i].store(uint32_t(i), std::memory_order_relaxed);
    });
  }
  uint32_t find(uint32_t x) const {
    for (;;) {
      const uint32_t p = parent_[x].load(std::memory_order_relaxed);
      if (p == x) return x;
      const uint32_t g = parent_[p].load(std::memory_order_relaxed);
      if (g == p) return p;
      parent_[x].store(g, std::memory_order_relaxed);
      x = g;
    }
  }
  void unite(uint32_t a, uint32_t b) {
    for (;;) {
      a = find(a);
      b = find(b);
      if (a == b) return;
      if (a < b) std::swap(a, b);
      uint32_t expected = a;
      if (parent_[a].compare_exchange_strong(expected, b, std::memory_order_relaxed)) return;
    }
  }

 private:
  std::unique_ptr<std::atomic<uint32_t>[]> parent_;
};

/// Connected components by shared vertices: each vertex's root (the component's smallest
/// vertex), and per root the signed enclosed volume and whether any triangle belongs to it.
struct MeshComponents {
  std::vector<uint32_t> root;
  std::vector<double> volume;
  std::vector<uint8_t> has_triangles;
};

MeshComponents mesh_components(const TriangleMesh& mesh) {
  const std::size_t nv = mesh.vertices.size();
  const std::size_t nt = mesh.triangles.size();
  // Components over vertices: triangles of a watertight mesh that share a vertex share an
  // edge, except at non-manifold vertices, which the extraction does not produce.
  ConcurrentForest forest(nv);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nt, 4096), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      const Triangle& t = mesh.triangles[i];
      forest.unite(t[0], t[1]);
      forest.unite(t[1], t[2]);
    }
  });
  MeshComponents c;
  c.root.resize(nv);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv), [&](const auto& r) {
    for (std::size_t v = r.begin(); v != r.end(); ++v) c.root[v] = forest.find(uint32_t(v));
  });

  // Signed volume per component. Fixed chunks of triangles (in the extraction's spatial order, so
  // a chunk holds long runs of one component) sum runs locally; the runs are added up in chunk
  // order, so the sums do not depend on the thread count.
  constexpr std::size_t kChunk = std::size_t(1) << 16;
  const std::size_t chunks = (nt + kChunk - 1) / kChunk;
  std::vector<std::vector<std::pair<uint32_t, double>>> runs(chunks);
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t k) {
    auto& out = runs[k];
    for (std::size_t i = k * kChunk, end = std::min(nt, i + kChunk); i < end; ++i) {
      const Triangle& t = mesh.triangles[i];
      const Vec3f a = mesh.vertices[t[0]], b = mesh.vertices[t[1]], cc = mesh.vertices[t[2]];
      const double v = (double(a.x) * (double(b.y) * cc.z - double(b.z) * cc.y) -
                        double(a.y) * (double(b.x) * cc.z - double(b.z) * cc.x) +
                        double(a.z) * (double(b.x) * cc.y - double(b.y) * cc.x)) / 6.0;
      const uint32_t r = c.root[t[0]];
      if (out.empty() || out.back().first != r)
        out.emplace_back(r, v);
      else
        out.back().second += v;
    }
  });
  c.volume.assign(nv, 0.0);
  c.has_triangles.assign(nv, 0);
  for (const auto& chunk : runs)
    for (const auto& [r, v] : chunk) {
      c.volume[r] += v;
      c.has_triangles[r] = 1;
    }
  return c;
}

/// Removes the triangles of the components whose root has drop[root] set, then the vertices no
/// triangle uses (order otherwise preserved; normals and attributes follow if present).
void drop_components(TriangleMesh& mesh, const std::vector<uint32_t>& root, const std::vector<uint8_t>& drop) {
  keep_triangles(mesh, [&](const Triangle& t) { return !drop[root[t[0]]]; });
}

}  // namespace

std::size_t remove_small_voids(TriangleMesh& mesh, double max_volume) {
  const std::size_t nv = mesh.vertices.size();
  const MeshComponents c = mesh_components(mesh);
  std::vector<uint8_t> drop(nv, 0);
  std::size_t removed = 0;
  for (uint32_t v = 0; v < nv; ++v)
    if (c.root[v] == v && c.has_triangles[v] && c.volume[v] <= 0.0 && c.volume[v] > -max_volume) {
      drop[v] = 1;
      ++removed;
    }
  if (removed > 0) drop_components(mesh, c.root, drop);
  return removed;
}

std::size_t remove_unsupported_blobs(TriangleMesh& mesh, const HashGrid& particles, double max_volume,
                                     double min_volume) {
  const std::size_t nv = mesh.vertices.size();
  const MeshComponents c = mesh_components(mesh);
  // The small outward components, and their triangles bucketed by component.
  std::vector<uint32_t> candidate_of(nv, kNotFound);
  std::vector<uint32_t> roots;
  for (uint32_t v = 0; v < nv; ++v)
    if (c.root[v] == v && c.has_triangles[v] && c.volume[v] > 0.0 && c.volume[v] <= max_volume) {
      candidate_of[v] = uint32_t(roots.size());
      roots.push_back(v);
    }
  if (roots.empty()) return 0;
  std::vector<uint32_t> start(roots.size() + 1, 0);
  for (const Triangle& t : mesh.triangles)
    if (const uint32_t k = candidate_of[c.root[t[0]]]; k != kNotFound) ++start[k + 1];
  for (std::size_t k = 0; k < roots.size(); ++k) start[k + 1] += start[k];
  std::vector<uint32_t> triangles(start.back());
  {
    std::vector<uint32_t> fill(start.begin(), start.end() - 1);
    for (uint32_t f = 0; f < mesh.triangles.size(); ++f)
      if (const uint32_t k = candidate_of[c.root[mesh.triangles[f][0]]]; k != kNotFound) triangles[fill[k]++] = f;
  }

  std::vector<uint8_t> empty(roots.size(), 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, roots.size(), 16), [&](const auto& r) {
    for (std::size_t k = r.begin(); k != r.end(); ++k)
      empty[k] = c.volume[roots[k]] <= min_volume ||
                 !encloses_a_point(particles, mesh.triangles.data()->data(), triangles.data() + start[k],
                                   start[k + 1] - start[k], mesh.vertices.data());
  });
  std::vector<uint8_t> drop(nv, 0);
  std::size_t removed = 0;
  for (std::size_t k = 0; k < roots.size(); ++k)
    if (empty[k]) {
      drop[roots[k]] = 1;
      ++removed;
    }
  if (removed > 0) drop_components(mesh, c.root, drop);
  return removed;
}

}  // namespace meniscus
