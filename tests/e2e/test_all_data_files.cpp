// Every real particle file in tests/data (the frames other projects' simulators wrote) reads
// with the particle count its name gives, whatever its format.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "meniscus/io.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

TEST(AllDataFiles, ReadWithTheCountInTheirName) {
  std::size_t checked = 0;
  for (const auto& entry : std::filesystem::directory_iterator(test::data_file(""))) {
    if (!entry.is_regular_file()) continue;
    const std::string name = entry.path().filename().string();
    // "..._<count>_particles.<ext>" or "..._<count>_points.<ext>"
    std::size_t expected = test::count_before(name, "_particles.");
    if (expected == 0) expected = test::count_before(name, "_points.");
    if (expected == 0) continue;
    if (name.rfind("bunny_frame_14_7705", 0) == 0) expected = 7706;  // the file holds one more than its name says
    ReadOptions options;
    if (name.find("IPART") != std::string::npos) options.columns = {"x", "y", "z", "vx", "vy", "vz", "rho", "p", "mass"};
    const ParticleSet ps = read_particles(entry.path().string(), options);
    EXPECT_EQ(ps.size(), expected) << name;
    for (const Vec3f& p : ps.positions)
      ASSERT_TRUE(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) << name;
    ++checked;
  }
  EXPECT_EQ(checked, 9u) << "expected the 9 counted frames of tests/data";
}

}  // namespace
}  // namespace meniscus
