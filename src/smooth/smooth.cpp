// meniscus — constrained smoothing schedule (Williams 2008 §4; Edespong 2010 §3.5).
#include "smooth/smooth.hpp"

#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <limits>
#include <optional>

#include "common/huge_pages.hpp"
#include "common/parallel_index.hpp"
#include "memory_scope.hpp"
#include "mesh/compact.hpp"
#include "mesh/components.hpp"
#include "mesh/packed_triangles.hpp"
#include "smooth/adjacency.hpp"
#include "smooth/operators.hpp"
#include "smooth/sweep_undo.hpp"

namespace meniscus {

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

template <class F>
void for_each_vertex(std::size_t n, F&& f) {
  parallel_for_index(n, 1024, [&](std::size_t i) { f(uint32_t(i)); });
}

/// The sweeps' vertices in chunks of this many consecutive indices: SweepLayout sorts each chunk
/// by class, and a sweep loads a chunk's ring data before it works there.
inline constexpr std::size_t kSweepChunk = 4096;

/// Hints the cache to load data[begin .. end).
template <class T>
void prefetch_range(const T* data, std::size_t begin, std::size_t end) {
  const char* p = reinterpret_cast<const char*>(data + begin);
  const char* const e = reinterpret_cast<const char*>(data + end);
  for (; p < e; p += 64) __builtin_prefetch(p);
}

/// Colour classes as runs of consecutive vertices: class c is runs[offsets[c] .. offsets[c+1]),
/// each run the vertices [first, second).
struct ClassRuns {
  std::vector<uint32_t> offsets;
  std::vector<std::pair<uint32_t, uint32_t>> runs;
  std::size_t colors() const { return offsets.empty() ? 0 : offsets.size() - 1; }
};

/// Runs f on every vertex, one colour class after another, in parallel within a class; calls
/// prefetch a few vertices ahead, and prefetch_chunk(q) for the chunk q a run enters and the one
/// after it. A class's vertices are a small part of each chunk, but their rings cover it: the data
/// the rings read (positions, W x) would otherwise come in line by line at random within the
/// chunk, a miss each — and the whole mesh streams through the cache between two classes, so it
/// does so for every class. Prefetching the chunk (and the next, which the thread reaches while
/// it loads) streams it in instead: 6–8 % off the splash 300k smoothing.
template <class F, class P, class PC>
void for_each_in_colors(const ClassRuns& classes, F&& f, P&& prefetch, PC&& prefetch_chunk) {
  constexpr uint32_t kAhead = 8;
  for (std::size_t c = 0; c < classes.colors(); ++c) {
    tbb::parallel_for(tbb::blocked_range<uint32_t>(classes.offsets[c], classes.offsets[c + 1]), [&](const auto& r) {
      std::size_t chunk = SIZE_MAX;
      for (uint32_t k = r.begin(); k != r.end(); ++k) {
        const auto [b, e] = classes.runs[k];
        if (b / kSweepChunk != chunk) {
          chunk = b / kSweepChunk;
          prefetch_chunk(chunk);
          prefetch_chunk(chunk + 1);
        }
        for (uint32_t i = b; i != e; ++i) {
          if (i + kAhead < e) prefetch(i + kAhead);
          f(i);
        }
      }
    });
  }
}

template <class Neighbors>
Vec3f neighbour_mean(const Adjacency& adj, const Neighbors& neighbors, std::span<const Vec3f> x, uint32_t i) {
  return neighbour_mean_row(adj.offsets.data(), neighbors, x.data(), i);
}

/// Hints the cache to load entry e of the neighbour lists.
inline void prefetch_entry(const uint32_t* neighbors, uint32_t e) { __builtin_prefetch(neighbors + e); }
inline void prefetch_entry(const CompactNeighbors& neighbors, uint32_t e) { __builtin_prefetch(neighbors.delta + e); }

double energy_of(const Adjacency& adj, const CotanOperator& op, std::span<const Vec3f> x, std::vector<Vec3f>& scratch,
                 std::span<const uint32_t> rank) {
  resize_huge(scratch, x.size());
  apply_w(adj, op, x, scratch);
  return bilaplacian_energy(op, scratch, rank);
}

/// The Gauss-Seidel sweeps' classes and vertex numbering. The greedy colourings of the mesh's own
/// (Z-order) numbering fix which vertices are updated together — the CUDA backend's classes. The
/// sweeps then run on the vertices renumbered by (chunk of kSweepChunk original indices, B colour,
/// A colour, original index): a class is a run of consecutive vertices in every chunk, so a sweep
/// streams the per-vertex arrays of the vertices it updates (operator rows, particle lists, slack)
/// where a class scattered over the whole range read a cache line of each array per vertex; and a
/// chunk is still a patch of the surface, so the rings it reads stay in cache from one class to
/// the next. The result is bit-identical: updates within a class are independent, the rows keep
/// their entries in the original order (renumber_adjacency) and the sums over all vertices run in
/// the original numbering (`rank`). On splash 300k the sweeps took about a tenth less.
struct SweepLayout {
  std::vector<uint32_t> order;  ///< new index → original index (empty: not renumbered; handed to the adjacency as tri_row)
  std::vector<uint32_t> rank;   ///< original index → new index (empty: not renumbered)
  ClassRuns a, b;               ///< the A (distance 1) and B (distance 2) classes, new numbering
};

/// The classes of `adj`, renumbered (or, with `renumber` false, in its own numbering: runs of one
/// vertex mostly — for the tests that the renumbering changes nothing).
SweepLayout sweep_layout(const Adjacency& adj, bool renumber) {
  const std::size_t nv = adj.vertex_count();
  // The two colourings are serial (the greedy order is the CUDA backend's): side by side.
  std::vector<uint16_t> ca, cb;
  tbb::parallel_invoke([&] { ca = greedy_colors(adj, 1); }, [&] { cb = greedy_colors(adj, 2); });
  const std::size_t na = nv == 0 ? 1 : std::size_t(*std::max_element(ca.begin(), ca.end())) + 1;
  const std::size_t nb = nv == 0 ? 1 : std::size_t(*std::max_element(cb.begin(), cb.end())) + 1;
  SweepLayout layout;
  if (renumber) {
    // Each chunk sorted by (B colour, A colour, original index), in parallel: a counting sort on
    // the colour pair, which keeps the index order within a pair (a comparison sort of the
    // indices, reading both colours at every comparison, took 0.7 s of the set-up on splash 1M).
    resize_huge(layout.order, nv);
    resize_huge(layout.rank, nv);
    tbb::parallel_for(std::size_t(0), (nv + kSweepChunk - 1) / kSweepChunk, [&](std::size_t q) {
      const uint32_t b = uint32_t(q * kSweepChunk), e = uint32_t(std::min(nv, (q + 1) * kSweepChunk));
      std::vector<uint32_t> start(na * nb + 1, 0);
      for (uint32_t i = b; i < e; ++i) ++start[std::size_t(cb[i]) * na + ca[i] + 1];
      for (std::size_t k = 1; k < start.size(); ++k) start[k] += start[k - 1];
      for (uint32_t i = b; i < e; ++i) {
        const uint32_t n = b + start[std::size_t(cb[i]) * na + ca[i]]++;
        layout.order[n] = i;
        layout.rank[i] = n;
      }
    });
  }
  auto original = [&](uint32_t n) { return renumber ? layout.order[n] : n; };
  // The runs: maximal ranges of one (chunk, colour), listed by colour, chunks in order.
  auto runs_of = [&](const std::vector<uint16_t>& color, std::size_t colors) {
    std::vector<std::vector<std::pair<uint32_t, uint32_t>>> by_color(colors);
    for (uint32_t n = 0; n < nv;) {
      const uint32_t i = original(n);
      const std::size_t chunk = i / kSweepChunk;
      const uint16_t c = color[i];
      uint32_t e = n + 1;
      while (e < nv && color[original(e)] == c && original(e) / kSweepChunk == chunk) ++e;
      by_color[c].emplace_back(n, e);
      n = e;
    }
    ClassRuns out;
    out.offsets.assign(colors + 1, 0);
    for (std::size_t c = 0; c < colors; ++c) {
      out.offsets[c + 1] = out.offsets[c] + uint32_t(by_color[c].size());
      out.runs.insert(out.runs.end(), by_color[c].begin(), by_color[c].end());
    }
    return out;
  };
  layout.a = runs_of(ca, na);
  layout.b = runs_of(cb, nb);
  return layout;
}

/// Renumbers the mesh (positions, and the triangle corners unless `triangles` is empty) by `rank`
/// (old index → new) for the lifetime of the object, and back when it ends (also when the sweeps
/// throw). Each direction allocates before it changes anything, so a failed allocation leaves the
/// mesh as it was; the way back runs after the sweeps' arrays are freed (on return or unwinding),
/// so its 16 bytes a vertex are there to take.
class Renumbered {
 public:
  Renumbered(std::vector<Vec3f>& x, std::span<Triangle> triangles, std::span<const uint32_t> rank)
      : x_(x), triangles_(triangles), rank_(rank) {
    std::vector<Vec3f> y = positions();
    relabel(rank);
    parallel_for_index(x_.size(), 4096, [&](std::size_t i) { y[rank_[i]] = x_[i]; });
    x_.swap(y);
  }
  ~Renumbered() {
    std::vector<Vec3f> y = positions();
    std::vector<uint32_t> order(rank_.size());
    parallel_for_index(rank_.size(), 4096, [&](std::size_t i) { order[rank_[i]] = uint32_t(i); });
    relabel(order);
    parallel_for_index(x_.size(), 4096, [&](std::size_t i) { y[i] = x_[rank_[i]]; });
    x_.swap(y);
  }
  Renumbered(const Renumbered&) = delete;
  Renumbered& operator=(const Renumbered&) = delete;

 private:
  void relabel(std::span<const uint32_t> to) {
    parallel_for_index(triangles_.size(), 4096, [&](std::size_t k) {
      for (uint32_t& v : triangles_[k]) v = to[v];
    });
  }
  /// Storage for the permuted positions (read at random by the sweeps: on huge pages).
  std::vector<Vec3f> positions() const {
    std::vector<Vec3f> y;
    resize_huge(y, x_.size());
    return y;
  }
  std::vector<Vec3f>& x_;
  std::span<Triangle> triangles_;
  std::span<const uint32_t> rank_;
};

/// The schedule; `project(i, from)` projects vertex i in place (when `constrained_any`), `from` being
/// where the vertex was before the move (where its previous projection left it); `forget()` is
/// called when the energy guard puts the vertices back where they were before a sweep. `adj` is the
/// triangles' (its triangle or corner lists are freed once the operator is built); `triangles` may
/// be empty when it has corner lists. Gauss-Seidel when
/// `layout` is given (the classes, in the numbering of x and triangles), Jacobi otherwise.
/// `neighbors`: adj's neighbour lists as Adjacency::with_neighbors gives them.
template <class Neighbors, class Project, class PrefetchConstraint, class Forget>
SmoothReport smooth_with(std::vector<Vec3f>& x, std::span<const Triangle> triangles, Adjacency& adj,
                         const Neighbors& neighbors, const SweepLayout* layout,
                         bool constrained_any, Project&& project_constraint,
                         PrefetchConstraint&& prefetch_constraint, Forget&& forget,
                         const SmoothOptions& o, const std::function<void(double)>& progress) {
  SmoothReport report;
  const std::size_t nv = x.size();
  if (nv == 0 || o.steps_a + o.steps_b + o.steps_free == 0) return report;  // no sweep: no set-up either
  const bool weighted = o.vertex_relax.size() == nv;
  auto vertex_factor = [&](uint32_t i) { return weighted ? o.vertex_relax[i] : 1.0f; };
  const bool gauss_seidel = layout != nullptr;
  // The sums over all vertices (energy, mean area) run in the original numbering.
  const std::span<const uint32_t> rank = gauss_seidel ? std::span<const uint32_t>(layout->rank) : std::span<const uint32_t>();
  const int total = o.steps_a + o.steps_b + o.steps_free;
  int done = 0;
  auto tick = [&] {
    ++done;
    if (progress && total > 0) progress(double(done) / total);
  };
  auto project = [&](uint32_t i, Vec3f from) {
    if (constrained_any) project_constraint(i, from);
  };
  auto prefetch = [&](uint32_t i) {
    if (constrained_any) prefetch_constraint(i);
    __builtin_prefetch(&x[i]);
  };
  // The vertex range of chunk q (empty past the last).
  auto chunk_range = [&](std::size_t q) {
    return std::pair(std::min(nv, q * kSweepChunk), std::min(nv, (q + 1) * kSweepChunk));
  };

  // Read at random by every sweep, as all the smoothing's per-vertex arrays: on huge pages.
  std::vector<Vec3f> next, scratch;  // next: the Jacobi iterate only
  if (!gauss_seidel) resize_huge(next, nv);

  // --- A: constrained graph-Laplacian sweeps ---------------------------------------------------
  const auto a_start = std::chrono::steady_clock::now();
  if (o.steps_a > 0) {
    const float w = o.relax_a;
    if (gauss_seidel) {
      for (int s = 0; s < o.steps_a; ++s, tick()) {
        for_each_in_colors(layout->a, [&](uint32_t i) {
          const Vec3f from = x[i];
          x[i] = from + (neighbour_mean(adj, neighbors, x, i) - from) * (w * vertex_factor(i));
          project(i, from);
        }, prefetch, [&](std::size_t q) {
          const auto [b, e] = chunk_range(q);
          prefetch_range(x.data(), b, e);
        });
      }
    } else {
      for (int s = 0; s < o.steps_a; ++s, tick()) {
        for_each_vertex(nv, [&](uint32_t i) { next[i] = x[i] + (neighbour_mean(adj, neighbors, x, i) - x[i]) * (w * vertex_factor(i)); });
        x.swap(next);  // next: where the vertices were
        for_each_vertex(nv, [&](uint32_t i) { project(i, next[i]); });
      }
    }
  }

  if (o.steps_a > 0) report.a_sweeps_seconds = seconds_since(a_start);

  // --- B: bilaplacian sweeps, constrained then free -------------------------------------------
  const int steps_b = o.steps_b + o.steps_free;
  if (steps_b > 0) {
    CotanOperator op = build_cotan_operator(x, triangles, adj, rank);
    const auto b_start = std::chrono::steady_clock::now();
    if (o.rebuild_b == 0) {
      // The triangle or corner lists only serve to build the operator: free them for the sweeps
      // (16 bytes a vertex as corner lists, 32 as triangle lists with tri_row).
      // (swap with empty vectors: `= {}` would keep the capacity).
      UninitVector<uint32_t>().swap(adj.tri_offsets);
      UninitVector<uint32_t>().swap(adj.tri_ids);
      std::vector<uint32_t>().swap(adj.tri_row);
      UninitVector<uint32_t>().swap(adj.corner_offsets);
      UninitVector<CornerSlots>().swap(adj.corners);
      give_back_free_heap_pages();  // as at the end of the set-up
    }
    float w = o.relax_b;
    double energy = energy_of(adj, op, x, scratch, rank);
    report.energy_start = energy;
    // Where the sweep started, for the guard's undo: Gauss-Seidel moves each vertex once and
    // records the move (SweepUndo, 6 bytes a vertex); Jacobi keeps a copy.
    SweepUndo undo;
    std::vector<Vec3f> backup;
    if (!gauss_seidel) reserve_huge(backup, nv);
    for (int s = 0; s < steps_b; ++s) {
      const bool constrained = s < o.steps_b && constrained_any;
      if (o.rebuild_b > 0 && s > 0 && s % o.rebuild_b == 0) {
        op = build_cotan_operator(x, triangles, adj, rank);
        energy = energy_of(adj, op, x, scratch, rank);
      }
      if (gauss_seidel) {
        undo.begin(nv);
        // scratch = W x (energy_of computed it for the current x) is kept current as vertices
        // move: (B x)_i needs only the W x of i's ring, and a move of x_i changes only the W x
        // of that ring — no two vertices of a distance-2 colour class share a ring vertex.
        for_each_in_colors(layout->b, [&](uint32_t i) {
          const Vec3f before = x[i];
          const float w_ii = w_diagonal(adj, op, i);
          float b_ii;
          const Vec3f bx = bilaplacian_row_and_diagonal(adj.offsets.data(), neighbors, op.w.data(), w_ii,
                                                        op.area.data(), scratch.data(), i, &b_ii);
          x[i] -= bx * (w * vertex_factor(i) / b_ii);
          if (constrained) project(i, before);
          undo.record(i, before, x[i]);
          const Vec3f delta = x[i] - before;
          scratch[i] += delta * w_ii;
          for (uint32_t e = adj.offsets[i]; e < adj.offsets[i + 1]; ++e)
            scratch[neighbor_at(neighbors, i, e)] += delta * op.w[e];
        }, [&](uint32_t i) {
          prefetch(i);
          __builtin_prefetch(&scratch[i]);
          prefetch_entry(neighbors, adj.offsets[i]);
        }, [&](std::size_t q) {
          const auto [b, e] = chunk_range(q);
          prefetch_range(scratch.data(), b, e);
          prefetch_range(op.area.data(), b, e);
          prefetch_range(x.data(), b, e);
        });
      } else {
        backup = x;
        // scratch = W x was computed by energy_of for the current x.
        std::vector<Vec3f> z(nv);
        for_each_vertex(nv, [&](uint32_t i) { z[i] = scratch[i] / op.area[i]; });
        apply_w(adj, op, z, next);  // next = B x
        for_each_vertex(nv, [&](uint32_t i) {
          const Vec3f from = x[i];
          x[i] -= next[i] * (w * vertex_factor(i) /
                             bilaplacian_diagonal_row(adj.offsets.data(), neighbors, op.w.data(), nullptr,
                                                      op.area.data(), i));
          if (constrained) project(i, from);
        });
      }
      // Gauss-Seidel kept scratch = W x current through the sweep: the energy needs no second pass
      // over the mesh (the CUDA backend does the same, so both sum the same values).
      const double e = gauss_seidel ? bilaplacian_energy(op, scratch, rank) : energy_of(adj, op, x, scratch, rank);
      // A free sweep of a convergent solver never raises xᵀBx; a constrained one may a little
      // (the projection is not a descent step), but a large rise means the sweep diverges.
      const double tolerance = constrained ? 0.05 : 1e-4;
      if (e > energy * (1.0 + tolerance) && w > 1.0f / 64) {
        if (gauss_seidel)
          undo.undo(x);
        else
          x.swap(backup);
        if (constrained_any) forget();
        w *= 0.5f;
        ++report.relax_halvings;
        energy_of(adj, op, x, scratch, rank);
        --s;  // redo this sweep with the smaller ω
        continue;
      }
      energy = e;
      tick();
    }
    report.energy_final = energy;
    report.relax_b_final = w;
    report.b_sweeps_seconds = seconds_since(b_start);
  }
  return report;
}

/// Keeps a mesh's triangles packed (PackedTriangles) while the sweeps run; unpacks them when
/// restore() is called or, if the sweeps throw first, when it is destroyed.
class TrianglesPackedAway {
 public:
  explicit TrianglesPackedAway(std::vector<Triangle>& triangles) : triangles_(triangles) {}
  ~TrianglesPackedAway() {
    try {
      restore();
    } catch (...) {  // unwinding already: the triangles are lost with the failed call
    }
  }
  TrianglesPackedAway(const TrianglesPackedAway&) = delete;
  TrianglesPackedAway& operator=(const TrianglesPackedAway&) = delete;
  void pack() { packed_.pack(triangles_); }
  void restore() {
    if (packed_.packed()) packed_.unpack(triangles_);
  }
  const PackedTriangles& packed() const { return packed_; }

 private:
  std::vector<Triangle>& triangles_;
  PackedTriangles packed_;
};

/// The schedule with constraint `c` (null: none) projected through a Cache (NeighbourCache,
/// EllipsoidCache); Gauss-Seidel in the SweepLayout numbering. The operator is built from corner
/// lists (adopt_corner_lists), so the triangles are not read during the sweeps: they wait packed,
/// in their own numbering (about 7 bytes a vertex instead of 24), and are neither renumbered nor
/// numbered back. Only a mesh with a row too long for the corner lists keeps its triangles, and
/// has them renumbered with the positions.
template <class Cache, class Constraint>
SmoothReport smooth_cached(std::vector<Vec3f>& x, std::vector<Triangle>& triangles, const Constraint* constraint,
                           const SmoothOptions& o, const std::function<void(double)>& progress) {
  if (x.empty() || o.steps_a + o.steps_b + o.steps_free == 0) return {};
  const bool gauss_seidel = o.solver == SmoothingSolver::gauss_seidel;
  const bool renumber = gauss_seidel && o.renumber;
  SweepLayout layout;
  std::optional<Renumbered> renumbered;
  TrianglesPackedAway packed(triangles);  // destroyed after the sweeps' arrays, before renumbered
  SmoothOptions options = o;
  std::vector<float> relax;
  SmoothReport report;
  {
    Adjacency adj = build_adjacency(x.size(), triangles);
    // With corner lists, the sweeps read the rows only through them and the row functions: 2 bytes
    // an entry will do (the adjacency's largest array; 12 bytes a vertex less). Compacted at once,
    // in the mesh's numbering (Z-order: as near as the sweeps'), so that the set-up's peak — the
    // triangles, their lists, the rows and the new corner lists side by side — holds them small.
    const bool corners = corner_lists_fit(adj);
    if (corners && o.compact_neighbors) adj.compact_neighbors();
    if (gauss_seidel) layout = sweep_layout(adj, o.renumber);
    // The corner lists first, in the mesh's numbering (a renumbering moves them with their rows):
    // the triangles and their lists are then done with before the rows are renumbered, which
    // holds two copies of the rows for a moment (the set-up's peak had been there).
    if (corners) {
      adopt_corner_lists(adj, triangles, {});  // (the rows fit: it adopts them)
      packed.pack();
    }
    if (renumber) {
      if (o.vertex_relax.size() == x.size()) {
        relax.resize(x.size());
        for (std::size_t n = 0; n < x.size(); ++n) relax[n] = o.vertex_relax[layout.order[n]];
        options.vertex_relax = relax;
      }
      // Without corner lists the order becomes the adjacency's tri_row (the sweeps need only rank).
      adj = renumber_adjacency(std::move(adj), std::move(layout.order));
    }
    if (renumber) renumbered.emplace(x, corners ? std::span<Triangle>() : std::span<Triangle>(triangles), layout.rank);
    // The set-up freed the triangles, their lists and the rows and positions in the old numbering;
    // where they sat in the heap (glibc serves a large block from a free one that fits, mapped
    // or not) they would stay resident beside the sweeps' new arrays: ~8 MB of block 1M's peak.
    give_back_free_heap_pages();
    // Vertices move little per sweep: each keeps a list of its nearby particles, refreshed only
    // when the vertex has moved too far from where the list was made.
    Cache cache;
    if (constraint) cache.build(*constraint, x);
    report = adj.with_neighbors([&](const auto& neighbors) {
      return smooth_with(
          x, triangles, adj, neighbors, gauss_seidel ? &layout : nullptr, constraint != nullptr,
          [&](uint32_t i, Vec3f from) { x[i] = cache.project(*constraint, i, x[i], from); },
          [&](uint32_t i) { cache.prefetch(i); }, [&] { cache.forget_slack(); }, options, progress);
    });
  }  // the adjacency, operator lists and particle lists freed: room for the triangles
  packed.restore();
  return report;  // renumbered maps the positions back
}

/// The indices i in [0, n) for which keep(i), ascending (mesh/compact.hpp's parallel count and
/// listing).
template <class Keep>
std::vector<uint32_t> indices_where(std::size_t n, Keep&& keep) {
  std::vector<std::size_t> offsets;
  std::vector<uint32_t> out;
  resize_huge(out, detail::chunk_offsets(n, keep, offsets));
  detail::for_each_set(n, keep, offsets, [&](std::size_t i, std::size_t k) { out[k] = uint32_t(i); });
  return out;
}

/// The mesh's connected components grouped into batches: `of[v]` is vertex v's batch.
struct ComponentBatches {
  std::vector<uint32_t> of;
  uint32_t count = 0;
  std::size_t largest_component = 0;  ///< vertices
};

/// Whole components, in the order of their smallest vertex (in space, on a mesh numbered in space),
/// into consecutive batches of at most max(target, the largest component) vertices.
ComponentBatches component_batches(std::size_t nv, std::span<const Triangle> triangles, std::size_t target) {
  ComponentBatches batches;
  std::vector<uint32_t>& of = batches.of;
  of = component_roots(nv, triangles);
  // The components numbered in root order, in place: a root comes before the rest of its
  // component, so a vertex's root already holds the component's number when the vertex is reached.
  std::vector<std::size_t> size;
  for (std::size_t v = 0; v < nv; ++v) {
    const uint32_t root = of[v];
    if (root == v) {
      of[v] = uint32_t(size.size());
      size.push_back(0);
    } else {
      of[v] = of[root];
    }
    ++size[of[v]];
  }
  batches.largest_component = *std::max_element(size.begin(), size.end());
  const std::size_t budget = std::max(target, batches.largest_component);
  std::vector<uint32_t> batch_of(size.size());
  std::size_t filled = 0;
  for (std::size_t k = 0; k < size.size(); ++k) {
    if (filled > 0 && filled + size[k] > budget) {
      ++batches.count;
      filled = 0;
    }
    batch_of[k] = batches.count;
    filled += size[k];
  }
  ++batches.count;
  parallel_for_index(nv, 4096, [&](std::size_t v) { of[v] = batch_of[of[v]]; });
  return batches;
}

/// smooth_cached on batches of whole components (SmoothOptions::batch_vertices), one after another:
/// the sweeps' arrays (about 115 bytes a vertex) are held for one batch at a time, beside the
/// mesh's positions and packed triangles (PackedTriangles: ~7 bytes a vertex instead of 24; each
/// batch decodes its own), a batch number and a batch index a vertex, and the batch's own copy of
/// its vertices and triangles. Components do not interact in the sweeps, and a batch numbers its
/// vertices in the mesh's order, which gives the same colour classes: the positions are those of
/// one call on the whole mesh, except where the energy guard halves ω (per batch here) or the
/// floor on the vertex areas (relative to the batch's mean area) applies.
template <class Cache, class Constraint>
SmoothReport smooth_batched(std::vector<Vec3f>& x, std::vector<Triangle>& triangles, const Constraint* constraint,
                            const SmoothOptions& o, const std::function<void(double)>& progress) {
  constexpr std::size_t kAutoBatches = 8;
  const std::size_t nv = x.size();
  const std::size_t target = o.batch_vertices != 0 ? o.batch_vertices : nv / kAutoBatches;
  if (nv == 0 || o.steps_a + o.steps_b + o.steps_free == 0) return {};
  const auto start = std::chrono::steady_clock::now();
  auto whole = [&] {
    SmoothReport r = smooth_cached<Cache>(x, triangles, constraint, o, progress);
    r.batches = 1;
    r.setup_seconds = std::max(seconds_since(start) - r.a_sweeps_seconds - r.b_sweeps_seconds, 0.0);
    return r;
  };
  if (target >= nv) return whole();
  ComponentBatches batches = component_batches(nv, triangles, target);
  // Batches hold, beside the sweeps' arrays of the largest batch (about 115 bytes a vertex), about
  // 30 bytes a vertex of the whole mesh (its positions and packed triangles, a batch number, a
  // batch index and the batch's vertex list): with a component of over 3/4 of the mesh, the whole
  // mesh at once needs less (the SPHysics frame of the bench: one component of 98 %, 8.6 MB of
  // its 48 MB peak). A batch size the caller gave is kept.
  const bool pays = o.batch_vertices != 0 || batches.largest_component * 4 <= nv * 3;
  if (batches.count == 1 || !pays) {
    std::vector<uint32_t>().swap(batches.of);
    return whole();
  }
  const bool weighted = o.vertex_relax.size() == nv;
  // The mesh's own triangles wait packed (about 7 bytes a vertex instead of 24) while the batches
  // run; each batch decodes its own from them.
  TrianglesPackedAway mesh_triangles(triangles);
  mesh_triangles.pack();
  // The batches each packed block has triangles of (a block is a run of triangles of a mesh
  // numbered in space: one or two batches), so that a batch decodes only its own blocks.
  const PackedTriangles& packed = mesh_triangles.packed();
  std::vector<std::pair<uint32_t, uint32_t>> block_batches(packed.block_count());
  tbb::parallel_for(std::size_t(0), packed.block_count(), [&](std::size_t k) {
    uint32_t lo = UINT32_MAX, hi = 0;
    packed.decode_block(k, [&](const Triangle& t) {
      lo = std::min(lo, batches.of[t[0]]);
      hi = std::max(hi, batches.of[t[0]]);
    });
    block_batches[k] = {lo, hi};
  });
  SmoothReport total;
  total.batches = batches.count;
  total.relax_b_final = std::numeric_limits<double>::infinity();
  std::vector<uint32_t> local;  // a vertex's index in its batch
  resize_huge(local, nv);
  std::size_t done = 0;
  for (uint32_t b = 0; b < batches.count; ++b) {
    const std::vector<uint32_t> vertices = indices_where(nv, [&](std::size_t v) { return batches.of[v] == b; });
    std::vector<Vec3f> xb;
    std::vector<float> relax;
    resize_huge(xb, vertices.size());
    if (weighted) relax.resize(vertices.size());
    parallel_for_index(vertices.size(), 4096, [&](std::size_t k) {
      local[vertices[k]] = uint32_t(k);
      xb[k] = x[vertices[k]];
      if (weighted) relax[k] = o.vertex_relax[vertices[k]];
    });
    std::vector<Triangle> tb = packed.select(
        [&](const Triangle& t) { return batches.of[t[0]] == b; },
        [&](const Triangle& t) { return Triangle{local[t[0]], local[t[1]], local[t[2]]}; },
        [&](std::size_t k) { return block_batches[k].first <= b && b <= block_batches[k].second; });
    SmoothOptions ob = o;
    if (weighted) ob.vertex_relax = relax;
    const std::function<void(double)> pb = [&](double f) {
      if (progress) progress((double(done) + f * double(vertices.size())) / double(nv));
    };
    const SmoothReport r = smooth_cached<Cache>(xb, tb, constraint, ob, pb);
    parallel_for_index(vertices.size(), 4096, [&](std::size_t k) { x[vertices[k]] = xb[k]; });
    done += vertices.size();
    total.energy_start += r.energy_start;
    total.energy_final += r.energy_final;
    total.relax_halvings += r.relax_halvings;
    total.relax_b_final = std::min(total.relax_b_final, r.relax_b_final);
    total.a_sweeps_seconds += r.a_sweeps_seconds;
    total.b_sweeps_seconds += r.b_sweeps_seconds;
  }
  std::vector<uint32_t>().swap(local);
  std::vector<uint32_t>().swap(batches.of);
  mesh_triangles.restore();
  total.setup_seconds = std::max(seconds_since(start) - total.a_sweeps_seconds - total.b_sweeps_seconds, 0.0);
  return total;
}

}  // namespace

SmoothReport smooth_surface(std::vector<Vec3f>& x, std::vector<Triangle>& triangles, const ShellConstraint* constraint,
                            const SmoothOptions& o, const std::function<void(double)>& progress) {
  return smooth_batched<NeighbourCache>(x, triangles, constraint, o, progress);
}

SmoothReport smooth_surface(std::vector<Vec3f>& x, std::vector<Triangle>& triangles,
                            const EllipsoidConstraint* constraint, const SmoothOptions& o,
                            const std::function<void(double)>& progress) {
  return smooth_batched<EllipsoidCache>(x, triangles, constraint, o, progress);
}

}  // namespace meniscus
