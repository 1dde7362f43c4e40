// meniscus — constrained smoothing schedule (Williams 2008 §4; Edespong 2010 §3.5).
#include "smooth/smooth.hpp"

#include <algorithm>
#include <chrono>
#include <atomic>
#include <cstdint>
#include <limits>
#include <optional>
#include <cstdlib>

#include "common/clock.hpp"
#include "common/huge_pages.hpp"
#include "common/for_each.hpp"
#include "common/primitives.hpp"
#include "system/memory_scope.hpp"
#include "mesh/components.hpp"
#include "mesh/packed_triangles.hpp"
#include "smooth/adjacency.hpp"
#include "smooth/operators.hpp"
#include "smooth/sweeps_impl.hpp"

namespace meniscus {

namespace {

/// Projects vertex i, moved by a sweep from `from` (where its previous projection left it), through
/// the constraint's particle lists (Cache: NeighbourCache, EllipsoidCache).
template <class Cache, class Constraint>
struct CachedProjection {
  Cache* cache;
  const Constraint* constraint;
  Vec3f operator()(uint32_t i, Vec3f moved, Vec3f from) const { return cache->project(*constraint, i, moved, from); }
};

/// The sweeps of the schedule (run_schedule, smooth/schedule.hpp) on the CPU: the shared
/// per-vertex work (smooth/sweeps_impl.hpp) over for_each_index. x holds the current iterate.
/// `adj` is the triangles' (its triangle or corner lists are freed once the operator is built when
/// it is built once); `triangles` may be empty when it has corner lists. `neighbors`: adj's
/// neighbour lists as Adjacency::with_neighbors gives them.
template <class Neighbors, class Project>
struct CpuSweeps {
  static constexpr bool kHostTimed = true;
  static constexpr std::size_t kGrain = 1024;

  std::vector<Vec3f>& x;
  std::span<const Triangle> triangles;
  Adjacency& adj;
  Neighbors neighbors;
  bool constrained_any;
  Project project;
  const SmoothOptions& o;
  const std::function<void(double)>& progress;

  int done = 0;
  std::vector<Vec3f> other{};  // the A sweeps' x⁽ˢ⁻¹⁾, read at random with x by every sweep: on huge pages
  CotanOperator op{};
  std::vector<Vec3f> wx{};    // W x of the current iterate
  std::vector<float> omega{};  // each vertex's B damping
  unsigned long long damped = 0;

  std::size_t nv() const { return x.size(); }
  SweepRows<Neighbors> rows() const {
    // The CPU keeps no diagonal of W (4 bytes a vertex less): the row functions sum it.
    return {adj.offsets.data(), neighbors, op.w.data(), nullptr, op.area.data(),
            o.vertex_relax.size() == nv() ? o.vertex_relax.data() : nullptr};
  }
  void swept() {
    ++done;
    const int total = o.steps_a + o.steps_b + o.steps_free;
    if (progress && total > 0) progress(double(done) / total);
  }

  void a_begin() {
    resize_huge(other, nv());
    for_each_index(nv(), 4096, [&](std::size_t i) { other[i] = x[i]; });
  }
  void a_sweep(float weight) {
    for_each_index(
        nv(), kGrain,
        ASweep<Neighbors, Project>{rows(), x.data(), other.data(), o.relax_a, weight, constrained_any, project});
    x.swap(other);
  }
  void a_end() { std::vector<Vec3f>().swap(other); }

  void build_operator() {
    const bool first = op.area.empty();
    op = build_cotan_operator(x, triangles, adj, o.area_floor);
    if (first && o.rebuild_b == 0) {
      // The triangle or corner lists only serve to build the operator: free them for the sweeps
      // (16 bytes a vertex as corner lists, 24 as triangle lists; swap with empty vectors: `= {}`
      // would keep the capacity).
      UninitVector<uint32_t>().swap(adj.tri_offsets);
      UninitVector<uint32_t>().swap(adj.tri_ids);
      UninitVector<uint32_t>().swap(adj.corner_offsets);
      UninitVector<CornerSlots>().swap(adj.corners);
      give_back_free_heap_pages();  // as at the end of the set-up
    }
    if (first) {
      resize_huge(wx, nv());
      resize_huge(omega, nv());
    }
  }
  void set_damping() {
    damped = 0;
    for_each_index(nv(), kGrain, BDamping<Neighbors>{rows(), o.relax_b, omega.data(), &damped});
  }
  void update_wx() { for_each_index(nv(), kGrain, ApplyW<Neighbors>{rows(), x.data(), wx.data()}); }
  double energy() const { return bilaplacian_energy(op, wx); }
  void b_sweep(bool constrained) {
    for_each_index(
        nv(), kGrain,
        BSweep<Neighbors, Project>{rows(), wx.data(), omega.data(), x.data(), constrained && constrained_any, project});
  }
  std::size_t damped_vertices() const { return std::size_t(damped); }
  double least_damping() const {
    float least = o.relax_b;
    for (float w : omega) least = std::min(least, w);
    return least;
  }
};

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
/// EllipsoidCache). The operator is built from corner lists (adopt_corner_lists), so the triangles
/// are not read during the sweeps: they wait packed (about 7 bytes a vertex instead of 24). Only a
/// mesh with a row too long for the corner lists keeps its triangles.
template <class Cache, class Constraint>
SmoothingStats smooth_cached(std::vector<Vec3f>& x, std::vector<Triangle>& triangles, const Constraint* constraint,
                           const SmoothOptions& o, const std::function<void(double)>& progress) {
  if (x.empty() || o.steps_a + o.steps_b + o.steps_free == 0) return {};
  TrianglesPackedAway packed(triangles);
  SmoothingStats report;
  {
    Adjacency adj = build_adjacency(x.size(), triangles);
    // With corner lists, the sweeps read the rows only through them and the row functions: 2 bytes
    // an entry will do (the adjacency's largest array; 12 bytes a vertex less).
    const bool corners = corner_lists_fit(adj);
    if (corners && o.compact_neighbors) adj.compact_neighbors();
    if (corners) {
      adopt_corner_lists(adj, triangles);
      packed.pack();
    }
    // The set-up freed the triangles' lists; where they sat in the heap they would stay resident
    // beside the sweeps' new arrays.
    give_back_free_heap_pages();
    // Vertices move little per sweep: each keeps a list of its nearby particles, refreshed only
    // when the vertex has moved too far from where the list was made.
    Cache cache;
    if (constraint) cache.build(*constraint, x);
    report = adj.with_neighbors([&](const auto& neighbors) {
      using Neighbors = std::decay_t<decltype(neighbors)>;
      using Project = CachedProjection<Cache, Constraint>;
      CpuSweeps<Neighbors, Project> sweeps{x, triangles, adj, neighbors, constraint != nullptr,
                                           Project{&cache, constraint}, o, progress};
      return run_schedule(o, sweeps);
    });
  }  // the adjacency, operator lists and particle lists freed: room for the triangles
  packed.restore();
  return report;
}

/// The indices i in [0, n) for which keep(i), ascending (mesh/compact.hpp's parallel count and
/// listing).
template <class Keep>
std::vector<uint32_t> indices_where(std::size_t n, Keep&& keep) {
  std::vector<std::size_t> offsets;
  std::vector<uint32_t> out;
  resize_huge(out, chunk_offsets(n, keep, offsets));
  for_each_set(n, keep, offsets, [&](std::size_t i, std::size_t k) { out[k] = uint32_t(i); });
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
  for_each_index(nv, 4096, [&](std::size_t v) { of[v] = batch_of[of[v]]; });
  return batches;
}

/// smooth_cached on batches of whole components (SmoothOptions::batch_vertices), one after another:
/// the sweeps' arrays are held for one batch at a time, beside the mesh's positions and packed
/// triangles (PackedTriangles: ~7 bytes a vertex instead of 24; each batch decodes its own), a
/// batch number and a batch index a vertex, and the batch's own copy of its vertices and triangles.
/// Components do not interact in the sweeps, every decision of the sweeps is a vertex's own, and a
/// batch numbers its vertices in the mesh's order: the positions are those of one call on the
/// whole mesh, bit for bit.
template <class Cache, class Constraint>
SmoothingStats smooth_batched(std::vector<Vec3f>& x, std::vector<Triangle>& triangles, const Constraint* constraint,
                            const SmoothOptions& o, const std::function<void(double)>& progress) {
  constexpr std::size_t kAutoBatches = 8;
  const std::size_t nv = x.size();
  const std::size_t target = o.batch_vertices != 0 ? o.batch_vertices : nv / kAutoBatches;
  if (nv == 0 || o.steps_a + o.steps_b + o.steps_free == 0) return {};
  const auto start = std::chrono::steady_clock::now();
  auto whole = [&] {
    SmoothingStats r = smooth_cached<Cache>(x, triangles, constraint, o, progress);
    r.batches = 1;
    r.setup_seconds = std::max(seconds_since(start) - r.a_sweeps_seconds - r.b_sweeps_seconds, 0.0);
    return r;
  };
  if (target >= nv) return whole();
  ComponentBatches batches = component_batches(nv, triangles, target);
  // Batches hold, beside the sweeps' arrays of the largest batch (about 115 bytes a vertex), about
  // 30 bytes a vertex of the whole mesh (its positions and packed triangles, a batch number, a
  // batch index and the batch's vertex list): with a component of over 3/4 of the mesh, the whole
  // mesh at once needs less (a tank frame, almost all of it one component). A batch size the
  // caller gave is kept.
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
  for_each_index(packed.block_count(), [&](std::size_t k) {
    uint32_t lo = UINT32_MAX, hi = 0;
    packed.decode_block(k, [&](const Triangle& t) {
      lo = std::min(lo, batches.of[t[0]]);
      hi = std::max(hi, batches.of[t[0]]);
    });
    block_batches[k] = {lo, hi};
  });
  SmoothingStats total;
  total.batches = batches.count;
  total.relax_b_min = std::numeric_limits<double>::infinity();
  std::vector<uint32_t> local;  // a vertex's index in its batch
  resize_huge(local, nv);
  std::size_t done = 0;
  for (uint32_t b = 0; b < batches.count; ++b) {
    const std::vector<uint32_t> vertices = indices_where(nv, [&](std::size_t v) { return batches.of[v] == b; });
    std::vector<Vec3f> xb;
    std::vector<float> relax;
    resize_huge(xb, vertices.size());
    if (weighted) relax.resize(vertices.size());
    for_each_index(vertices.size(), 4096, [&](std::size_t k) {
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
    const SmoothingStats r = smooth_cached<Cache>(xb, tb, constraint, ob, pb);
    for_each_index(vertices.size(), 4096, [&](std::size_t k) { x[vertices[k]] = xb[k]; });
    done += vertices.size();
    total.energy_start += r.energy_start;
    total.energy_final += r.energy_final;
    total.damped_vertices += r.damped_vertices;
    total.relax_b_min = std::min(total.relax_b_min, r.relax_b_min);
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

SmoothingStats smooth_surface(std::vector<Vec3f>& x, std::vector<Triangle>& triangles, const ShellConstraint* constraint,
                            const SmoothOptions& o, const std::function<void(double)>& progress) {
  return smooth_batched<NeighbourCache>(x, triangles, constraint, o, progress);
}

SmoothingStats smooth_surface(std::vector<Vec3f>& x, std::vector<Triangle>& triangles,
                            const EllipsoidConstraint* constraint, const SmoothOptions& o,
                            const std::function<void(double)>& progress) {
  return smooth_batched<EllipsoidCache>(x, triangles, constraint, o, progress);
}

}  // namespace meniscus
