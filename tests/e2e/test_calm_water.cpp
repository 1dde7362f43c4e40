// Calm water that does not shimmer: `meniscus surface` of a sequence smooths each frame's particles
// in time with the frames either side (meniscus/temporal.hpp), so a block of water at rest whose
// particles jiggle from frame to frame comes out steady, a block moving steadily as it was, and
// every chunk of a sequence gives the meshes of the whole run byte for byte.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <numeric>
#include <random>

#include <fmt/format.h>

#include "meniscus/io.hpp"
#include "meniscus/quality.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

constexpr float kD = 0.1f;
constexpr int kFrames = 7;

/// A block of 20 × 20 × 6 particles d apart (each jittered ±0.1 d once), frame f (1-based) with
/// `move(f)` added to every particle and, per frame, independent noise of σ = `noise` d: an SPH
/// tank at rest jiggles like that. Each frame is written in its own order, with an "id".
void write_block(const test::TempDir& dir, const std::function<Vec3f(int)>& move, float noise) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> jitter(-0.1f * kD, 0.1f * kD);
  std::vector<Vec3f> base;
  for (int z = 0; z < 6; ++z)
    for (int y = 0; y < 20; ++y)
      for (int x = 0; x < 20; ++x)
        base.push_back(Vec3f{float(x), float(y), float(z)} * kD + Vec3f{jitter(rng), jitter(rng), jitter(rng)});
  std::normal_distribution<float> e(0.0f, noise * kD);
  for (int f = 1; f <= kFrames; ++f) {
    std::vector<std::size_t> order(base.size());
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), rng);
    TriangleMesh points;  // a mesh without triangles is a point file
    Attribute ids{"id", 1, true, {}};
    for (const std::size_t i : order) {
      points.vertices.push_back(base[i] + move(f) + Vec3f{e(rng), e(rng), e(rng)});
      ids.values.push_back(float(i));
    }
    points.attributes.push_back(std::move(ids));
    write_mesh(dir.file(fmt::format("block_{:04d}.ply", f)), points);
  }
}

/// The output with its wrapped lines joined.
std::string joined(const std::string& text) {
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '\n') {
      out += text[i];
      continue;
    }
    out += ' ';
    while (i + 1 < text.size() && text[i + 1] == ' ') ++i;
  }
  return out;
}

std::string run(const test::TempDir& dir, const std::string& out, const std::string& options) {
  std::string output;
  const std::string command = fmt::format("{} surface '{}' -o '{}' --spacing {} {}", test::cli(), dir.file("block_####.ply"),
                                          dir.file(out + "/m_####.ply"), kD, options);
  EXPECT_EQ(test::run_command(command, &output), 0) << command << "\n" << output;
  return joined(output);
}

/// The jitter (in d) of the inner frames whose neighbours were smoothed too (3 … kFrames − 2),
/// the median of their medians.
double jitter(const test::TempDir& dir, const std::string& out) {
  std::vector<TriangleMesh> m;
  for (int f = 2; f <= kFrames - 1; ++f) m.push_back(read_mesh(dir.file(fmt::format("{}/m_{:04d}.ply", out, f))));
  std::vector<double> medians;
  for (std::size_t k = 1; k + 1 < m.size(); ++k)
    medians.push_back(surface_jitter(m[k - 1], m[k], m[k + 1], kJitterPoints, uint32_t(k), 4 * kD).median / kD);
  std::sort(medians.begin(), medians.end());
  return medians[medians.size() / 2];
}

std::string bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(CalmWater, AJigglingBlockAtRestComesOutSteadyAndKeepsItsParticlesInside) {
  test::TempDir dir;
  write_block(dir, [](int) { return Vec3f{0, 0, 0}; }, 0.05f);
  const std::string summary = run(dir, "smoothed", "");
  run(dir, "own", "-q --temporal-smoothing 0");
  const double smoothed = jitter(dir, "smoothed"), own = jitter(dir, "own");
  std::printf("[ measured ] jitter of a block at rest, noise 0.05 d: %.4f d from the frames' own positions, %.4f d "
              "smoothed in time\n", own, smoothed);
  EXPECT_GT(own, 0.010);       // the shimmer the frames' own positions give
  EXPECT_LT(smoothed, 0.007);  // [1 2 1] / 4 takes the noise's second difference to a quarter
  EXPECT_LT(smoothed, 0.5 * own);
  EXPECT_NE(summary.find("temporal smoothing (w = 0.25, particles matched by 'id' in the frames either side): 5 of 7 "
                         "frames; from their own positions; frame 1: frame 0 is not on disk"),
            std::string::npos)
      << summary;
  // The surface still holds every particle of the file (the shift is at most r_inner / 2).
  std::string out;
  ASSERT_EQ(test::run_command(fmt::format("{} inspect '{}' --particles '{}' --spacing {} --json", test::cli(),
                                          dir.file("smoothed/m_0004.ply"), dir.file("block_0004.ply"), kD),
                              &out),
            0)
      << out;
  EXPECT_EQ(nlohmann::json::parse(out)["particles"]["outside_surface"], 0) << out;
}

TEST(CalmWater, SteadyMotionIsKeptAndEveryChunkGivesTheWholeRunsMeshes) {
  test::TempDir dir;
  write_block(dir, [](int f) { return Vec3f{0.37f, 0.23f, 0.11f} * (kD * float(f)); }, 0.0f);
  run(dir, "whole", fmt::format("-q --stats '{}'", dir.file("whole/s_####.json")));
  run(dir, "own", "-q --temporal-smoothing 0");
  // Moving steadily, the particles stay where they are (to rounding): the jitter is the surface's own.
  const auto stats = nlohmann::json::parse(bytes(dir.file("whole/s_0004.json")));
  EXPECT_TRUE(stats["temporal_smoothing"]["applied"].get<bool>());
  EXPECT_EQ(stats["temporal_smoothing"]["matched"], 2400);
  EXPECT_LT(stats["temporal_smoothing"]["max_shift"].get<double>(), 1e-5 * kD);
  EXPECT_GT(stats["stages"]["temporal"].get<double>(), 0.0);
  const auto first = nlohmann::json::parse(bytes(dir.file("whole/s_0001.json")));
  EXPECT_FALSE(first["temporal_smoothing"]["applied"].get<bool>());
  const double smoothed = jitter(dir, "whole"), own = jitter(dir, "own");
  std::printf("[ measured ] jitter of a block moving steadily: %.4f d own, %.4f d smoothed\n", own, smoothed);
  EXPECT_NEAR(smoothed, own, 0.1 * own);
  // Chunks (a job array's tasks) read the frames either side from disk as the whole run does.
  run(dir, "chunks", "-q --frames 1-3");
  run(dir, "chunks", "-q --frames 4-7 --jobs 2");
  for (int f = 1; f <= kFrames; ++f) {
    SCOPED_TRACE(f);
    const std::string whole = bytes(dir.file(fmt::format("whole/m_{:04d}.ply", f)));
    EXPECT_FALSE(whole.empty());
    EXPECT_EQ(whole, bytes(dir.file(fmt::format("chunks/m_{:04d}.ply", f))));
  }
}

// A real SPlisHSPlasH frame between its neighbours (tests/data/sph_dambreak, frames 19-21: the
// particles in another order in every file): every particle matched by id, the shifts small beside
// d and the surface holding every particle of the file.
TEST(CalmWater, ARealFrameIsMatchedByIdAndKeepsEveryParticleInside) {
  test::TempDir dir;
  std::string out;
  const std::string command = fmt::format(
      "{} surface '{}' -o '{}' --frames 20 --spacing 0.03 --stats '{}'", test::cli(),
      test::data_file("sph_dambreak/ParticleData_Fluid_####.bgeo"), dir.file("m_####.ply"), dir.file("s_####.json"));
  ASSERT_EQ(test::run_command(command, &out), 0) << out;
  EXPECT_NE(joined(out).find("temporal smoothing (w = 0.25, particles matched by 'id' in the frames either side): 1 of "
                             "1 frames"),
            std::string::npos)
      << out;
  const auto stats = nlohmann::json::parse(bytes(dir.file("s_0020.json")))["temporal_smoothing"];
  EXPECT_TRUE(stats["applied"].get<bool>());
  EXPECT_EQ(stats["matched"], 32768);
  const double d = 0.03;
  std::printf("[ measured ] frame 20: mean shift %.4f d, largest %.4f d, %d cut to r_inner / 2\n",
              stats["mean_shift"].get<double>() / d, stats["max_shift"].get<double>() / d, stats["clamped"].get<int>());
  EXPECT_LT(stats["mean_shift"].get<double>(), 0.1 * d);
  EXPECT_LE(stats["max_shift"].get<double>(), 0.25 * d * (1 + 1e-6));
  ASSERT_EQ(test::run_command(fmt::format("{} inspect '{}' --particles '{}' --spacing 0.03 --json", test::cli(),
                                          dir.file("m_0020.ply"),
                                          test::data_file("sph_dambreak/ParticleData_Fluid_0020.bgeo")),
                              &out),
            0)
      << out;
  EXPECT_EQ(nlohmann::json::parse(out)["particles"]["outside_surface"], 0) << out;
}

TEST(CalmWater, FramesWithoutIdsAreSurfacedFromTheirOwnPositionsAndTheSummarySaysSo) {
  test::TempDir dir;
  std::string out;
  const std::string command =
      fmt::format("{} surface '{}' -o '{}' --frames 1-3 --stats '{}'", test::cli(),
                  test::data_file("sequence/fluid_####.bgeo.sc"), dir.file("m_####.ply"), dir.file("s_####.json"));
  ASSERT_EQ(test::run_command(command, &out), 0) << out;
  out = joined(out);
  EXPECT_NE(out.find("0 of 3 frames; from their own positions; frame 1: frame 0 is not on disk"), std::string::npos)
      << out;
  EXPECT_NE(out.find("frames 2-3: no 'id' attribute in the current frame"), std::string::npos) << out;
  // Without ids of its own a frame does not read its neighbours.
  const auto stats = nlohmann::json::parse(bytes(dir.file("s_0002.json")));
  EXPECT_FALSE(stats["temporal_smoothing"]["applied"].get<bool>());
  EXPECT_FALSE(stats["stages"].contains("temporal")) << stats["stages"];
  // A neighbour that does not read leaves the frame its own positions; the frame itself is surfaced.
  write_block(dir, [](int) { return Vec3f{0, 0, 0}; }, 0.05f);
  std::filesystem::resize_file(dir.file("block_0003.ply"), 200);
  out = run(dir, "broken", "--frames 2");
  EXPECT_TRUE(std::filesystem::exists(dir.file("broken/m_0002.ply")));
  EXPECT_NE(out.find("0 of 1 frames; from their own positions; frame 2: a neighbouring frame does not read ("),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("block_0003.ply"), std::string::npos) << out;
}

}  // namespace
}  // namespace meniscus
