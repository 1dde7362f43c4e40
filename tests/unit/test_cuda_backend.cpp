// The backend choice and the CUDA backend: the CPU side of the code both backends share (the
// fixed summation tree, the marching kernels with explicit tables), the dispatch without a device
// (auto falls back with a warning, cuda is refused), and the device's views run on the host. The
// device's own tests are tests/cuda/ (ctest label `cuda`).
#include <gtest/gtest.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>

#include "extract/marching_impl.hpp"
#include "common/primitives.hpp"
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

/// A device --backend auto would use: a real one (not the emulated device of a test build).
bool have_real_cuda_device() {
  const std::vector<CudaDeviceInfo> d = cuda_devices();
  return std::any_of(d.begin(), d.end(), [](const CudaDeviceInfo& i) { return !i.emulated; });
}

// --- shared code, CPU side ------------------------------------------------------------------------

// deterministic_sum is the tree of tbb::parallel_deterministic_reduce (the reference the device's
// version, tests/cuda/test_device.cpp, is held to), whatever the threads.
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
    const double tree = deterministic_sum(Host{}, n, kSumTreeGrain, [&](std::size_t k) { return v[k]; });
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
      if (!d.emulated) {
        EXPECT_GT(d.major, 0);
      }
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

// Without a real device: cuda is refused (unless the build's emulated device is there) and auto
// runs on the CPU without a word each run (`meniscus info` says why there is no device).
TEST(Backend, WithoutADeviceCudaIsRefusedAndAutoFallsBack) {
  if (have_real_cuda_device()) GTEST_SKIP() << "skipped: a CUDA device is present (this checks the no-device path)";
  Params p;
  p.spacing = 0.1;
  p.backend = Backend::cuda;
  const ParticleSet ps = test::lattice_block(6, 6, 6, 0.1f);
  if (cuda_devices().empty()) {
    try {
      reconstruct(ps, p);
      FAIL() << "expected ResourceError";
    } catch (const ResourceError& e) {
      EXPECT_NE(std::string(e.what()).find("--backend cuda"), std::string::npos) << e.what();
    }
  }
  p.backend = Backend::automatic;
  const Result r = reconstruct(ps, p);
  EXPECT_EQ(r.stats.backend, "cpu");
  EXPECT_TRUE(r.stats.warnings.empty()) << r.stats.warnings.front();
}

// The field methods of #7 go to the same dispatch as the distance field (none is refused for its
// field on the CUDA backend): without a device, cuda is refused for the missing device and auto
// falls back to the CPU with the same result as --backend cpu.
TEST(Backend, FieldMethodsTakeTheSameDispatchWithoutADevice) {
  if (have_real_cuda_device()) GTEST_SKIP() << "skipped: a CUDA device is present (this checks the no-device path)";
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
    if (cuda_devices().empty()) {
      try {
        reconstruct(ps, p);
        FAIL() << "expected ResourceError";
      } catch (const ResourceError& e) {
        EXPECT_NE(std::string(e.what()).find("no CUDA backend available"), std::string::npos) << e.what();
      }
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
  if (!cuda_devices().empty()) return;
  EXPECT_NE(test::run_command(test::cli() + " surface " + input + " -o " + tmp.file("m.ply") + " --backend cuda", &out), 0);
  EXPECT_NE(out.find("--backend cuda"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(tmp.file("m.ply")));
  ASSERT_EQ(test::run_command(test::cli() + " surface " + input + " -o " + tmp.file("m.ply") + " --backend cpu", &out), 0)
      << out;
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
    const Vec3f from = x + Vec3f{u(rng), u(rng), u(rng)} * (0.5f * d);  // where the move began
    const Vec3f ya = project_vertex_in_metric(grid, shells.data(), x, from, 0.5f * d, d, max_axis);
    const Vec3f yb = project_vertex_in_metric(view, shells.data(), x, from, 0.5f * d, d, max_axis);
    ASSERT_EQ(ya, yb) << t;
    projected += !(ya == x);
  }
  EXPECT_GT(projected, 50u);  // the queries moved vertices, not only accepted them
}

#endif

}  // namespace
}  // namespace meniscus
