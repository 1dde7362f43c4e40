// The CUDA backend against the CPU, on the device (ctest label `cuda`): its stages bit for bit
// against the CPU's, whole-pipeline parity on jittered blocks and every real frame in tests/data
// (counts equal, extraction bit-identical, positions within 1e-4·h after the full default
// schedule), both solvers, every field method, particle smoothing, velocity weighting, transfer,
// erosion, the out-of-memory fallback, the dispatch, and the CLI end to end with --backend cuda.
// They run on a real GPU, and in every CI run on the emulated device of a MENISCUS_CUDA_EMULATION
// build, where none of them may skip; elsewhere they skip visibly ("skipped: no CUDA device").
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "meniscus/backend.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "meniscus/quality.hpp"
#include "meniscus/reconstruct.hpp"
#include "support/checksums.hpp"
#include "support/io_helpers.hpp"
#include "support/locality.hpp"
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
bool emulated_device() {
  const std::vector<CudaDeviceInfo> d = cuda_devices();
  return !d.empty() && d[0].emulated;
}

#define MENISCUS_REQUIRE_CUDA_DEVICE() \
  if (!have_cuda_device()) GTEST_SKIP() << "skipped: no CUDA device"

/// The real frames in tests/data (their PLY conversions: the same particles).
const std::vector<std::string> kFrames = {
    "dam_break_frame_23_24389_particles.ply",     "dam_break_frame_9_6859_particles.ply",
    "bunny_frame_14_7705_particles.ply",          "double_dam_break_frame_26_4732_particles.ply",
    "cube_2366_particles.ply",                    "free_particles_1000_particles.ply",
    "fluid_250_particles.ply",                    "sphysics_dam_break_IPART_29814_particles.ply"};

// --- whole-pipeline parity ---------------------------------------------------------------------------

struct Comparison {
  std::size_t vertices_cpu = 0, vertices_cuda = 0, triangles_cpu = 0, triangles_cuda = 0;
  double max_difference = 0;  ///< over vertices, in world units
  bool triangles_equal = false;
  Stats stats_cpu, stats_cuda;
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
  c.stats_cpu = cpu.stats;
  c.stats_cuda = gpu.stats;
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
  for (SmoothingSolver s : {SmoothingSolver::chebyshev, SmoothingSolver::jacobi}) {
    Params p;
    p.spacing = 0.1;
    p.solver = s;
    p.erode = 0.01;
    expect_parity(compare_backends(test::lattice_block(14, 12, 10, 0.1f, 0.1f, 5), p), 0.05);
  }
}

TEST(CudaParity, PilesOfCoincidentParticlesGiveTheSameMesh) {
  // The CPU's queries skip the copies a pile makes (a grid of the first particle at each
  // position), the device's visit every one: the same nearest particles, the same mesh.
  MENISCUS_REQUIRE_CUDA_DEVICE();
  ParticleSet ps = test::lattice_block(12, 10, 8, 0.1f, 0.1f, 3);
  const Vec3f corner = ps.positions[0], face = ps.positions[ps.size() / 2 + 5];
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> hair(-1e-7f, 1e-7f);
  for (int k = 0; k < 300; ++k) ps.positions.push_back(corner);
  for (int k = 0; k < 300; ++k) ps.positions.push_back(face + Vec3f{hair(rng), hair(rng), hair(rng)});
  Params p;
  p.spacing = 0.1;
  const Comparison c = compare_backends(ps, p);
  expect_parity(c, 0.05);
  EXPECT_EQ(c.max_difference, 0.0);
  p.field = FieldMethod::anisotropic;
  expect_parity(compare_backends(ps, p), 0.05);
}

// --fill-pinholes adds its bridges before the stages: the device surfaces them as the CPU does
// (a sheet one particle thick whose lanes, 1.6 d wide, leave pinholes where they cross).
TEST(CudaParity, BridgesAcrossPinholesGiveTheSameMesh) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> jitter(-0.02f, 0.02f);
  ParticleSet ps;
  std::vector<float> at(16, 0.0f);
  for (std::size_t i = 1; i < at.size(); ++i) at[i] = at[i - 1] + (i % 4 == 0 ? 0.16f : 0.1f);
  for (const float y : at)
    for (const float x : at) ps.positions.push_back({x + jitter(rng), y + jitter(rng), 0});
  Params p;
  p.spacing = 0.1;
  p.fill_pinholes = true;
  const Comparison c = compare_backends(ps, p);
  expect_parity(c, 0.05);
  EXPECT_GT(c.stats_cpu.pinhole_bridges, 0u);
  EXPECT_EQ(c.stats_cuda.pinhole_bridges, c.stats_cpu.pinhole_bridges);
  EXPECT_EQ(c.stats_cuda.genus, c.stats_cpu.genus);
  p.fill_pinholes = false;
  EXPECT_LT(c.stats_cuda.genus, reconstruct(ps, p).stats.genus);
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

// The field methods on both backends: the extraction is bit-identical (the device gathers exactly
// the CPU scatter's sums: KernelField.PerSampleGatherMatchesTheScatterBitForBit checks the shared
// gather on the CPU; the ellipsoids need only correctly rounded sqrt and division); the smoothing
// agrees to rounding (ties between two nearest particles may go either way: docs/gpu.md).
TEST(CudaParity, FieldMethodsGiveTheSameMesh) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
  const ParticleSet ps = read_particles(test::data_file(test::kSanitized ? "ply/double_dam_break_frame_26_4732_particles.ply"
                                                                         : "ply/dam_break_frame_9_6859_particles.ply"));
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
    p.steps_a = test::kSanitized ? 8 : 40, p.steps_b = test::kSanitized ? 4 : 20, p.steps_free = 3;  // fewer sweeps there
    expect_parity(compare_backends(ps, p), d / 2);
  }
}

// --min-particles runs on the finished mesh of either backend: the same strays go.
TEST(CudaParity, MinParticlesDropsTheSameStrays) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
  // (the free particles have strays too, at a twentieth of the dam break's cost under the sanitizers)
  const ParticleSet ps = read_particles(test::data_file(test::kSanitized ? "ply/free_particles_1000_particles.ply"
                                                                         : "ply/dam_break_frame_23_24389_particles.ply"));
  Params p;
  p.spacing = estimate_spacing(ps);
  p.min_particles = 2;
  p.backend = Backend::cpu;
  const Result cpu = reconstruct(ps, p);
  p.backend = Backend::cuda;
  const Result gpu = reconstruct(ps, p);
  EXPECT_GT(cpu.stats.removed_strays, 0u);
  EXPECT_EQ(gpu.stats.removed_strays, cpu.stats.removed_strays);
  EXPECT_EQ(gpu.mesh.triangles.size(), cpu.mesh.triangles.size());
}

// --clip-box, --clip-cap and --decimate run on the finished mesh of either backend: both cut,
// capped watertight and simplified within the bound, to nearly the same counts (the backends'
// meshes agree to rounding, not bit for bit).
TEST(CudaParity, ClipCapAndDecimateOnBothBackends) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
  const ParticleSet ps = read_particles(test::data_file("ply/dam_break_frame_9_6859_particles.ply"));
  Params p;
  p.spacing = estimate_spacing(ps);
  p.clip_box = {-1.5, 0.06, -0.5, -0.5, 1, 0.5};
  p.clip_cap = true;
  p.decimate = 0.02;
  Result r[2];
  for (int b = 0; b < 2; ++b) {
    p.backend = b == 0 ? Backend::cpu : Backend::cuda;
    r[b] = reconstruct(ps, p);
    EXPECT_EQ(r[b].stats.backend, b == 0 ? "cpu" : "cuda");
    EXPECT_TRUE(analyze_topology(r[b].mesh).watertight()) << to_string(p.backend);
    EXPECT_EQ(r[b].stats.cap_open_edges, 0u);
    EXPECT_GT(r[b].stats.cap_triangles, 100u);
    EXPECT_GT(r[b].stats.decimated_triangles, 1000u);
    EXPECT_LE(r[b].stats.decimate_error, 0.02 * p.spacing);
    for (const Vec3f x : r[b].mesh.vertices) {
      ASSERT_GE(x.y, float(0.06));
      ASSERT_LE(x.x, float(-0.5));
    }
  }
  const double ratio = double(r[1].mesh.triangles.size()) / double(r[0].mesh.triangles.size());
  EXPECT_NEAR(ratio, 1.0, 0.03);
}

// Particle smoothing and velocity weighting on the SPHysics dam break (the double dam break under
// the sanitizers): the same meshes.
TEST(CudaParity, ParticleSmoothingAndVelocityWeighting) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
  const ParticleSet ps = read_particles(test::data_file(test::kSanitized ? "ply/double_dam_break_frame_26_4732_particles.ply"
                                                                         : "ply/sphysics_dam_break_IPART_29814_particles.ply"));
  Params p;
  p.spacing = estimate_spacing(ps);
  p.smooth_particles = 0.5;
  expect_parity(compare_backends(ps, p), p.spacing / 2);
  p.smooth_particles = -1;
  p.velocity_weighted = true;
  expect_parity(compare_backends(ps, p), p.spacing / 2);
}


TEST(CudaParity, ErosionMovesTheSameVerticesAndFlipsTheSameTriangles) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
  const ParticleSet ps = read_particles(test::data_file("ply/cube_2366_particles.ply"));
  Params p;
  p.spacing = estimate_spacing(ps);
  for (double e : {0.2, 0.7}) {  // within h/2, and beyond it (triangles fold)
    p.erode = e * p.spacing;
    p.backend = Backend::cpu;
    const Result cpu = reconstruct(ps, p);
    p.backend = Backend::cuda;
    const Result gpu = reconstruct(ps, p);
    EXPECT_EQ(cpu.stats.flipped_triangles, gpu.stats.flipped_triangles) << e;
    ASSERT_EQ(cpu.mesh.vertices.size(), gpu.mesh.vertices.size());
    double worst = 0;
    for (std::size_t i = 0; i < cpu.mesh.vertices.size(); ++i)
      worst = std::max(worst, double(length(cpu.mesh.vertices[i] - gpu.mesh.vertices[i])));
    EXPECT_LE(worst, 1e-4 * p.spacing / 2) << e;
  }
}

// When a job does not fit in the device's memory, --backend cuda fails with the estimate and
// --backend auto runs on the CPU with a warning; on the emulated device the memory is made small,
// on a real one most of it is taken first.
TEST(CudaFallback, OutOfDeviceMemoryFailsCudaAndAutoRunsOnTheCpu) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
  const ParticleSet ps = read_particles(test::data_file("ply/dam_break_frame_9_6859_particles.ply"));
  Params p;
  p.spacing = estimate_spacing(ps);
#if defined(MENISCUS_CUDA_EMULATION)
  setenv("MENISCUS_EMULATED_DEVICE_MEMORY", "1000000", 1);
  setenv("MENISCUS_EMULATED_DEVICE_FOR_AUTO", "1", 1);
#elif defined(MENISCUS_HAS_CUDA)
  p.backend = Backend::cuda;
  reconstruct(ps, p);  // the kernels loaded (lazily, into device memory) before the memory is taken
  // Every byte the device will give, in halving chunks down to 1 MB: a small frame needs only a
  // few MB, so anything less than all of them may still let it fit.
  std::vector<cuda::DeviceBuffer<char>> hog;
  for (std::size_t chunk = std::size_t(1) << 32; chunk >= (std::size_t(1) << 20); chunk /= 2)
    for (;;) {
      try {
        hog.emplace_back(chunk);
      } catch (const std::exception&) {
        break;
      }
    }
  (void)cudaGetLastError();  // the last refusal is not an error of the run below
#endif
  p.backend = Backend::cuda;
  try {
    reconstruct(ps, p);
    ADD_FAILURE() << "expected ResourceError";
  } catch (const ResourceError& e) {
    EXPECT_NE(std::string(e.what()).find("the CUDA device has"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(" free, "), std::string::npos) << e.what();
  }
  p.backend = Backend::automatic;
  const Result r = reconstruct(ps, p);
#if defined(MENISCUS_CUDA_EMULATION)
  unsetenv("MENISCUS_EMULATED_DEVICE_MEMORY");
  unsetenv("MENISCUS_EMULATED_DEVICE_FOR_AUTO");
#endif
  EXPECT_EQ(r.stats.backend, "cpu");
  EXPECT_GT(r.mesh.triangles.size(), 0u);
  EXPECT_TRUE(std::any_of(r.stats.warnings.begin(), r.stats.warnings.end(), [](const std::string& w) {
    return w.find("CUDA backend failed, running on the CPU instead") != std::string::npos;
  }));
  EXPECT_TRUE(r.stats.device_calls.empty());
}

TEST(CudaDispatch, CudaUsesTheDeviceAutoOnlyARealOne) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
  const ParticleSet ps = test::lattice_block(6, 6, 6, 0.1f);
  Params p;
  p.spacing = 0.1;
  p.backend = Backend::cuda;
  EXPECT_EQ(reconstruct(ps, p).stats.backend, "cuda");
  p.backend = Backend::automatic;
  const Result r = reconstruct(ps, p);
  EXPECT_EQ(r.stats.backend, emulated_device() ? "cpu" : "cuda");
  if (emulated_device()) {
    // auto without a real device runs on the CPU without a word per run: `meniscus info` says why.
    EXPECT_TRUE(r.stats.warnings.empty()) << r.stats.warnings.front();
    std::string out;
    ASSERT_EQ(test::run_command(test::cli() + " info", &out), 0);
    EXPECT_NE(out.find("EMULATED"), std::string::npos) << out;
  }
}

// --close-handles is a pass of the CPU's (mesh/handles.hpp): cuda refuses it by name, auto with
// a device runs the frame on the CPU and says so in a warning.
TEST(CudaDispatch, CloseHandlesRunsOnTheCpuAndSaysSo) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
  const ParticleSet ps = test::lattice_block(6, 6, 6, 0.1f);
  Params p;
  p.spacing = 0.1;
  p.close_handles = true;
  p.backend = Backend::cuda;
  EXPECT_THROW(reconstruct(ps, p), InvalidParameter);
  p.backend = Backend::automatic;
#if defined(MENISCUS_CUDA_EMULATION)
  setenv("MENISCUS_EMULATED_DEVICE_FOR_AUTO", "1", 1);
#endif
  const Result r = reconstruct(ps, p);
#if defined(MENISCUS_CUDA_EMULATION)
  unsetenv("MENISCUS_EMULATED_DEVICE_FOR_AUTO");
#endif
  EXPECT_EQ(r.stats.backend, "cpu");
  EXPECT_TRUE(r.stats.device_calls.empty());
  EXPECT_TRUE(std::any_of(r.stats.warnings.begin(), r.stats.warnings.end(), [](const std::string& w) {
    return w.find("close_handles") != std::string::npos && w.find("ran on the CPU") != std::string::npos;
  }));
}

// --stats records what each stage asked of the device; the counts are those of this run.
TEST(CudaStats, EveryStageReportsItsLaunchesCopiesAndWaits) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
  Params p;
  p.spacing = 0.1;
  p.backend = Backend::cuda;
  const Result r = reconstruct(test::lattice_block(10, 10, 10, 0.1f, 0.1f), p);
  // The device's stages are the last ones (the parameters are resolved on the host first).
  ASSERT_GE(r.stats.stages.size(), r.stats.device_calls.size());
  ASSERT_GE(r.stats.device_calls.size(), 8u);
  const std::size_t host_stages = r.stats.stages.size() - r.stats.device_calls.size();
  for (std::size_t k = 0; k < r.stats.device_calls.size(); ++k) {
    const DeviceStageCalls& c = r.stats.device_calls[k];
    EXPECT_EQ(c.name, r.stats.stages[host_stages + k].name);
    if (c.name == "upload") {
      EXPECT_GT(c.uploads, 0u);
      EXPECT_EQ(c.launches, 0u);
    } else if (c.name == "download") {
      EXPECT_GE(c.downloads, 3u);  // vertices, triangles, normals
    } else {
      EXPECT_GT(c.launches, 0u) << c.name;
    }
  }
  const auto j = nlohmann::json::parse(stats_to_json(r));
  ASSERT_TRUE(j.contains("device_calls"));
  uint64_t launches = 0;
  for (const DeviceStageCalls& c : r.stats.device_calls) launches += c.launches;
  EXPECT_EQ(j["device_calls"]["total"]["launches"].get<uint64_t>(), launches);
}

// What a frame costs the device besides arithmetic: kernel launches (several µs each on a GPU) and
// host waits. The default schedule stays within 1,500 launches and 50 waits per frame at 1M
// particles, and neither grows with the frame (every sweep is one or two kernels, nothing is read
// back per sweep). Measured: 86 launches and 19 waits at 100k and at 1M. Under the sanitizers
// (much slower) the 1M frame is left out: the 100k one and the size-independence stand for it.
TEST(CudaStats, LaunchesAndWaitsPerFrameAreBoundedAndDoNotGrowWithTheFrame) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
#if defined(__SANITIZE_ADDRESS__)
  const std::vector<int> sides = {22, 34};  // 10k, 39k particles
#else
  const std::vector<int> sides = {46, 100};  // 97k, 1M particles
#endif
  std::vector<std::pair<uint64_t, uint64_t>> counts;
  for (int side : sides) {
    Params p;
    p.spacing = 0.01;
    p.backend = Backend::cuda;
    const Result r = reconstruct(test::lattice_block(side, side, side, 0.01f, 0.1f, 5), p);
    ASSERT_EQ(r.stats.backend, "cuda");
    uint64_t launches = 0, waits = 0;
    for (const DeviceStageCalls& c : r.stats.device_calls) launches += c.launches, waits += c.waits;
    std::printf("%zu particles: %llu launches, %llu waits\n", r.stats.particles, (unsigned long long)launches,
                (unsigned long long)waits);
    EXPECT_LE(launches, 1500u) << r.stats.particles << " particles";
    EXPECT_LE(waits, 50u) << r.stats.particles << " particles";
    counts.emplace_back(launches, waits);
  }
  EXPECT_EQ(counts.front(), counts.back()) << "the launches and waits depend on the frame's size";
}

// The CLI end to end on every real frame and a Houdini cache (one small frame under the
// sanitizers): --backend cuda writes the mesh --backend cpu writes (the same vertex and triangle
// counts), and says in its stats that the device ran it.
TEST(CudaCli, EveryRealFrameGivesTheCpuCounts) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
  const test::TempDir tmp;
  std::vector<std::string> inputs;
  for (const std::string& f : kFrames)
    if (!test::kSanitized || f == kFrames[3]) inputs.push_back(test::data_file("ply/" + f));
  if (!test::kSanitized) inputs.push_back(test::data_file("houdini_pop_splatter_13883_points.bgeo.sc"));
  for (const std::string& input : inputs) {
    SCOPED_TRACE(input);
    std::string out;
    for (const char* backend : {"cpu", "cuda"}) {
      ASSERT_EQ(test::run_command(test::cli() + " surface " + input + " -o " + tmp.file(std::string(backend) + ".ply") +
                                      " -q --backend " + backend + " --stats " + tmp.file(std::string(backend) + ".json"),
                                  &out),
                0)
          << out;
    }
    const auto cpu = nlohmann::json::parse(std::ifstream(tmp.file("cpu.json")));
    const auto gpu = nlohmann::json::parse(std::ifstream(tmp.file("cuda.json")));
    EXPECT_EQ(gpu["backend"], "cuda");
    EXPECT_EQ(cpu["vertices"], gpu["vertices"]);
    EXPECT_EQ(cpu["triangles"], gpu["triangles"]);
    EXPECT_EQ(read_mesh(tmp.file("cpu.ply")).triangles, read_mesh(tmp.file("cuda.ply")).triangles);
  }
}

#if defined(MENISCUS_HAS_CUDA)
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

// Every real frame: the extraction bit-identical, then the full default schedule within 1e-4·h
// and its smoothing report bit-identical.
TEST_P(CudaParityFrame, ExtractionIsBitIdenticalAndTheFullScheduleMatches) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
  if (test::large_for_sanitizers(GetParam())) GTEST_SKIP() << "a large frame: the Release run has it";
  const ParticleSet ps = read_particles(test::data_file("ply/" + GetParam()));
  Params p;
  p.spacing = estimate_spacing(ps);
  p.steps_a = p.steps_b = p.steps_free = 0;
  const Comparison raw = compare_backends(ps, p);
  expect_parity(raw, p.spacing / 2);
  EXPECT_EQ(raw.max_difference, 0.0);
  p = Params{};
  p.spacing = estimate_spacing(ps);
  const Comparison full = compare_backends(ps, p);
  expect_parity(full, p.spacing / 2);
  // The smoothing's report: the energies in deterministic_sum's fixed tree (the device's evaluated
  // in parallel, in two launches) the same bits on both backends where the CPU smoothed the mesh
  // in one batch (in several, it adds the batches' sums); the least damping (reduce_index) and
  // the damped count exactly.
  const SmoothingStats& a = full.stats_cpu.smoothing;
  const SmoothingStats& b = full.stats_cuda.smoothing;
  EXPECT_GT(a.energy_start, 0.0);
  if (a.batches <= 1) {
    EXPECT_EQ(a.energy_start, b.energy_start);
    EXPECT_EQ(a.energy_final, b.energy_final);
  } else {
    EXPECT_NEAR(a.energy_start, b.energy_start, 1e-12 * a.energy_start);
    EXPECT_NEAR(a.energy_final, b.energy_final, 1e-12 * a.energy_final);
  }
  EXPECT_EQ(a.relax_b_min, b.relax_b_min);
  EXPECT_EQ(a.damped_vertices, b.damped_vertices);
}

// --- locality (README "A local surface"), as tests/e2e/test_locality.cpp on the CPU -------------

// The largest real frame that holds vertices beyond R_local of a change at each of its ends (the
// CPU covers every frame; the two backends' meshes agree on all of them, CudaParityFrame); the
// default schedule, --field anisotropic and --extract cubes (the default only under the sanitizers).
TEST(CudaLocality, ChangesFartherThanRLocalMoveNoVertexOfARealFrame) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
  for (const char* file : {test::kSanitized ? "dam_break_frame_9_6859_particles.ply" : "dam_break_frame_23_24389_particles.ply"}) {
    const ParticleSet base = read_particles(test::data_file(std::string("ply/") + file));
    for (test::Variant v : {test::Variant::standard, test::Variant::anisotropic, test::Variant::cubes}) {
      if (test::kSanitized && v != test::Variant::standard) continue;  // the default schedule only there
      Params p = resolve_frame_estimates(base, test::variant_params(v));
      p.backend = Backend::cuda;
      const double reach = local_reach(resolve_params(base, p));
      const std::size_t region = test::expect_local(std::string(file) + " " + test::to_string(v), base, p,
                                                    test::frame_changes(base, p.spacing, reach), reach);
      EXPECT_GT(region, 0u);
    }
  }
}

TEST(CudaLocality, RemovingASplashLeavesThePoolBeyondRLocalBitIdentical) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
  const test::SplashScene s = test::synthetic_splash();
  std::vector<std::size_t> splash;
  std::vector<Vec3f> at;
  for (std::size_t i = s.particles.size() - s.splash_count; i < s.particles.size(); ++i)
    splash.push_back(i), at.push_back(s.particles.positions[i]);
  for (test::Variant v : {test::Variant::standard, test::Variant::anisotropic, test::Variant::cubes}) {
    if (test::kSanitized && v == test::Variant::anisotropic) continue;  // (its device path: FieldMethodsGiveTheSameMesh)
    Params p = test::variant_params(v);
    p.spacing = s.d;
    p.backend = Backend::cuda;
    const double reach = local_reach(resolve_params(s.particles, p));
    const test::FrameChange removed{"the splash removed", test::without_particles(s.particles, splash), at};
    EXPECT_GT(test::expect_local(std::string("splash ") + test::to_string(v), s.particles, p, {removed}, reach), 1000u);
  }
}

// The emulated device's meshes of every real frame, bit for bit, against the checksums stored in
// tests/data/checksums.json (tests/e2e/test_mesh_checksums.cpp does the CPU's): a restructuring of
// the backend must leave them as they were. A real GPU may differ in the last bits (its atomics'
// order in the void volumes, ties between nearest particles: docs/gpu.md) and is compared with the
// CPU instead.
TEST_P(CudaParityFrame, EmulatedDeviceMeshesAreTheStoredBits) {
  MENISCUS_REQUIRE_CUDA_DEVICE();
  if (!emulated_device()) GTEST_SKIP() << "a real device: CudaParityFrame compares it with the CPU";
  if (test::large_for_sanitizers(GetParam())) GTEST_SKIP() << "a large frame: the Release run has it";
  const ParticleSet ps = read_particles(test::data_file("ply/" + GetParam()));
  const std::string frame = GetParam().substr(0, GetParam().find('.'));
  for (const test::ChecksumVariant& v : test::checksum_variants()) {
    if (v.params.decimate > 0) continue;  // the post-processing runs on the host: the CPU's test has it
    Params p = v.params;
    p.backend = Backend::cuda;
    if (v.transfer_all)
      for (const Attribute& a : ps.attributes) p.transfer.push_back(a.name);
    const Result r = reconstruct(ps, p);
    ASSERT_EQ(r.stats.backend, "cuda");
    test::expect_stored_checksum("emulated/" + frame + "/" + v.name, r.mesh);
  }
}

INSTANTIATE_TEST_SUITE_P(Frames, CudaParityFrame, ::testing::ValuesIn(kFrames), [](const auto& test_param) {
  return test_param.param.substr(0, test_param.param.find('.'));
});

}  // namespace
}  // namespace meniscus
