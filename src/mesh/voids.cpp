// meniscus — small interior void removal.
#include "mesh/voids.hpp"

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

}  // namespace

std::size_t remove_small_voids(TriangleMesh& mesh, double max_volume) {
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
  std::vector<uint32_t> root(nv);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv), [&](const auto& r) {
    for (std::size_t v = r.begin(); v != r.end(); ++v) root[v] = forest.find(uint32_t(v));
  });

  // Signed volume per component. Fixed chunks of triangles (in the extraction's spatial order, so
  // a chunk holds long runs of one component) sum runs locally; the runs are added up in chunk
  // order, so the sums do not depend on the thread count.
  constexpr std::size_t kChunk = std::size_t(1) << 16;
  const std::size_t chunks = (nt + kChunk - 1) / kChunk;
  std::vector<std::vector<std::pair<uint32_t, double>>> runs(chunks);
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
    auto& out = runs[c];
    for (std::size_t i = c * kChunk, end = std::min(nt, i + kChunk); i < end; ++i) {
      const Triangle& t = mesh.triangles[i];
      const Vec3f a = mesh.vertices[t[0]], b = mesh.vertices[t[1]], cc = mesh.vertices[t[2]];
      const double v = (double(a.x) * (double(b.y) * cc.z - double(b.z) * cc.y) -
                        double(a.y) * (double(b.x) * cc.z - double(b.z) * cc.x) +
                        double(a.z) * (double(b.x) * cc.y - double(b.y) * cc.x)) / 6.0;
      const uint32_t r = root[t[0]];
      if (out.empty() || out.back().first != r)
        out.emplace_back(r, v);
      else
        out.back().second += v;
    }
  });
  std::vector<double> volume(nv, 0.0);
  std::vector<uint8_t> has_triangles(nv, 0);
  for (const auto& chunk : runs)
    for (const auto& [r, v] : chunk) {
      volume[r] += v;
      has_triangles[r] = 1;
    }
  runs = {};
  std::vector<uint8_t> drop(nv, 0);
  std::size_t removed = 0;
  for (uint32_t v = 0; v < nv; ++v)
    if (root[v] == v && has_triangles[v] && volume[v] <= 0.0 && volume[v] > -max_volume) {
      drop[v] = 1;
      ++removed;
    }
  if (removed == 0) return 0;

  std::vector<Triangle> kept;
  kept.reserve(mesh.triangles.size());
  for (const Triangle& t : mesh.triangles)
    if (!drop[root[t[0]]]) kept.push_back(t);
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
