// meniscus — constrained smoothing schedule (Williams 2008 §4; Edespong 2010 §3.5).
#include "smooth/smooth.hpp"

#include <tbb/parallel_for.h>

#include "common/huge_pages.hpp"
#include "smooth/adjacency.hpp"
#include "smooth/operators.hpp"

namespace meniscus {

namespace {

template <class F>
void for_each_vertex(std::size_t n, F&& f) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1024), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) f(uint32_t(i));
  });
}

/// Runs f on every vertex, one colour class after another (in parallel within a class), and
/// calls prefetch a few vertices ahead: a class is scattered over the whole vertex range, so the
/// hardware prefetcher cannot guess the next vertex's per-vertex data.
template <class F, class P>
void for_each_in_colors(const Coloring& coloring, F&& f, P&& prefetch) {
  constexpr uint32_t kAhead = 8;
  for (std::size_t c = 0; c < coloring.colors(); ++c) {
    const uint32_t b = coloring.offsets[c], e = coloring.offsets[c + 1];
    tbb::parallel_for(tbb::blocked_range<uint32_t>(b, e, 512), [&](const auto& r) {
      for (uint32_t k = r.begin(); k != r.end(); ++k) {
        if (k + kAhead < r.end()) prefetch(coloring.vertices[k + kAhead]);
        f(coloring.vertices[k]);
      }
    });
  }
}

Vec3f neighbour_mean(const Adjacency& adj, std::span<const Vec3f> x, uint32_t i) {
  return neighbour_mean_row(adj.offsets.data(), adj.neighbors.data(), x.data(), i);
}

double energy_of(const Adjacency& adj, const CotanOperator& op, std::span<const Vec3f> x, std::vector<Vec3f>& scratch) {
  resize_huge(scratch, x.size());
  apply_w(adj, op, x, scratch);
  return bilaplacian_energy(op, scratch);
}

/// The schedule; `project(i, from)` projects vertex i in place (when `constrained_any`), `from` being
/// where the vertex was before the move (where its previous projection left it);
/// `prefetch_constraint(i)` hints its constraint data; `forget()` is called when the energy guard
/// puts the vertices back where they were before a sweep.
template <class Project, class PrefetchConstraint, class Forget>
SmoothReport smooth_with(std::vector<Vec3f>& x, std::span<const Triangle> triangles, bool constrained_any,
                         Project&& project_constraint, PrefetchConstraint&& prefetch_constraint, Forget&& forget,
                         const SmoothOptions& o, const std::function<void(double)>& progress) {
  SmoothReport report;
  const std::size_t nv = x.size();
  if (nv == 0 || o.steps_a + o.steps_b + o.steps_free == 0) return report;  // no sweep: no set-up either
  Adjacency adj = build_adjacency(nv, triangles);
  const bool weighted = o.vertex_relax.size() == nv;
  auto vertex_factor = [&](uint32_t i) { return weighted ? o.vertex_relax[i] : 1.0f; };
  const bool gauss_seidel = o.solver == SmoothingSolver::gauss_seidel;
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

  // Read at random by every sweep, as all the smoothing's per-vertex arrays: on huge pages.
  std::vector<Vec3f> next, scratch;  // next: the Jacobi iterate only
  if (!gauss_seidel) resize_huge(next, nv);

  // --- A: constrained graph-Laplacian sweeps ---------------------------------------------------
  if (o.steps_a > 0) {
    const float w = o.relax_a;
    if (gauss_seidel) {
      const Coloring colors = color_vertices(adj, 1);
      for (int s = 0; s < o.steps_a; ++s, tick()) {
        for_each_in_colors(colors, [&](uint32_t i) {
          const Vec3f from = x[i];
          x[i] = from + (neighbour_mean(adj, x, i) - from) * (w * vertex_factor(i));
          project(i, from);
        }, prefetch);
      }
    } else {
      for (int s = 0; s < o.steps_a; ++s, tick()) {
        for_each_vertex(nv, [&](uint32_t i) { next[i] = x[i] + (neighbour_mean(adj, x, i) - x[i]) * (w * vertex_factor(i)); });
        x.swap(next);  // next: where the vertices were
        for_each_vertex(nv, [&](uint32_t i) { project(i, next[i]); });
      }
    }
  }

  // --- B: bilaplacian sweeps, constrained then free -------------------------------------------
  const int steps_b = o.steps_b + o.steps_free;
  if (steps_b > 0) {
    CotanOperator op = build_cotan_operator(x, triangles, adj);
    if (o.rebuild_b == 0) {
      // The triangle lists only serve to build the operator: free them for the sweeps (28 bytes a
      // vertex, an eighth of the smoothing's memory).
      // (swap with empty vectors: `= {}` would keep the capacity).
      std::vector<uint32_t>().swap(adj.tri_offsets);
      std::vector<uint32_t>().swap(adj.tri_ids);
    }
    Coloring colors;
    if (gauss_seidel) colors = color_vertices(adj, 2);
    float w = o.relax_b;
    double energy = energy_of(adj, op, x, scratch);
    report.energy_start = energy;
    std::vector<Vec3f> backup;
    reserve_huge(backup, nv);
    for (int s = 0; s < steps_b; ++s) {
      const bool constrained = s < o.steps_b && constrained_any;
      if (o.rebuild_b > 0 && s > 0 && s % o.rebuild_b == 0) {
        op = build_cotan_operator(x, triangles, adj);
        energy = energy_of(adj, op, x, scratch);
      }
      backup = x;
      if (gauss_seidel) {
        // scratch = W x (energy_of computed it for the current x) is kept current as vertices
        // move: (B x)_i needs only the W x of i's ring, and a move of x_i changes only the W x
        // of that ring — no two vertices of a distance-2 colour class share a ring vertex.
        for_each_in_colors(colors, [&](uint32_t i) {
          const Vec3f before = x[i];
          x[i] -= bilaplacian_row_from_wx(adj, op, scratch, i) * (w * vertex_factor(i) / op.b_diag[i]);
          if (constrained) project(i, before);
          const Vec3f delta = x[i] - before;
          scratch[i] += delta * op.diag[i];
          for (uint32_t e = adj.offsets[i]; e < adj.offsets[i + 1]; ++e) scratch[adj.neighbors[e]] += delta * op.w[e];
        }, [&](uint32_t i) {
          prefetch(i);
          __builtin_prefetch(&scratch[i]);
          __builtin_prefetch(&adj.neighbors[adj.offsets[i]]);
        });
      } else {
        // scratch = W x was computed by energy_of for the current x.
        std::vector<Vec3f> z(nv);
        for_each_vertex(nv, [&](uint32_t i) { z[i] = scratch[i] / op.area[i]; });
        apply_w(adj, op, z, next);  // next = B x
        for_each_vertex(nv, [&](uint32_t i) {
          const Vec3f from = x[i];
          x[i] -= next[i] * (w * vertex_factor(i) / op.b_diag[i]);
          if (constrained) project(i, from);
        });
      }
      // Gauss-Seidel kept scratch = W x current through the sweep: the energy needs no second pass
      // over the mesh (the CUDA backend does the same, so both sum the same values).
      const double e = gauss_seidel ? bilaplacian_energy(op, scratch) : energy_of(adj, op, x, scratch);
      // A free sweep of a convergent solver never raises xᵀBx; a constrained one may a little
      // (the projection is not a descent step), but a large rise means the sweep diverges.
      const double tolerance = constrained ? 0.05 : 1e-4;
      if (e > energy * (1.0 + tolerance) && w > 1.0f / 64) {
        x.swap(backup);
        if (constrained_any) forget();
        w *= 0.5f;
        ++report.relax_halvings;
        energy_of(adj, op, x, scratch);
        --s;  // redo this sweep with the smaller ω
        continue;
      }
      energy = e;
      tick();
    }
    report.energy_final = energy;
    report.relax_b_final = w;
  }
  return report;
}

}  // namespace

SmoothReport smooth_surface(std::vector<Vec3f>& x, std::span<const Triangle> triangles,
                            const ShellConstraint* constraint, const SmoothOptions& o,
                            const std::function<void(double)>& progress) {
  if (x.empty() || o.steps_a + o.steps_b + o.steps_free == 0) return {};
  // Vertices move little per sweep: each keeps a list of its nearby particles, refreshed only
  // when the vertex has moved too far from where the list was made.
  NeighbourCache cache;
  if (constraint) cache.build(*constraint, x);
  return smooth_with(
      x, triangles, constraint != nullptr,
      [&](uint32_t i, Vec3f from) { x[i] = cache.project(*constraint, i, x[i], from); },
      [&](uint32_t i) { cache.prefetch(i); }, [&] { cache.forget_slack(); }, o, progress);
}

SmoothReport smooth_surface(std::vector<Vec3f>& x, std::span<const Triangle> triangles,
                            const EllipsoidConstraint* constraint, const SmoothOptions& o,
                            const std::function<void(double)>& progress) {
  if (x.empty() || o.steps_a + o.steps_b + o.steps_free == 0) return {};
  EllipsoidCache cache;
  if (constraint) cache.build(*constraint, x);
  return smooth_with(
      x, triangles, constraint != nullptr,
      [&](uint32_t i, Vec3f from) { x[i] = cache.project(*constraint, i, x[i], from); },
      [&](uint32_t i) { cache.prefetch(i); }, [&] { cache.forget_slack(); }, o, progress);
}

}  // namespace meniscus
