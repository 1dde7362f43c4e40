// meniscus — connected components of a triangle mesh.
#include "mesh/components.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <memory>
#include <utility>

#include "common/huge_pages.hpp"

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
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n), [&](const auto& r) {
      for (std::size_t i = r.begin(); i != r.end(); ++i) parent_[i] = uint32_t(i);
    });
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
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, triangles.size(), 4096), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      const Triangle& t = triangles[i];
      // The second union starts from the first's root, not from t[1] again: one walk saved.
      forest.unite(forest.unite(t[0], t[1]), t[2]);
    }
  });
  std::vector<uint32_t> root;
  resize_huge(root, vertex_count);
  // A vertex's parent is never larger than the vertex (roots hook under smaller roots, halving
  // moves a vertex to an ancestor), so going up the range a parent within it already has its root:
  // one read instead of a walk (and of the walk's stores into lines the other threads read).
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, vertex_count), [&](const auto& r) {
    for (std::size_t v = r.begin(); v != r.end(); ++v) {
      const uint32_t p = forest.parent(uint32_t(v));
      root[v] = p == v ? p : p >= r.begin() ? root[p] : forest.find(p);
    }
  });
  return root;
}

}  // namespace meniscus
