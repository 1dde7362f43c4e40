// Tests of the smoothing schedule on raw extractions: convergence, the B sweeps' stable damping,
// Chebyshev's acceleration, the constraint projection after every constrained sweep, and results
// that depend on neither the thread count, the neighbour lists' form nor the batches; the CPU's
// sweeps against the shared ones the device runs.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <cmath>
#include <random>

#include "common/primitives.hpp"
#include "extract/extract.hpp"
#include "field/distance_field.hpp"
#include "grid/grid_buffers.hpp"
#include "meniscus/io.hpp"
#include "meniscus/quality.hpp"
#include "meniscus/reconstruct.hpp"
#include "mesh/adjacency_backend.hpp"
#include "mesh/vertex_order.hpp"
#include "smooth/smooth.hpp"
#include "smooth/sweeps_backend.hpp"
#include "support/io_helpers.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

struct Raw {
  ParticleSet particles;
  HashGrid grid;
  TriangleMesh mesh;
};

Raw raw_block(float jitter) {
  const float d = 0.1f, h = d / 2, r_outer = d;
  Raw raw;
  raw.particles = test::lattice_block(14, 14, 6, d, jitter, 12);
  raw.grid = HashGrid(raw.particles.positions, r_outer);
  const SampleLattice lattice{SampleLattice::Kind::a15, 2 * h};
  const float band = r_outer + 2 * h;
  const SparseField field = distance_field(raw.grid, lattice, band, band_blocks(raw.grid, lattice, band));
  raw.mesh = extract_surface(field, r_outer, Extractor::tiles).mesh;
  return raw;
}

bool all_finite(const std::vector<Vec3f>& x) {
  for (const Vec3f& v : x)
    if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) return false;
  return true;
}

// The CPU's sweeps (smooth.cpp: 16-bit neighbour lists, corner lists, no stored diagonal, cached
// particle lists, batches) are a fast path of the shared sweeps the device runs
// (smooth/sweeps_backend.hpp): on a real frame, the shared ones run with Host{} over the shared
// adjacency and the CPU's hash grid give the same vertices bit for bit and the same report.
TEST(SmoothSchedule, TheSharedSweepsOnTheHostGiveTheCpusMeshOnARealFrame) {
  const ParticleSet particles = read_particles(test::data_file("ply/double_dam_break_frame_26_4732_particles.ply"));
  const float d = float(estimate_spacing(particles)), h = d / 2, r_outer = d, r_inner = d / 2;
  const HashGrid grid(particles.positions, r_outer);
  const SampleLattice lattice{SampleLattice::Kind::a15, 2 * h};
  const float band = r_outer + 2 * h;
  TriangleMesh mesh =
      extract_surface(distance_field(grid, lattice, band, band_blocks(grid, lattice, band)), r_outer, Extractor::tiles)
          .mesh;
  reorder_vertices_spatially(mesh, lattice.cell_size);
  ASSERT_GT(mesh.vertices.size(), 10000u);
  SmoothOptions o;
  o.area_floor = 1e-6f * h * h;
  o.batch_vertices = SIZE_MAX;  // one call on the whole mesh: its energies summed in one tree
  const ShellConstraint constraint{&grid, r_inner, r_outer};
  std::vector<Vec3f> x = mesh.vertices;
  std::vector<Triangle> triangles = mesh.triangles;
  const SmoothingStats cpu = smooth_surface(x, triangles, &constraint, o);

  MeshBuffers<Host> shared;
  shared.vertex_count = mesh.vertices.size();
  shared.triangle_count = mesh.triangles.size();
  shared.vertices.upload(mesh.vertices.data(), mesh.vertices.size());
  shared.triangles.upload(mesh.triangles.data()->data(), 3 * mesh.triangles.size());
  const AdjacencyBuffers<Host> adj = build_adjacency(Host{}, shared);
  const GridView view{grid.points(),          grid.cell_keys().data(), grid.cell_starts().data(),
                      uint32_t(grid.cell_keys().size()), uint32_t(grid.size()), grid.cell_size(),
                      grid.cell_min(),        grid.cell_max()};
  const SmoothingStats host = smooth_mesh(Host{}, shared, adj, o, ShellProjection<GridView>{view, r_inner, r_outer});
  EXPECT_EQ(std::memcmp(shared.vertices.data(), x.data(), x.size() * sizeof(Vec3f)), 0);
  EXPECT_EQ(host.energy_start, cpu.energy_start);
  EXPECT_EQ(host.energy_final, cpu.energy_final);
  EXPECT_EQ(host.relax_b_min, cpu.relax_b_min);
  EXPECT_EQ(host.damped_vertices, cpu.damped_vertices);
}

TEST(SmoothSchedule, BStepsWithoutAStepsDoNotDiverge) {
  Raw raw = raw_block(0.1f);
  const ShellConstraint c{&raw.grid, 0.05f, 0.1f};
  for (SmoothingSolver solver : {SmoothingSolver::chebyshev, SmoothingSolver::jacobi}) {
    std::vector<Vec3f> x = raw.mesh.vertices;
    SmoothOptions o;
    o.steps_a = 0;
    o.steps_b = 30;
    o.steps_free = 5;
    o.solver = solver;
    const SmoothingStats r = smooth_surface(x, raw.mesh.triangles, &c, o);
    ASSERT_TRUE(all_finite(x)) << to_string(solver);
    EXPECT_LT(r.energy_final, r.energy_start) << to_string(solver);
    EXPECT_EQ(r.a_sweeps_seconds, 0.0) << "no A sweep ran";
    EXPECT_GT(r.b_sweeps_seconds, 0.0);
    EXPECT_GT(r.setup_seconds, 0.0);
    // Free sweeps move vertices only a little: still near the shell.
    const ConstraintReport res = constraint_residual(x, raw.particles.positions, 0.05, 0.1);
    EXPECT_LT(res.max_violation, 0.02) << to_string(solver);
  }
}

// Free B sweeps at the largest damping the parameters allow: each vertex's own stable damping
// (b_stable_damping, Gershgorin's bound) keeps every sweep a descent, so the bending energy falls
// however many sweeps run, on the bumpy extraction of a jittered block as on a smoothed one.
TEST(SmoothSchedule, FreeSweepsAtFullDampingDescend) {
  Raw raw = raw_block(0.2f);
  for (int sweeps : {1, 5, 40}) {
    std::vector<Vec3f> x = raw.mesh.vertices;
    SmoothOptions o;
    o.steps_a = 0;
    o.steps_b = 0;
    o.steps_free = sweeps;
    o.relax_b = 1.0f;
    const SmoothingStats r = smooth_surface(x, raw.mesh.triangles, nullptr, o);
    ASSERT_TRUE(all_finite(x));
    EXPECT_LT(r.energy_final, r.energy_start) << sweeps;
    EXPECT_EQ(r.damped_vertices, x.size()) << "the bound is below 1 everywhere (about 0.5 on a regular mesh)";
    EXPECT_GT(r.relax_b_min, 0.01);  // the raw extraction's slivers have the smallest bound
    EXPECT_LT(r.relax_b_min, 0.6);
  }
}

// Chebyshev's weights make the A sweeps converge much faster than plain Jacobi sweeps: after the
// same 20 sweeps, the top face of a jittered block (the interior of it, away from the rounded
// edges) is flatter.
TEST(SmoothSchedule, ChebyshevFlattensMoreThanPlainJacobi) {
  Raw raw = raw_block(0.1f);
  const float d = 0.1f;
  const ShellConstraint c{&raw.grid, 0.05f, 0.1f};
  double rms[2];
  for (int k = 0; k < 2; ++k) {
    std::vector<Vec3f> x = raw.mesh.vertices;
    SmoothOptions o;
    o.steps_a = 20;
    o.steps_b = 0;
    o.steps_free = 0;
    o.solver = k == 0 ? SmoothingSolver::chebyshev : SmoothingSolver::jacobi;
    smooth_surface(x, raw.mesh.triangles, &c, o);
    std::vector<Vec3f> face;
    const float top = 5 * d, lo = 3 * d, hi = 10 * d;
    for (const Vec3f& v : x)
      if (v.z > top + 0.25f * d && v.x > lo && v.y > lo && v.x < hi && v.y < hi) face.push_back(v);
    ASSERT_GT(face.size(), 100u);
    rms[k] = fit_plane(face).rms / d;
  }
  EXPECT_LT(rms[0], 0.8 * rms[1]) << "top-face RMS, Chebyshev " << rms[0] << " d vs Jacobi " << rms[1] << " d";
}

TEST(SmoothSchedule, ChebyshevWeightsAreGolubAndVargas) {
  // w₀ = 1, w₁ = 2/(2 − ρ²), wₛ = 4/(4 − ρ² wₛ₋₁) → 2/(1 + √(1 − ρ²)); 1 in the plain tail.
  const int steps = 20, tail = chebyshev_plain_tail(steps);
  EXPECT_EQ(tail, 6);
  const float rho2 = kChebyshevRhoA * kChebyshevRhoA, limit = 2.0f / (1.0f + std::sqrt(1.0f - rho2));
  float w = 1;
  for (int s = 0; s < steps; ++s) {
    const float previous = w;
    w = chebyshev_weight(s, steps, w, SmoothingSolver::chebyshev, kChebyshevRhoA);
    if (s == 0 || s >= steps - tail) {
      EXPECT_EQ(w, 1.0f) << s;
    } else if (s == 1) {
      EXPECT_FLOAT_EQ(w, 2.0f / (2.0f - rho2));
    } else {  // falling toward the limit from above
      EXPECT_LT(w, previous) << s;
      EXPECT_GT(w, limit - 1e-5f) << s;
      if (s == steps - tail - 1) {
        EXPECT_LT(w, limit + 0.02f);  // close to it by the last accelerated sweep
      }
    }
    EXPECT_EQ(chebyshev_weight(s, steps, 1.5f, SmoothingSolver::jacobi, kChebyshevRhoA), 1.0f);
  }
  // The distance fields are accelerated for ρ = 0.97, the density fields, smooth as extracted, less.
  EXPECT_EQ(chebyshev_rho_for(FieldMethod::distance), kChebyshevRhoA);
  EXPECT_EQ(chebyshev_rho_for(FieldMethod::zhu_bridson), kChebyshevRhoA);
  for (FieldMethod f : {FieldMethod::metaball, FieldMethod::sph, FieldMethod::anisotropic})
    EXPECT_EQ(chebyshev_rho_for(f), kChebyshevRhoDensity);
}

TEST(SmoothSchedule, ConstrainedSweepsKeepEveryVertexInTheShell) {
  Raw raw = raw_block(0.2f);
  const ShellConstraint c{&raw.grid, 0.05f, 0.1f};
  for (SmoothingSolver solver : {SmoothingSolver::chebyshev, SmoothingSolver::jacobi}) {
    std::vector<Vec3f> x = raw.mesh.vertices;
    SmoothOptions o;
    o.steps_a = 4;
    o.steps_b = 6;
    o.steps_free = 0;
    o.solver = solver;
    smooth_surface(x, raw.mesh.triangles, &c, o);
    const ConstraintReport res = constraint_residual(x, raw.particles.positions, 0.05, 0.1);
    EXPECT_LE(res.max_violation, 1e-6) << to_string(solver);
  }
}

// Every sweep reads only the previous iterate and every decision is a vertex's own: the thread
// count (1, 2, 4) and the neighbour lists' form (16 or 32 bits) change no bit of any position, with
// per-vertex damping (velocity weighting) too.
TEST(SmoothSchedule, ThreadsAndNeighbourListsChangeNoBit) {
  Raw raw = raw_block(0.2f);
  const std::size_t nv = raw.mesh.vertices.size();
  const ShellConstraint c{&raw.grid, 0.05f, 0.1f};
  std::vector<float> damping(nv);
  for (std::size_t i = 0; i < nv; ++i) damping[i] = 0.5f + 0.5f * float((i * 7919) % 101) / 100.0f;
  for (const bool weighted : {false, true}) {
    SmoothOptions o;
    o.steps_a = 12;
    o.steps_b = 8;
    o.steps_free = 2;
    if (weighted) o.vertex_relax = damping;
    std::vector<Vec3f> reference;
    for (int run = 0; run < 4; ++run) {
      const std::size_t threads = run == 3 ? 2 : std::size_t(1) << run;  // 1, 2, 4, then 2 with 32-bit lists
      tbb::global_control cap(tbb::global_control::max_allowed_parallelism, threads);
      o.compact_neighbors = run != 3;
      std::vector<Vec3f> x = raw.mesh.vertices;
      std::vector<Triangle> t = raw.mesh.triangles;
      smooth_surface(x, t, &c, o);
      EXPECT_TRUE(t == raw.mesh.triangles);
      if (run == 0) {
        reference = x;
        std::size_t moved = 0;
        for (std::size_t i = 0; i < nv; ++i) moved += !(x[i] == raw.mesh.vertices[i]);
        EXPECT_GT(moved, nv / 2) << "the sweeps moved the vertices";
        continue;
      }
      for (std::size_t i = 0; i < nv; ++i)
        for (int a = 0; a < 3; ++a)
          ASSERT_TRUE(test::same_bits(x[i][a], reference[i][a])) << "run " << run << " vertex " << i << " axis " << a;
    }
  }
}

// A mesh with a row too long for the corner lists (a double cone over a ring of 300 vertices)
// keeps its triangles through the sweeps and is smoothed all the same.
TEST(SmoothSchedule, AMeshWithoutCornerListsIsSmoothedAndKeepsItsTriangles) {
  TriangleMesh cone;
  const uint32_t ring = 300;
  cone.vertices.push_back({0, 0, 0.3f});
  cone.vertices.push_back({0, 0, -0.3f});
  for (uint32_t k = 0; k < ring; ++k) {
    const float a = 6.2831853f * float(k) / float(ring);
    cone.vertices.push_back({std::cos(a), std::sin(a), 0.05f * float(k % 3)});
  }
  for (uint32_t k = 0; k < ring; ++k) {
    const uint32_t a = 2 + k, b = 2 + (k + 1) % ring;
    cone.triangles.push_back({0, a, b});
    cone.triangles.push_back({1, b, a});
  }
  SmoothOptions o;
  o.steps_a = 3;
  o.steps_b = 3;
  o.steps_free = 1;
  std::vector<Vec3f> x = cone.vertices;
  std::vector<Triangle> t = cone.triangles;
  const SmoothingStats r = smooth_surface(x, t, nullptr, o);
  EXPECT_TRUE(t == cone.triangles);
  ASSERT_TRUE(all_finite(x));
  EXPECT_LT(r.energy_final, r.energy_start);
  std::size_t moved = 0;
  for (std::size_t i = 0; i < cone.vertices.size(); ++i) moved += !(x[i] == cone.vertices[i]);
  EXPECT_GT(moved, cone.vertices.size() / 2);
}

// A pool and droplets (a jittered block and balls of particles apart from it, each its own
// component): the sweeps on batches of whole components (SmoothOptions::batch_vertices) must give
// the vertices of one call on the whole mesh, bit for bit (a batch keeps the mesh's order, rows
// are summed alike, every decision is a vertex's own), with per-vertex damping too; the reported
// energies are the batches' sums.
/// The extraction of `particles` (d = 0.1, r_outer = d) with its grid.
Raw raw_of(ParticleSet particles) {
  const float d = 0.1f, h = d / 2, r_outer = d;
  Raw raw;
  raw.particles = std::move(particles);
  raw.grid = HashGrid(raw.particles.positions, r_outer);
  const SampleLattice lattice{SampleLattice::Kind::a15, 2 * h};
  const float band = r_outer + 2 * h;
  const SparseField field = distance_field(raw.grid, lattice, band, band_blocks(raw.grid, lattice, band));
  raw.mesh = extract_surface(field, r_outer, Extractor::tiles).mesh;
  return raw;
}

/// A jittered pool and, a row above it, `drops` droplets of a few particles each.
Raw raw_pool_and_drops(int drops) {
  const float d = 0.1f;
  ParticleSet particles = test::lattice_block(12, 12, 4, d, 0.2f, 3);
  for (int k = 0; k < drops; ++k) {
    const ParticleSet drop = test::lattice_ball(0.12f + 0.03f * float(k % 3), d, {0.2f + 0.2f * float(k), 0.6f, 0.9f});
    particles.positions.insert(particles.positions.end(), drop.positions.begin(), drop.positions.end());
  }
  return raw_of(std::move(particles));
}

/// The vertex count of the largest connected component (a union-find of its own).
std::size_t largest_component(const TriangleMesh& mesh) {
  std::vector<uint32_t> parent(mesh.vertices.size());
  for (uint32_t i = 0; i < parent.size(); ++i) parent[i] = i;
  auto find = [&](uint32_t v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  for (const Triangle& t : mesh.triangles) {
    parent[find(t[1])] = find(t[0]);
    parent[find(t[2])] = find(t[0]);
  }
  std::vector<std::size_t> size(parent.size(), 0);
  for (uint32_t i = 0; i < parent.size(); ++i) ++size[find(i)];
  return *std::max_element(size.begin(), size.end());
}

TEST(SmoothSchedule, BatchesOfWholeComponentsGiveTheWholeMeshsVertices) {
  const Raw raw = raw_pool_and_drops(6);
  const std::size_t nv = raw.mesh.vertices.size();
  const ShellConstraint c{&raw.grid, 0.05f, 0.1f};
  std::vector<float> damping(nv);
  for (std::size_t i = 0; i < nv; ++i) damping[i] = 0.5f + 0.5f * float((i * 7919) % 101) / 100.0f;
  for (const bool weighted : {false, true}) {
    SmoothOptions o;
    o.steps_a = 8;
    o.steps_b = 6;
    o.steps_free = 2;
    if (weighted) o.vertex_relax = damping;
    std::vector<Vec3f> x[2] = {raw.mesh.vertices, raw.mesh.vertices};
    std::vector<Triangle> t[2] = {raw.mesh.triangles, raw.mesh.triangles};
    SmoothingStats r[2];
    for (int m = 0; m < 2; ++m) {
      o.batch_vertices = m == 0 ? SIZE_MAX : nv / 20;
      r[m] = smooth_surface(x[m], t[m], &c, o);
    }
    EXPECT_EQ(r[0].batches, 1u);
    EXPECT_GE(r[1].batches, 2u) << "the pool alone (a batch is as large as the largest component), the droplets";
    EXPECT_TRUE(t[1] == raw.mesh.triangles) << "the triangles are left as they were";
    EXPECT_NEAR(r[1].energy_start, r[0].energy_start, 1e-9 * r[0].energy_start);
    EXPECT_NEAR(r[1].energy_final, r[0].energy_final, 1e-9 * r[0].energy_final);
    EXPECT_EQ(r[1].damped_vertices, r[0].damped_vertices);
    EXPECT_EQ(r[1].relax_b_min, r[0].relax_b_min);
    std::size_t moved = 0;
    for (std::size_t i = 0; i < nv; ++i) {
      for (int a = 0; a < 3; ++a)
        ASSERT_TRUE(test::same_bits(x[0][i][a], x[1][i][a])) << "weighted " << weighted << " vertex " << i;
      moved += !(x[1][i] == raw.mesh.vertices[i]);
    }
    EXPECT_GT(moved, nv / 2);
  }
}

// Left to choose (batch_vertices 0), the smoothing batches a mesh only where that lowers its
// peak: not when one component holds over 3/4 of the vertices (the batches' arrays over the whole
// mesh would cost more than the smaller sweeps save), but a mesh of many like components, yes.
TEST(SmoothSchedule, AutomaticBatchesOnlyWhereNoComponentDominates) {
  SmoothOptions o;
  o.steps_a = 2;
  o.steps_b = 2;
  o.steps_free = 0;
  const Raw pool = raw_pool_and_drops(2);
  ASSERT_GT(largest_component(pool.mesh) * 4, pool.mesh.vertices.size() * 3);
  ParticleSet balls;
  for (int k = 0; k < 12; ++k) {
    const ParticleSet ball = test::lattice_ball(0.25f, 0.1f, {float(k % 4), float(k / 4), 0.0f});
    balls.positions.insert(balls.positions.end(), ball.positions.begin(), ball.positions.end());
  }
  const Raw apart = raw_of(std::move(balls));
  ASSERT_LE(largest_component(apart.mesh) * 8, apart.mesh.vertices.size()) << "12 like balls";
  for (const Raw* raw : {&pool, &apart}) {
    const ShellConstraint c{&raw->grid, 0.05f, 0.1f};
    std::vector<Vec3f> x = raw->mesh.vertices;
    std::vector<Triangle> t = raw->mesh.triangles;
    o.batch_vertices = 0;
    const SmoothingStats automatic = smooth_surface(x, t, &c, o);
    if (raw == &pool) {
      EXPECT_EQ(automatic.batches, 1u) << "one component of over 3/4: the whole mesh at once";
      x = raw->mesh.vertices;
      t = raw->mesh.triangles;
      o.batch_vertices = raw->mesh.vertices.size() / 20;
      EXPECT_GE(smooth_surface(x, t, &c, o).batches, 2u) << "a batch size given is kept";
    } else {
      EXPECT_GE(automatic.batches, 4u) << "twelve like components: about an eighth of the mesh each";
    }
  }
}

}  // namespace
}  // namespace meniscus
