// meniscus — connected components of a triangle mesh.
#include "mesh/components.hpp"

#include <algorithm>
#include <atomic>
#include <memory>
#include <utility>

#include "common/for_each.hpp"
#include "common/huge_pages.hpp"
#include "common/prefetch.hpp"
#include "mesh/compact.hpp"
#include "mesh/volume_impl.hpp"

namespace meniscus {

namespace {

/// Lock-free union-find over vertex indices (as in ECL-CC, Jaiganesh & Burtscher 2018): a root
/// is hooked under the smaller root by compare-and-swap, finds halve their paths with plain
/// stores (a vertex that is not a root only ever points to an ancestor, so a lost store is
/// harmless). Whatever the interleaving, each component ends with its smallest vertex as root.
/// Plain words behind atomic_ref: `new std::atomic<uint32_t>[n]` would zero them first (C++20),
/// touching every page before the huge-page advice could apply.
class ConcurrentForest {
 public:
  explicit ConcurrentForest(std::size_t n) : parent_(std::make_unique_for_overwrite<uint32_t[]>(n)) {
    advise_huge_pages(parent_.get(), n * sizeof(uint32_t));
    for_each_index(n, [&](std::size_t i) { parent_[i] = uint32_t(i); });
  }
  uint32_t find(uint32_t x) const {
    for (;;) {
      const uint32_t p = at(x).load(std::memory_order_relaxed);
      if (p == x) return x;
      const uint32_t g = at(p).load(std::memory_order_relaxed);
      if (g == p) return p;
      at(x).store(g, std::memory_order_relaxed);
      x = g;
    }
  }
  /// x's parent: x itself for a root, otherwise an ancestor, always ≤ x.
  uint32_t parent(uint32_t x) const { return at(x).load(std::memory_order_relaxed); }
  /// Joins the sets of a and b; returns the root the joined set had (a later union may have hooked
  /// it since: it is then an ancestor of both, which is all unite needs from it).
  uint32_t unite(uint32_t a, uint32_t b) {
    for (;;) {
      a = find(a);
      b = find(b);
      if (a == b) return a;
      if (a < b) std::swap(a, b);
      uint32_t expected = a;
      if (at(a).compare_exchange_strong(expected, b, std::memory_order_relaxed)) return b;
    }
  }

 private:
  std::atomic_ref<uint32_t> at(uint32_t i) const { return std::atomic_ref<uint32_t>(parent_[i]); }
  std::unique_ptr<uint32_t[]> parent_;
};

}  // namespace

std::vector<uint32_t> component_roots(std::size_t vertex_count, std::span<const Triangle> triangles) {
  // Triangles of a watertight mesh that share a vertex share an edge, except at non-manifold
  // vertices, which the extraction does not produce: components by vertices are by edges.
  ConcurrentForest forest(vertex_count);
  for_each_index(triangles.size(), 4096, [&](std::size_t i) {
    const Triangle& t = triangles[i];
    // The second union starts from the first's root, not from t[1] again: one walk saved.
    forest.unite(forest.unite(t[0], t[1]), t[2]);
  });
  std::vector<uint32_t> root;
  resize_huge(root, vertex_count);
  // A vertex's parent is never larger than the vertex (roots hook under smaller roots, halving
  // moves a vertex to an ancestor), so going up the range a parent within it already has its root:
  // one read instead of a walk (and of the walk's stores into lines the other threads read).
  for_each_chunk(vertex_count, 1, [&](std::size_t begin, std::size_t end) {
    for (std::size_t v = begin; v != end; ++v) {
      const uint32_t p = forest.parent(uint32_t(v));
      root[v] = p == v ? p : p >= begin ? root[p] : forest.find(p);
    }
  });
  return root;
}

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
  for_each_index(chunks, [&](std::size_t k) {
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

}  // namespace meniscus
