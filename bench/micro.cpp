// meniscus bench — Google Benchmark micro-benchmarks of the pipeline stages on a 100k-particle
// jittered block, with the pipeline's own parameters (h = d/2, r_outer = d, tiles lattice).
#include <benchmark/benchmark.h>

#include <vector>

#include "extract/extract.hpp"
#include "field/distance_field.hpp"
#include "grid/hash_grid.hpp"
#include "scenes.hpp"
#include "smooth/adjacency.hpp"
#include "smooth/operators.hpp"
#include "smooth/smooth.hpp"
#include "mesh/normals.hpp"

namespace {

using namespace meniscus;

// Built once and shared: each benchmark times only its own stage on the previous stages'
// output, exactly as the pipeline hands it on.
struct Fixture {
  bench::Scene scene = bench::make_scene("block", 100000);
  float d = scene.spacing, h = d / 2, r_outer = d, r_inner = d / 2, band = r_outer + 2 * h;
  SampleLattice lattice{SampleLattice::Kind::a15, 2 * h};
  HashGrid grid{scene.particles.positions, 2 * r_outer};
  SparseField field = distance_field(grid, lattice, band, band_blocks(grid, lattice, band));
  TriangleMesh mesh = extract_surface(field, r_outer, Extractor::tiles).mesh;

  static const Fixture& get() {
    static const Fixture f;
    return f;
  }
};

void BM_HashGrid(benchmark::State& state) {
  const Fixture& f = Fixture::get();
  for (auto _ : state) {
    HashGrid g(f.scene.particles.positions, 2 * f.r_outer);
    benchmark::DoNotOptimize(g.cell_keys().data());
  }
  state.SetItemsProcessed(state.iterations() * int64_t(f.scene.particles.size()));
  state.SetLabel("items = particles");
}

void BM_DistanceField(benchmark::State& state) {
  const Fixture& f = Fixture::get();
  for (auto _ : state) {
    SparseField field = distance_field(f.grid, f.lattice, f.band, band_blocks(f.grid, f.lattice, f.band));
    benchmark::DoNotOptimize(field.block_count());
  }
  state.SetItemsProcessed(state.iterations() * int64_t(f.field.block_count() * kBlockSamples));
  state.SetLabel("items = field samples (band_blocks + distance_field)");
}

void BM_ExtractTiles(benchmark::State& state) {
  const Fixture& f = Fixture::get();
  for (auto _ : state) {
    ExtractResult r = extract_surface(f.field, f.r_outer, Extractor::tiles);
    benchmark::DoNotOptimize(r.mesh.vertices.data());
  }
  state.SetItemsProcessed(state.iterations() * int64_t(f.field.block_count() * kBlockSamples));
  state.SetLabel("items = field samples");
}

// The smoothing set-up's parts on the extracted mesh: the adjacency (rows and triangle lists) and
// the cotangent operator W, D, diag(B).
void BM_Adjacency(benchmark::State& state) {
  const Fixture& f = Fixture::get();
  for (auto _ : state) {
    Adjacency adj = build_adjacency(f.mesh.vertices.size(), f.mesh.triangles);
    benchmark::DoNotOptimize(adj.neighbors.data());
  }
  state.SetItemsProcessed(state.iterations() * int64_t(f.mesh.vertices.size()));
  state.SetLabel("items = vertices");
}

void BM_CotanOperator(benchmark::State& state) {
  const Fixture& f = Fixture::get();
  const Adjacency adj = build_adjacency(f.mesh.vertices.size(), f.mesh.triangles);
  for (auto _ : state) {
    CotanOperator op = build_cotan_operator(f.mesh.vertices, f.mesh.triangles, adj, 1e-6f * f.h * f.h);
    benchmark::DoNotOptimize(op.w.data());
  }
  state.SetItemsProcessed(state.iterations() * int64_t(f.mesh.vertices.size()));
  state.SetLabel("items = vertices");
}

// A few sweeps of each phase; items = vertex-iterations, so the rate extrapolates to the
// default 20 + 10 + 3 schedule (the B run includes building the bilaplacian once).
void BM_Smooth(benchmark::State& state) {
  const Fixture& f = Fixture::get();
  SmoothOptions o;
  o.steps_a = int(state.range(0));
  o.steps_b = int(state.range(1));
  o.steps_free = 0;
  const ShellConstraint constraint{&f.grid, f.r_inner, f.r_outer};
  for (auto _ : state) {
    state.PauseTiming();
    std::vector<Vec3f> x = f.mesh.vertices;
    std::vector<Triangle> triangles = f.mesh.triangles;  // renumbered during the call
    state.ResumeTiming();
    smooth_surface(x, triangles, &constraint, o);
    benchmark::DoNotOptimize(x.data());
  }
  state.SetItemsProcessed(state.iterations() * int64_t(f.mesh.vertices.size()) * (o.steps_a + o.steps_b));
  state.SetLabel("items = vertex-iterations");
}

void BM_VertexNormals(benchmark::State& state) {
  const Fixture& f = Fixture::get();
  for (auto _ : state) {
    std::vector<Vec3f> n = vertex_normals(f.mesh.vertices, f.mesh.triangles);
    benchmark::DoNotOptimize(n.data());
  }
  state.SetItemsProcessed(state.iterations() * int64_t(f.mesh.vertices.size()));
  state.SetLabel("items = vertices");
}

BENCHMARK(BM_HashGrid)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_DistanceField)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ExtractTiles)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Adjacency)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_CotanOperator)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Smooth)->Args({5, 0})->Args({0, 5})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_VertexNormals)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
