// Tests of the smoothing schedule on raw extractions: convergence, the B-step guard, and the
// constraint projection after every constrained sweep.
#include <gtest/gtest.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <random>

#include "extract/extract.hpp"
#include "field/distance_field.hpp"
#include "meniscus/quality.hpp"
#include "smooth/smooth.hpp"
#include "smooth/sweep_undo.hpp"
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

TEST(SmoothSchedule, BStepsWithoutAStepsDoNotDiverge) {
  Raw raw = raw_block(0.1f);
  const ShellConstraint c{&raw.grid, 0.05f, 0.1f};
  for (SmoothingSolver solver : {SmoothingSolver::gauss_seidel, SmoothingSolver::jacobi}) {
    std::vector<Vec3f> x = raw.mesh.vertices;
    SmoothOptions o;
    o.steps_a = 0;
    o.steps_b = 30;
    o.steps_free = 5;
    o.solver = solver;
    const SmoothReport r = smooth_surface(x, raw.mesh.triangles, &c, o);
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

TEST(SmoothSchedule, GuardHalvesAnOverRelaxedFreeSweep) {
  Raw raw = raw_block(0.1f);
  std::vector<Vec3f> x = raw.mesh.vertices;
  SmoothOptions o;
  o.steps_a = 0;
  o.steps_b = 0;
  o.steps_free = 20;
  o.relax_b = 1.99f;
  o.solver = SmoothingSolver::jacobi;  // over-relaxed Jacobi on B diverges without the guard
  const SmoothReport r = smooth_surface(x, raw.mesh.triangles, nullptr, o);
  ASSERT_TRUE(all_finite(x));
  EXPECT_GT(r.relax_halvings, 0);
  EXPECT_LT(r.relax_b_final, 1.99f);
  EXPECT_LE(r.energy_final, r.energy_start);
}

// The guard puts the vertices back where they were before the rejected sweep; their cached slack
// belonged to the rejected positions and must be forgotten, or a vertex could skip its projection
// and end outside its shell.
TEST(SmoothSchedule, GuardedConstrainedSweepsEndInsideTheShells) {
  Raw raw = raw_block(0.1f);
  const ShellConstraint c{&raw.grid, 0.05f, 0.1f};
  for (SmoothingSolver solver : {SmoothingSolver::jacobi, SmoothingSolver::gauss_seidel}) {
    std::vector<Vec3f> x = raw.mesh.vertices;
    SmoothOptions o;
    o.steps_a = 5;
    o.steps_b = 25;
    o.steps_free = 0;
    o.relax_b = 3.0f;  // far over-relaxed: the guard must step in
    o.solver = solver;
    const SmoothReport r = smooth_surface(x, raw.mesh.triangles, &c, o);
    EXPECT_GT(r.relax_halvings, 0) << to_string(solver);
    const ConstraintReport res = constraint_residual(x, raw.particles.positions, 0.05, 0.1);
    EXPECT_LE(res.max_violation, 1e-6) << to_string(solver);
  }
}

TEST(SmoothSchedule, GaussSeidelConvergesFasterThanJacobi) {
  Raw raw = raw_block(0.1f);
  const ShellConstraint c{&raw.grid, 0.05f, 0.1f};
  double energy[2];
  for (int k = 0; k < 2; ++k) {
    std::vector<Vec3f> x = raw.mesh.vertices;
    SmoothOptions o;
    o.steps_a = 5;
    o.steps_b = 15;
    o.steps_free = 0;
    o.solver = k == 0 ? SmoothingSolver::gauss_seidel : SmoothingSolver::jacobi;
    energy[k] = smooth_surface(x, raw.mesh.triangles, &c, o).energy_final;
  }
  EXPECT_LT(energy[0], energy[1]) << "Gauss-Seidel " << energy[0] << " vs Jacobi " << energy[1];
}

TEST(SmoothSchedule, ConstrainedSweepsKeepEveryVertexInTheShell) {
  Raw raw = raw_block(0.2f);
  const ShellConstraint c{&raw.grid, 0.05f, 0.1f};
  for (SmoothingSolver solver : {SmoothingSolver::gauss_seidel, SmoothingSolver::jacobi}) {
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

// The Gauss-Seidel sweeps run on the vertices renumbered class by class (smooth.cpp, SweepLayout):
// the same classes, each row summed in the same order, the energy in the same tree — so the
// vertices must come out bit-identical to the sweeps in the mesh's own numbering, and the mesh
// back in its own numbering. With per-vertex damping (velocity weighting), and with the energy
// guard rejecting sweeps (which puts the renumbered vertices back and forgets their slack).
TEST(SmoothSchedule, RenumberedSweepsGiveBitIdenticalVertices) {
  Raw raw = raw_block(0.2f);
  const std::size_t nv = raw.mesh.vertices.size();
  ASSERT_GT(nv, 3u * 4096) << "the layout's chunks are 4096 vertices: several of them";
  const ShellConstraint c{&raw.grid, 0.05f, 0.1f};
  std::vector<float> damping(nv);
  for (std::size_t i = 0; i < nv; ++i) damping[i] = 0.5f + 0.5f * float((i * 7919) % 101) / 100.0f;
  struct Case {
    const char* name;
    bool weighted;
    float relax_b;
  };
  for (const Case& k : {Case{"default", false, 1.0f}, Case{"weighted", true, 1.0f}, Case{"guarded", false, 3.0f}}) {
    SmoothOptions o;
    o.steps_a = 12;
    o.steps_b = 10;
    o.steps_free = 2;
    o.relax_b = k.relax_b;
    if (k.weighted) o.vertex_relax = damping;
    std::vector<Vec3f> x[2] = {raw.mesh.vertices, raw.mesh.vertices};
    std::vector<Triangle> t[2] = {raw.mesh.triangles, raw.mesh.triangles};
    SmoothReport r[2];
    for (int m = 0; m < 2; ++m) {
      o.renumber = m == 0;
      r[m] = smooth_surface(x[m], t[m], &c, o);
    }
    EXPECT_TRUE(t[0] == raw.mesh.triangles) << k.name << ": the triangles come back in their own numbering";
    EXPECT_EQ(r[0].energy_start, r[1].energy_start) << k.name;
    EXPECT_EQ(r[0].energy_final, r[1].energy_final) << k.name;
    EXPECT_EQ(r[0].relax_halvings, r[1].relax_halvings) << k.name;
    if (k.relax_b > 2) {
      EXPECT_GT(r[0].relax_halvings, 0) << k.name << ": the guard must step in";
    }
    std::size_t moved = 0;
    for (std::size_t i = 0; i < nv; ++i) {
      for (int a = 0; a < 3; ++a)
        ASSERT_TRUE(test::same_bits(x[0][i][a], x[1][i][a])) << k.name << " vertex " << i << " axis " << a;
      moved += !(x[0][i] == raw.mesh.vertices[i]);
    }
    EXPECT_GT(moved, nv / 2) << k.name << ": the sweeps moved the vertices";
  }
}

// A mesh with a row too long for the corner lists (a double cone over a ring of 300 vertices)
// keeps its triangles through the sweeps, renumbered with the positions: the same two checks.
TEST(SmoothSchedule, AMeshWithoutCornerListsStillGivesBitIdenticalVertices) {
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
  std::vector<Vec3f> x[2] = {cone.vertices, cone.vertices};
  std::vector<Triangle> t[2] = {cone.triangles, cone.triangles};
  for (int m = 0; m < 2; ++m) {
    o.renumber = m == 0;
    smooth_surface(x[m], t[m], nullptr, o);
    EXPECT_TRUE(t[m] == cone.triangles) << m;
  }
  std::size_t moved = 0;
  for (std::size_t i = 0; i < cone.vertices.size(); ++i) {
    for (int a = 0; a < 3; ++a) ASSERT_TRUE(test::same_bits(x[0][i][a], x[1][i][a])) << "vertex " << i;
    moved += !(x[0][i] == cone.vertices[i]);
  }
  EXPECT_GT(moved, cone.vertices.size() / 2);
}

// A pool and droplets (a jittered block and balls of particles apart from it, each its own
// component): the sweeps on batches of whole components (SmoothOptions::batch_vertices) must give
// the vertices of one call on the whole mesh, bit for bit (the same colour classes: a batch keeps
// the mesh's order; rows summed alike), with per-vertex damping too; the reported energies are
// the batches' sums; and the energy guard, per batch, still steps in and keeps the sweeps finite.
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
    SmoothReport r[2];
    for (int m = 0; m < 2; ++m) {
      o.batch_vertices = m == 0 ? SIZE_MAX : nv / 20;
      r[m] = smooth_surface(x[m], t[m], &c, o);
    }
    EXPECT_EQ(r[0].batches, 1u);
    EXPECT_GE(r[1].batches, 2u) << "the pool alone (a batch is as large as the largest component), the droplets";
    EXPECT_TRUE(t[1] == raw.mesh.triangles) << "the triangles are left as they were";
    EXPECT_NEAR(r[1].energy_start, r[0].energy_start, 1e-9 * r[0].energy_start);
    EXPECT_NEAR(r[1].energy_final, r[0].energy_final, 1e-9 * r[0].energy_final);
    EXPECT_EQ(r[1].relax_halvings, 0);
    std::size_t moved = 0;
    for (std::size_t i = 0; i < nv; ++i) {
      for (int a = 0; a < 3; ++a)
        ASSERT_TRUE(test::same_bits(x[0][i][a], x[1][i][a])) << "weighted " << weighted << " vertex " << i;
      moved += !(x[1][i] == raw.mesh.vertices[i]);
    }
    EXPECT_GT(moved, nv / 2);
  }
  // ω = 3 diverges: every batch's guard halves it until its sweeps descend.
  SmoothOptions o;
  o.steps_a = 4;
  o.steps_b = 6;
  o.steps_free = 1;
  o.relax_b = 3.0f;
  o.batch_vertices = nv / 20;
  std::vector<Vec3f> x = raw.mesh.vertices;
  std::vector<Triangle> triangles = raw.mesh.triangles;
  const SmoothReport r = smooth_surface(x, triangles, &c, o);
  EXPECT_GE(r.relax_halvings, int(r.batches));
  EXPECT_LE(r.relax_b_final, 1.5);
  EXPECT_LT(r.energy_final, r.energy_start);
  EXPECT_TRUE(all_finite(x));
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
    const SmoothReport automatic = smooth_surface(x, t, &c, o);
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

// The guard's undo of a Gauss-Seidel sweep gives back every position bit for bit: small moves
// (kept as 16-bit differences of the float bits), moves of a vertex to the far side of zero, large
// moves, moves from and to zero, denormals and vertices that did not move (kept whole aside),
// recorded from several threads; a second sweep's record replaces the first's.
TEST(SweepUndo, GivesBackEveryPositionBitForBit) {
  const std::size_t nv = 200000;
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(-100.0f, 100.0f);
  std::vector<Vec3f> before(nv), after(nv);
  for (std::size_t i = 0; i < nv; ++i) {
    before[i] = {u(rng), u(rng), u(rng)};
    Vec3f step{u(rng), u(rng), u(rng)};
    switch (i % 8) {
      case 0: step = step * 1e-6f; break;                          // a few ulps to thousands
      case 1: step = {0, 0, 0}; break;                             // did not move
      case 2: before[i].y = 1e-3f; step = {0, -2e-3f, 0}; break;   // across zero
      case 3: step = step * 0.5f; break;                           // far
      case 4: before[i].z = 0.0f; step = {0, 0, 1e-30f}; break;    // from zero
      case 5: before[i].x = 1e-40f; step = {-1e-40f, 0, 0}; break;  // a denormal to zero
      default: step = step * 1e-5f; break;
    }
    after[i] = before[i] + step;
  }
  SweepUndo undo;
  std::vector<Vec3f> x(nv, Vec3f{1, 2, 3});
  for (int sweep = 0; sweep < 2; ++sweep) {  // the first sweep's record is dropped by begin()
    undo.begin(nv);
    tbb::parallel_for(std::size_t(0), nv, [&](std::size_t i) {
      const Vec3f from = sweep == 0 ? Vec3f{1, 2, 3} : before[i];
      x[i] = sweep == 0 ? before[i] : after[i];
      undo.record(uint32_t(i), from, x[i]);
    });
  }
  EXPECT_EQ(undo.memory_bytes(), 6 * nv);
  undo.undo(x);
  for (std::size_t i = 0; i < nv; ++i)
    for (int k = 0; k < 3; ++k)
      ASSERT_EQ(std::bit_cast<uint32_t>(x[i][k]), std::bit_cast<uint32_t>(before[i][k])) << "vertex " << i << " axis " << k;
}

// With ω = 3 the guard undoes the first B sweep and halves ω until the sweeps descend; when every
// halving comes in that first sweep, the positions are those of a run started at the final ω —
// bit for bit, since each undo restores the positions exactly.
TEST(SmoothSchedule, GuardUndoRestoresThePositionsExactly) {
  const Raw raw = raw_pool_and_drops(2);
  const ShellConstraint c{&raw.grid, 0.05f, 0.1f};
  SmoothOptions o;
  o.steps_a = 4;
  o.steps_b = 4;
  o.steps_free = 1;
  o.batch_vertices = SIZE_MAX;
  o.relax_b = 3.0f;
  std::vector<Vec3f> x = raw.mesh.vertices;
  std::vector<Triangle> t = raw.mesh.triangles;
  const SmoothReport halved = smooth_surface(x, t, &c, o);
  ASSERT_GE(halved.relax_halvings, 1);
  o.relax_b = float(halved.relax_b_final);
  std::vector<Vec3f> y = raw.mesh.vertices;
  t = raw.mesh.triangles;
  const SmoothReport direct = smooth_surface(y, t, &c, o);
  ASSERT_EQ(direct.relax_halvings, 0) << "then no halving came after the first sweep";
  EXPECT_EQ(direct.energy_final, halved.energy_final);
  for (std::size_t i = 0; i < x.size(); ++i)
    for (int k = 0; k < 3; ++k) ASSERT_TRUE(test::same_bits(x[i][k], y[i][k])) << "vertex " << i;
}

}  // namespace
}  // namespace meniscus
