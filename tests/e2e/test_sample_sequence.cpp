// The bundled sample sequence (tests/data/sequence): frames of the test suite's own dam-break
// simulation, written as Houdini's .bgeo.sc cache, for the sequence, Houdini and cluster examples
// of the README and docs. The test checks they are what tests/data/README.md says they are: the
// simulation's frames, read back through the .bgeo.sc reader. With MENISCUS_WRITE_SAMPLES=1 it
// writes them (the files are committed; regenerate only when the simulation changes).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>

#include <fmt/format.h>

#include "meniscus/io.hpp"
#include "support/sph_sim.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

/// The sample: 4,096 particles (16 × 32 × 8, spacing 0.025, y up) released in the corner of a
/// 1.2 × 1.0 × 0.2 tank, frames 1..kFrames at 24 frames a second from t = 0.2 s.
constexpr int kFrames = 6;
test::DamBreakSetup sample_setup() {
  test::DamBreakSetup s;
  s.spacing = 0.025f;
  s.nx = 16, s.ny = 32, s.nz = 8;
  s.tank = {1.2f, 1.0f, 0.2f};
  return s;
}

std::string frame_path(int frame) { return test::data_file(fmt::format("sequence/fluid_{:04d}.bgeo.sc", frame)); }

TEST(SampleSequence, TheBundledFramesAreTheSimulationsOutput) {
  const std::vector<ParticleSet> frames = test::simulate_dam_break(sample_setup(), 0.2f, 1.0f / 24, kFrames);
  if (const char* write = std::getenv("MENISCUS_WRITE_SAMPLES"); write && std::string(write) == "1") {
    for (int f = 0; f < kFrames; ++f) {
      TriangleMesh points;  // a mesh without triangles is a point cache
      points.vertices = frames[std::size_t(f)].positions;
      points.attributes = frames[std::size_t(f)].attributes;
      write_mesh(frame_path(f + 1), points);
    }
  }
  for (int f = 0; f < kFrames; ++f) {
    SCOPED_TRACE(frame_path(f + 1));
    ReadReport report;
    const ParticleSet read = read_particles(frame_path(f + 1), {}, &report);
    EXPECT_EQ(report.format, "bgeo.sc (Blosc-compressed binary JSON bgeo)");
    const ParticleSet& simulated = frames[std::size_t(f)];
    ASSERT_EQ(read.size(), simulated.size());
    double worst = 0;
    for (std::size_t i = 0; i < read.size(); ++i) worst = std::max(worst, double(length(read.positions[i] - simulated.positions[i])));
    EXPECT_LT(worst, 1e-5) << "the frame is not the simulation's (positions differ by " << worst << ")";
    const Attribute* v = read.find("v");  // Houdini's name for the velocity
    ASSERT_NE(v, nullptr);
    EXPECT_EQ(v->components, 3);
  }
  // The fluid moves from frame to frame: a sequence, not copies.
  const ParticleSet a = read_particles(frame_path(1)), b = read_particles(frame_path(kFrames));
  double moved = 0;
  for (std::size_t i = 0; i < a.size(); ++i) moved = std::max(moved, double(length(a.positions[i] - b.positions[i])));
  EXPECT_GT(moved, 0.1);
}

}  // namespace
}  // namespace meniscus
