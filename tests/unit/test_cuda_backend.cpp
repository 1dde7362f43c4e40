// The backend choice and the CUDA backend: the CPU side of the code both backends share (the
// fixed summation tree, the marching kernels with explicit tables), the dispatch without a device
// (auto falls back with a warning, cuda is refused), and — with a CUDA device — the device stages
// against the CPU's and full-pipeline parity on synthetic blocks and the real frames. Device
// tests skip visibly ("skipped: no CUDA device") where there is no build or no device.
#include <gtest/gtest.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>

#include "extract/marching_impl.hpp"
#include "meniscus/backend.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "meniscus/reconstruct.hpp"
#include "smooth/constraint_impl.hpp"
#include "smooth/operators_impl.hpp"
#include "support/io_helpers.hpp"
#include "support/test_support.hpp"

#if defined(MENISCUS_HAS_CUDA)
#include "cuda/stages_cuda.hpp"
#include "extract/extract.hpp"
#include "field/anisotropy.hpp"
#include "field/anisotropy_impl.hpp"
#include "field/distance_field.hpp"
#include "field/kernel_field.hpp"
#include "grid/hash_grid.hpp"
#endif

namespace meniscus {
namespace {

bool have_cuda_device() { return !cuda_devices().empty(); }

#define MENISCUS_REQUIRE_CUDA_DEVICE() \
  if (!have_cuda_device()) GTEST_SKIP() << "skipped: no CUDA device"

// --- shared code, CPU side ------------------------------------------------------------------------

TEST(SumTree, MatchesTbbDeterministicReduceBitForBit) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1e3);
  for (std::size_t n : {std::size_t(0), std::size_t(1), std::size_t(4095), std::size_t(4096), std::size_t(4097),
                        std::size_t(12345), std::size_t(100000), std::size_t(1 << 20)}) {
    std::vector<double> v(n);
    for (double& x : v) x = u(rng);
    const double reference = tbb::parallel_deterministic_reduce(
        tbb::blocked_range<std::size_t>(0, n, kSumTreeGrain), 0.0,
        [&](const auto& r, double e) {
          for (std::size_t k = r.begin(); k != r.end(); ++k) e += v[k];
          return e;
        },
        std::plus<>());
    const std::vector<std::size_t> leaves = sum_tree_leaves(n);
    ASSERT_EQ(leaves.front(), 0u);
    ASSERT_EQ(leaves.back(), n);
    std::vector<double> sums;
    for (std::size_t l = 0; l + 1 < leaves.size(); ++l) {
      ASSERT_LE(leaves[l + 1] - leaves[l], kSumTreeGrain);
      double s = 0.0;
      for (std::size_t k = leaves[l]; k < leaves[l + 1]; ++k) s += v[k];
      sums.push_back(s);
    }
    std::size_t next = 0;
    const double tree = sum_tree_combine(0, n, kSumTreeGrain, sums.data(), &next);
    EXPECT_EQ(next, sums.size());
    EXPECT_EQ(tree, reference) << "n = " << n;
  }
}

TEST(MarchingTables, ExplicitTablesGiveTheSameTrianglesAsTheConstexprOnes) {
  const MarchingTables tables = host_marching_tables();
  constexpr TileVertexLookup lookup = make_tile_vertex_lookup(6, 36);
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> bits(0, 255);
  uint8_t masks[216];
  for (int trial = 0; trial < 200; ++trial) {
    for (uint8_t& m : masks) m = uint8_t(bits(rng));
    const uint8_t* centre = masks + (1 * 6 + 1) * 6 + 1;
    uint64_t a[3 * 46 * 2], b[3 * 46 * 2];
    const uint32_t na = march_tile_cell(centre, lookup, 640, a);
    const uint32_t nb = march_tile_cell(centre, lookup, tables.tet_cases, tables.a15_edges, 640, b);
    ASSERT_EQ(na, nb);
    for (uint32_t k = 0; k < 3 * na; ++k) ASSERT_EQ(a[k], b[k]);
    uint64_t c[15], d[15];
    ASSERT_EQ(march_cube_cell(centre, 6, 36, 64, c), march_cube_cell(centre, 6, 36, tables, 64, d));
    uint64_t e[36], f[36];
    ASSERT_EQ(march_kuhn_cell(centre, 6, 36, 64, e), march_kuhn_cell(centre, 6, 36, tables, 64, f));
  }
}

// --- dispatch ---------------------------------------------------------------------------------------

TEST(Backend, ParsesAndPrintsTheBackendNames) {
  EXPECT_EQ(parse_backend("auto"), Backend::automatic);
  EXPECT_EQ(parse_backend("cpu"), Backend::cpu);
  EXPECT_EQ(parse_backend("cuda"), Backend::cuda);
  EXPECT_STREQ(to_string(Backend::automatic), "auto");
  EXPECT_THROW(parse_backend("gpu"), InvalidParameter);
}

TEST(Backend, NoDeviceListSaysWhy) {
  std::string why;
  const std::vector<CudaDeviceInfo> devices = cuda_devices(&why);
  if (devices.empty()) {
    EXPECT_FALSE(why.empty());
    if (!cuda_built()) {
      EXPECT_EQ(why, "built without CUDA");
    }
  } else {
    for (const CudaDeviceInfo& d : devices) {
      EXPECT_FALSE(d.name.empty());
      EXPECT_GT(d.major, 0);
      EXPECT_GT(d.total_memory, 0u);
    }
  }
}

TEST(Backend, CpuBackendIsRecordedInTheStats) {
  Params p;
  p.spacing = 0.1;
  p.backend = Backend::cpu;
  const Result r = reconstruct(test::lattice_block(6, 6, 6, 0.1f), p);
  EXPECT_EQ(r.stats.backend, "cpu");
  EXPECT_NE(stats_to_json(r).find("\"backend\": \"cpu\""), std::string::npos);
}

TEST(Backend, WithoutADeviceCudaIsRefusedAndAutoFallsBack) {
  if (have_cuda_device()) GTEST_SKIP() << "skipped: a CUDA device is present (this checks the no-device path)";
  Params p;
  p.spacing = 0.1;
  p.backend = Backend::cuda;
  const ParticleSet ps = test::lattice_block(6, 6, 6, 0.1f);
  try {
    reconstruct(ps, p);
    FAIL() << "expected ResourceError";
  } catch (const ResourceError& e) {
    EXPECT_NE(std::string(e.what()).find("--backend cuda"), std::string::npos) << e.what();
  }
  p.backend = Backend::automatic;
  const Result r = reconstruct(ps, p);
  EXPECT_EQ(r.stats.backend, "cpu");
  const bool warned = std::any_of(r.stats.warnings.begin(), r.stats.warnings.end(),
                                  [](const std::string& w) { return w.find("backend auto") != std::string::npos; });
  EXPECT_EQ(warned, cuda_built());  // a build without CUDA has nothing to fall back from
}

// The field methods of #7 go to the same dispatch as the distance field (they used to be refused
// on the CUDA backend): without a device, cuda is refused for the missing device and auto falls
// back to the CPU with the same result as --backend cpu.
TEST(Backend, FieldMethodsTakeTheSameDispatchWithoutADevice) {
  if (have_cuda_device()) GTEST_SKIP() << "skipped: a CUDA device is present (this checks the no-device path)";
  ParticleSet ps = test::lattice_block(6, 6, 6, 0.1f, 0.1f);
  Attribute v{"v", 3, false, {}};
  for (std::size_t i = 0; i < ps.size(); ++i) v.values.insert(v.values.end(), {float(i % 5), 0.0f, 0.0f});
  ps.attributes.push_back(v);
  for (FieldMethod m : {FieldMethod::metaball, FieldMethod::sph, FieldMethod::zhu_bridson, FieldMethod::anisotropic}) {
    SCOPED_TRACE(to_string(m));
    Params p;
    p.spacing = 0.1;
    p.field = m;
    p.smooth_particles = 0.5;
    p.velocity_weighted = true;
    p.backend = Backend::cuda;
    try {
      reconstruct(ps, p);
      FAIL() << "expected ResourceError";
    } catch (const ResourceError& e) {
      EXPECT_NE(std::string(e.what()).find("no CUDA backend available"), std::string::npos) << e.what();
    }
    p.backend = Backend::automatic;
    const Result automatic = reconstruct(ps, p);
    p.backend = Backend::cpu;
    const Result cpu = reconstruct(ps, p);
    EXPECT_EQ(automatic.stats.backend, "cpu");
    EXPECT_GT(cpu.mesh.triangles.size(), 0u);
    EXPECT_EQ(automatic.mesh.triangles, cpu.mesh.triangles);
    EXPECT_EQ(automatic.mesh.vertices, cpu.mesh.vertices);
    EXPECT_GT(automatic.params.velocity_reference, 0.0);  // resolved before the dispatch, for both
  }
}

TEST(Backend, CliInfoAndBackendFlag) {
  std::string out;
  ASSERT_EQ(test::run_command(test::cli() + " info", &out), 0);
  EXPECT_NE(out.find("cuda: "), std::string::npos) << out;
  const test::TempDir tmp;
  const std::string input = test::data_file("ply/cube_2366_particles.ply");
  EXPECT_NE(test::run_command(test::cli() + " surface " + input + " -o " + tmp.file("m.ply") + " --backend gpu", &out), 0);
  EXPECT_NE(out.find("gpu"), std::string::npos) << out;
  if (have_cuda_device()) return;
  EXPECT_NE(test::run_command(test::cli() + " surface " + input + " -o " + tmp.file("m.ply") + " --backend cuda", &out), 0);
  EXPECT_NE(out.find("--backend cuda"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(tmp.file("m.ply")));
  ASSERT_EQ(test::run_command(test::cli() + " surface " + input + " -o " + tmp.file("m.ply") + " --backend cpu", &out), 0)
      << out;
}

// --- parity (needs a device) ------------------------------------------------------------------------

struct Comparison {
  std::size_t vertices_cpu = 0, vertices_cuda = 0, triangles_cpu = 0, triangles_cuda = 0;
  double max_difference = 0;  ///< over vertices, in world units
  bool triangles_equal = false;
};

Comparison compare_backends(const ParticleSet& ps, Params p) {
  Comparison c;
  p.backend = Backend::cpu;
  const Result cpu = reconstruct(ps, p);
  p.backend = Backend::cuda;
  const Result gpu = reconstruct(ps, p);
  EXPECT_EQ(gpu.stats.backend, "cuda");
  c.vertices_cpu = cpu.mesh.vertices.size();
  c.vertices_cuda = gpu.mesh.vertices.size();
  c.triangles_cpu = cpu.mesh.triangles.size();
  c.triangles_cuda = gpu.mesh.triangles.size();
  c.triangles_equal = cpu.mesh.triangles == gpu.mesh.triangles;
  if (c.vertices_cpu == c.vertices_cuda)
    for (std::size_t i = 0; i < c.vertices_cpu; ++i)
      c.max_difference = std::max(c.max_difference, double(length(cpu.mesh.vertices[i] - gpu.mesh.vertices[i])));
  return c;
}

void expect_parity(const Comparison& c, double h) {
  EXPECT_EQ(c.vertices_cpu, c.vertices_cuda);
  EXPECT_EQ(c.triangles_cpu, c.triangles_cuda);
  EXPECT_TRUE(c.triangles_equal);
  EXPECT_LE(c.max_difference, 1e-4 * h);
}

TEST(CudaParity, ExtractionOnlyGivesTheSameMesh) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
  for (Extractor e : {Extractor::tiles, Extractor::cubes, Extractor::tetrahedra}) {
    Params p;
    p.spacing = 0.1;
    p.extract = e;
    p.steps_a = p.steps_b = p.steps_free = 0;
    const Comparison c = compare_backends(test::lattice_block(12, 10, 8, 0.1f, 0.1f), p);
    expect_parity(c, 0.05);
    EXPECT_EQ(c.max_difference, 0.0) << to_string(e) << ": the field and the weld are bit-identical";
  }
}

TEST(CudaParity, FullScheduleOnJitteredBlocksBothSolvers) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
  for (SmoothingSolver s : {SmoothingSolver::gauss_seidel, SmoothingSolver::jacobi}) {
    Params p;
    p.spacing = 0.1;
    p.solver = s;
    p.erode = 0.01;
    expect_parity(compare_backends(test::lattice_block(14, 12, 10, 0.1f, 0.1f, 5), p), 0.05);
  }
}

TEST(CudaParity, TransferredAttributesMatch) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
  ParticleSet ps = test::lattice_block(10, 10, 10, 0.1f, 0.1f);
  Attribute a{"speed", 1, false, {}};
  for (std::size_t i = 0; i < ps.size(); ++i) a.values.push_back(float(i % 17));
  ps.attributes.push_back(a);
  Params p;
  p.spacing = 0.1;
  p.transfer = {"speed"};
  p.backend = Backend::cpu;
  const Result cpu = reconstruct(ps, p);
  p.backend = Backend::cuda;
  const Result gpu = reconstruct(ps, p);
  ASSERT_EQ(cpu.mesh.attributes.size(), 1u);
  ASSERT_EQ(gpu.mesh.attributes.size(), 1u);
  ASSERT_EQ(cpu.mesh.attributes[0].values.size(), gpu.mesh.attributes[0].values.size());
  for (std::size_t i = 0; i < cpu.mesh.attributes[0].values.size(); ++i)
    EXPECT_NEAR(cpu.mesh.attributes[0].values[i], gpu.mesh.attributes[0].values[i], 1e-4);
}

// The field methods of issue #7 on both backends: the extraction is bit-identical (the device
// gathers exactly the CPU scatter's sums: KernelField.PerSampleGatherMatchesTheScatterBitForBit
// checks the shared gather on the CPU; the ellipsoids need only correctly rounded sqrt and
// division); the smoothing agrees to rounding (the anisotropic shells use cbrtf, which may differ
// in the last bit between the device and glibc).
TEST(CudaParity, FieldMethodsGiveTheSameMesh) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
  const ParticleSet ps = read_particles(test::data_file("ply/dam_break_frame_9_6859_particles.ply"));
  const double d = estimate_spacing(ps);
  for (FieldMethod m : {FieldMethod::metaball, FieldMethod::sph, FieldMethod::zhu_bridson, FieldMethod::anisotropic}) {
    SCOPED_TRACE(to_string(m));
    Params p;
    p.spacing = d;
    p.field = m;
    p.steps_a = p.steps_b = p.steps_free = 0;
    const Comparison raw = compare_backends(ps, p);
    expect_parity(raw, d / 2);
    EXPECT_EQ(raw.max_difference, 0.0) << "the kernel sums are bit-identical";
    p.steps_a = 40, p.steps_b = 20, p.steps_free = 3;
    expect_parity(compare_backends(ps, p), d / 2);
  }
}

TEST(CudaParity, ParticleSmoothingAndVelocityWeighting) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
  const ParticleSet ps = read_particles(test::data_file("ply/sphysics_dam_break_IPART_29814_particles.ply"));
  Params p;
  p.spacing = estimate_spacing(ps);
  p.smooth_particles = 0.5;
  expect_parity(compare_backends(ps, p), p.spacing / 2);
  p.smooth_particles = -1;
  p.velocity_weighted = true;
  expect_parity(compare_backends(ps, p), p.spacing / 2);
}

#if defined(MENISCUS_HAS_CUDA)
// --- the device's views, run on the host (no device needed) ------------------------------------------

// The device stages call the shared templates through GridView (binary search over the sorted cell
// keys) where the CPU uses its HashGrid. A GridView over the HashGrid's host arrays must answer
// every query of the field methods exactly as the HashGrid does.
TEST(CudaViews, HostGridViewAnswersTheFieldMethodQueriesAsTheHashGrid) {
  const ParticleSet ps = read_particles(test::data_file("ply/double_dam_break_frame_26_4732_particles.ply"));
  const float d = float(estimate_spacing(ps)), R = 2 * d;
  const HashGrid grid(ps.positions, 2 * d);
  cuda::GridView view;
  view.sorted = grid.points();
  view.keys = grid.cell_keys().data();
  view.starts = grid.cell_starts().data();
  view.cells = uint32_t(grid.cell_keys().size());
  view.count = uint32_t(grid.size());
  view.cs = grid.cell_size();
  view.lo = grid.cell_min();
  view.hi = grid.cell_max();

  AnisotropyConstants k;
  k.bulk_variance = yu_turk_bulk_variance(2 * R);
  std::vector<Ellipsoid> shells(grid.size());
  float max_axis = 0;
  for (uint32_t i = 0; i < grid.size(); ++i) {
    const Ellipsoid a = particle_ellipsoid(grid, i, 2 * R, k), b = particle_ellipsoid(view, i, 2 * R, k);
    ASSERT_EQ(std::memcmp(&a, &b, sizeof a), 0) << i;
    const Vec3f c = smoothed_position(grid, i, 2 * d, 0.5f);
    ASSERT_EQ(c, smoothed_position(view, i, 2 * d, 0.5f)) << i;
    shells[i] = unit_volume_shell(a);
    max_axis = std::max(max_axis, shells[i].max_axis);
  }
  // Kernel sums at random points of a few blocks, and the metric-nearest projection.
  KernelParticles kp;
  kp.method = FieldMethod::anisotropic;
  kp.radius = R;
  kp.uniform_volume = d * d * d;
  kp.ellipsoids = shells.data();
  std::mt19937 rng(3);
  std::uniform_int_distribution<uint32_t> pick(0, uint32_t(grid.size() - 1));
  std::uniform_real_distribution<float> u(-1.5f, 1.5f);
  const float off[3] = {0.25f, 0.5f, 0.0f};
  std::size_t projected = 0;
  for (int t = 0; t < 400; ++t) {
    const Vec3f p = grid.point(pick(rng));
    const Vec3i cell = grid_cell_of(p, d);
    const Vec3i origin{cell.x - 3, cell.y - 3, cell.z - 3};
    const float a = kernel_field_sample(grid, kp, R * max_axis, 0.5f, 0.5f, origin, 8, d, cell, off);
    const float b = kernel_field_sample(view, kp, R * max_axis, 0.5f, 0.5f, origin, 8, d, cell, off);
    ASSERT_TRUE(test::same_bits(a, b)) << t;
    const Vec3f x = p + Vec3f{u(rng), u(rng), u(rng)} * d;
    const Vec3f ya = project_vertex_in_metric(grid, shells.data(), x, 0.5f * d, d, max_axis);
    const Vec3f yb = project_vertex_in_metric(view, shells.data(), x, 0.5f * d, d, max_axis);
    ASSERT_EQ(ya, yb) << t;
    projected += !(ya == x);
  }
  EXPECT_GT(projected, 50u);  // the queries moved vertices, not only accepted them
}

// --- device stages against the CPU's (needs a device) --------------------------------------------------

TEST(CudaStages, GridFieldAndExtractionMatchTheCpu) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
  const ParticleSet ps = test::lattice_block(11, 9, 7, 0.1f, 0.1f, 3);
  const float r_outer = 0.1f, h = 0.05f, band = r_outer + 2 * h;
  const HashGrid cpu_grid(ps.positions, 2 * r_outer);
  cuda::DeviceBuffer<Vec3f> points;
  points.upload(ps.positions.data(), ps.size());
  const cuda::DeviceGrid grid = cuda::build_grid(points, uint32_t(ps.size()), 2 * r_outer, cpu_grid.cell_min(),
                                                 cpu_grid.cell_max());
  ASSERT_EQ(grid.cells, cpu_grid.cell_keys().size());
  std::vector<uint32_t> order(ps.size());
  grid.order.download(order.data(), order.size());
  EXPECT_TRUE(std::equal(order.begin(), order.end(), cpu_grid.order().begin()));
  std::vector<uint32_t> starts(grid.cells + 1);
  grid.starts.download(starts.data(), starts.size());
  EXPECT_TRUE(std::equal(starts.begin(), starts.end(), cpu_grid.cell_starts().begin()));

  for (Extractor e : {Extractor::tiles, Extractor::cubes}) {
    SampleLattice lattice;
    lattice.kind = e == Extractor::tiles ? SampleLattice::Kind::a15 : SampleLattice::Kind::cubic;
    lattice.cell_size = e == Extractor::tiles ? 2 * h : h;
    const SparseField cpu_field = distance_field(cpu_grid, lattice, band, band_blocks(cpu_grid, lattice, band));
    std::size_t blocks = 0;
    cuda::DeviceBuffer<uint64_t> keys = cuda::band_blocks(grid, lattice, band, &blocks);
    ASSERT_EQ(blocks, cpu_field.block_count());
    const cuda::DeviceField field = cuda::distance_field(grid, lattice, band, std::move(keys), blocks);
    std::vector<float> values(blocks * kBlockSamples);
    field.values.download(values.data(), values.size());
    for (std::size_t b = 0; b < blocks; ++b)
      for (int k = 0; k < kBlockSamples; ++k)
        ASSERT_TRUE(test::same_bits(values[b * kBlockSamples + std::size_t(k)], cpu_field.block_values(b)[std::size_t(k)]))
            << "block " << b << " sample " << k;
    const ExtractResult cpu_mesh = extract_surface(cpu_field, r_outer, e);
    const cuda::DeviceMesh mesh = cuda::extract_surface(field, r_outer, e);
    ASSERT_EQ(mesh.vertex_count, cpu_mesh.mesh.vertices.size());
    ASSERT_EQ(mesh.triangle_count, cpu_mesh.mesh.triangles.size());
    std::vector<uint32_t> tris(3 * mesh.triangle_count);
    mesh.triangles.download(tris.data(), tris.size());
    EXPECT_TRUE(std::equal(tris.begin(), tris.end(), cpu_mesh.mesh.triangles.data()->data()));
  }
}

TEST(CudaStages, KernelFieldsAndYuTurkFramesMatchTheCpu) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
  const ParticleSet ps = read_particles(test::data_file("ply/double_dam_break_frame_26_4732_particles.ply"));
  const float d = float(estimate_spacing(ps)), R = 2 * d;
  cuda::DeviceBuffer<Vec3f> points;
  points.upload(ps.positions.data(), ps.size());
  // Yu & Turk: ellipsoids and smoothed centres (original order) from a grid of the raw particles.
  const HashGrid raw(ps.positions, 2 * R);
  const cuda::DeviceGrid raw_device =
      cuda::build_grid(points, uint32_t(ps.size()), 2 * R, raw.cell_min(), raw.cell_max());
  AnisotropyConstants k;
  k.bulk_variance = yu_turk_bulk_variance(2 * R);
  cuda::DeviceBuffer<Vec3f> centres_device;
  cuda::DeviceBuffer<Ellipsoid> ellipsoids_device;
  cuda::particle_frames(raw_device, 2 * R, k, 2 * d, 0.5f, &centres_device, &ellipsoids_device);
  const std::vector<Ellipsoid> ellipsoids = yu_turk_ellipsoids(raw, 2 * R, k);
  const std::vector<Vec3f> centres = smooth_positions(raw, 2 * d, 0.5f);
  std::vector<Ellipsoid> e_dev(ps.size());
  std::vector<Vec3f> c_dev(ps.size());
  ellipsoids_device.download(e_dev.data(), e_dev.size());
  centres_device.download(c_dev.data(), c_dev.size());
  for (std::size_t i = 0; i < ps.size(); ++i) {
    ASSERT_LE(length(c_dev[i] - centres[i]), 1e-6f * d) << i;
    ASSERT_NEAR(e_dev[i].max_axis, ellipsoids[i].max_axis, 1e-5f) << i;
    ASSERT_NEAR(e_dev[i].det, ellipsoids[i].det, 1e-4f * ellipsoids[i].det) << i;
  }
  // The kernel fields over the CPU's ellipsoids (uploaded), bit for bit.
  const HashGrid grid(ps.positions, 2 * d);
  const cuda::DeviceGrid grid_device = cuda::build_grid(points, uint32_t(ps.size()), 2 * d, grid.cell_min(), grid.cell_max());
  std::vector<Ellipsoid> sorted(ps.size());
  for (std::size_t i = 0; i < sorted.size(); ++i) sorted[i] = ellipsoids[grid.order()[i]];
  cuda::DeviceBuffer<Ellipsoid> sorted_device;
  sorted_device.upload(sorted.data(), sorted.size());
  for (FieldMethod m : {FieldMethod::metaball, FieldMethod::sph, FieldMethod::zhu_bridson, FieldMethod::anisotropic}) {
    SampleLattice lattice;
    lattice.cell_size = d;
    KernelFieldInput in;
    in.centres = &grid;
    in.method = m;
    in.kernel_radius = R;
    in.iso = m == FieldMethod::zhu_bridson ? d : 0.5f;
    in.uniform_volume = d * d * d;
    in.ellipsoids = sorted;
    const float support = kernel_support(in);
    const SparseField cpu = kernel_field(in, lattice, band_blocks(grid, lattice, support + d));
    std::size_t blocks = 0;
    cuda::DeviceBuffer<uint64_t> keys = cuda::band_blocks(grid_device, lattice, support + d, &blocks);
    ASSERT_EQ(blocks, cpu.block_count());
    KernelParticles kp = kernel_particles(in);
    kp.ellipsoids = m == FieldMethod::anisotropic ? sorted_device.data() : nullptr;
    const cuda::DeviceField f =
        cuda::kernel_field(grid_device, lattice, kp, support, in.iso, kernel_background(in), std::move(keys), blocks);
    std::vector<float> values(blocks * kBlockSamples);
    f.values.download(values.data(), values.size());
    for (std::size_t b = 0; b < blocks; ++b)
      for (int j = 0; j < kBlockSamples; ++j)
        ASSERT_TRUE(test::same_bits(values[b * kBlockSamples + std::size_t(j)], cpu.block_values(b)[std::size_t(j)]))
            << to_string(m) << " block " << b << " sample " << j;
  }
}
#endif

class CudaParityFrame : public ::testing::TestWithParam<std::string> {};

TEST_P(CudaParityFrame, FullScheduleMatchesTheCpu) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
  const ParticleSet ps = read_particles(test::data_file("ply/" + GetParam()));
  Params p;
  p.spacing = estimate_spacing(ps);
  expect_parity(compare_backends(ps, p), p.spacing / 2);
}

INSTANTIATE_TEST_SUITE_P(Frames, CudaParityFrame,
                         ::testing::Values("dam_break_frame_23_24389_particles.ply", "bunny_frame_14_7705_particles.ply",
                                           "cube_2366_particles.ply", "double_dam_break_frame_26_4732_particles.ply",
                                           "free_particles_1000_particles.ply"),
                         [](const auto& test_param) {
                           std::string name = test_param.param.substr(0, test_param.param.find('.'));
                           std::replace(name.begin(), name.end(), '-', '_');
                           return name;
                         });

}  // namespace
}  // namespace meniscus
