// The meshes of every real frame, bit for bit, against checksums stored in tests/data/checksums.json:
// a change of the code's structure must leave every mesh as it was. The checksums were made before
// the redesign of the driver and the stages (MENISCUS_WRITE_CHECKSUMS=1 records them again, for
// a change that means to alter meshes: say which and why in its commit).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include <fmt/format.h>

#include "meniscus/io.hpp"
#include "meniscus/reconstruct.hpp"
#include "support/checksums.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

std::vector<std::string> frames() {
  std::vector<std::string> out;
  for (const auto& e : std::filesystem::directory_iterator(test::data_file("ply")))
    if (e.path().extension() == ".ply") out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

class Checksum : public ::testing::TestWithParam<std::string> {};

TEST_P(Checksum, EveryVariantOfTheFrameIsTheStoredMeshBitForBit) {
  if (test::large_for_sanitizers(GetParam())) GTEST_SKIP() << "a large frame: the Release run has it";
  const ParticleSet ps = read_particles(test::data_file("ply/" + GetParam()));
  const std::string frame = GetParam().substr(0, GetParam().find('.'));
  for (const test::ChecksumVariant& v : test::checksum_variants()) {
    // Decimation takes 9-15x the surfacing: the frames under 8,000 particles carry it.
    if (v.params.decimate > 0 && ps.size() >= 8000) continue;
    Params p = v.params;
    if (v.transfer_all)
      for (const Attribute& a : ps.attributes) p.transfer.push_back(a.name);
    const Result r = reconstruct(ps, p);
    const std::string key = fmt::format("cpu/{}/{}", frame, v.name);
    const uint64_t sum = test::mesh_checksum(r.mesh);
    if (test::writing_checksums()) {
      test::record_checksum(key, sum);
      continue;
    }
    const uint64_t stored = test::stored_checksum(key);
    ASSERT_NE(stored, 0u) << "no stored checksum for " << key;
    EXPECT_EQ(fmt::format("{:016x}", sum), fmt::format("{:016x}", stored))
        << key << ": the mesh is not the stored one (" << r.mesh.vertices.size() << " vertices, "
        << r.mesh.triangles.size() << " triangles)";
  }
}

INSTANTIATE_TEST_SUITE_P(Data, Checksum, ::testing::ValuesIn(frames()), [](const auto& test_param) {
  return test_param.param.substr(0, test_param.param.find('.'));
});

}  // namespace
}  // namespace meniscus
