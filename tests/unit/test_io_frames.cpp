// meniscus tests — the real frames converted to PLY (tests/data/ply) load with the expected counts.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <string>

#include "meniscus/io.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

// The count in a frame's name ("…_24389_particles"), except where the name is known to be wrong.
std::size_t expected_count(const std::string& stem) {
  static const std::map<std::string, std::size_t> misnamed = {{"bunny_frame_14_7705_particles", 7706}};
  if (auto it = misnamed.find(stem); it != misnamed.end()) return it->second;
  return stem.ends_with("_particles") ? test::count_before(stem, "_particles") : 0;
}

TEST(RealFrames, CountInANameIsTheNumberBeforeTheSuffix) {
  EXPECT_EQ(test::count_before("dam_break_frame_23_24389_particles.ply", "_particles."), 24389u);
  EXPECT_EQ(test::count_before("free_particles_1000_particles", "_particles"), 1000u);  // the first "_particles" has no count
  EXPECT_EQ(test::count_before("cube_2366_points.bgeo", "_particles."), 0u);
  EXPECT_EQ(test::count_before("x2366_particles.ply", "_particles."), 0u);  // no "_" before the digits
  EXPECT_EQ(test::count_before("_particles.ply", "_particles."), 0u);
}

TEST(RealFrames, EveryConvertedFrameLoadsWithItsParticleCount) {
  const std::filesystem::path dir = test::data_file("ply");
  std::size_t files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".ply") continue;
    ++files;
    const std::string stem = entry.path().stem().string();
    SCOPED_TRACE(stem);
    const std::size_t expected = expected_count(stem);
    ASSERT_GT(expected, 0u) << "no particle count in the name";
    ReadReport report;
    const ParticleSet particles = read_particles(entry.path().string(), {}, &report);
    EXPECT_EQ(report.format, "ply (binary little endian)");
    EXPECT_EQ(particles.size(), expected);
    EXPECT_EQ(report.dropped_invalid, 0u);
    std::size_t non_finite = 0;
    for (const Vec3f& p : particles.positions)
      non_finite += !(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z));
    EXPECT_EQ(non_finite, 0u);
    EXPECT_NO_THROW(particles.validate());
  }
  EXPECT_EQ(files, 8u);  // all converted frames are present, so the loop cannot pass vacuously
}

TEST(RealFrames, SimulatorAttributesSurviveTheConversion) {
  const ParticleSet frame = read_particles(test::data_file("ply/dam_break_frame_9_6859_particles.ply"));
  const Attribute* velocity = frame.find("velocity");
  ASSERT_NE(velocity, nullptr);
  EXPECT_EQ(velocity->components, 3);
  EXPECT_FALSE(velocity->integer);
  const Attribute* id = frame.find("id");
  ASSERT_NE(id, nullptr);
  EXPECT_TRUE(id->integer);
  // SPlisHSPlasH ids are 0 … n-1, each once.
  std::vector<bool> seen(frame.size(), false);
  for (const float v : id->values) {
    ASSERT_GE(v, 0.0f);
    ASSERT_LT(v, float(frame.size()));
    EXPECT_FALSE(seen[std::size_t(v)]) << v;
    seen[std::size_t(v)] = true;
  }
  const Attribute* density = frame.find("density");
  ASSERT_NE(density, nullptr);
  EXPECT_EQ(density->components, 1);

  const ParticleSet sph = read_particles(test::data_file("ply/sphysics_dam_break_IPART_29814_particles.ply"));
  for (const char* name : {"velocity", "density", "pressure", "mass"}) EXPECT_NE(sph.find(name), nullptr) << name;
}

}  // namespace
}  // namespace meniscus
