// The meshes of every real frame, bit for bit, against checksums stored in tests/data/checksums.json:
// a change of the code's structure must leave every mesh as it was. The checksums were made before
// the redesign of the driver and the stages (MENISCUS_WRITE_CHECKSUMS=1 records them again, for
// a change that means to alter meshes: say which and why in its commit).
#include <gtest/gtest.h>

#include <fmt/format.h>

#include "meniscus/io.hpp"
#include "meniscus/reconstruct.hpp"
#include "support/checksums.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

class Checksum : public ::testing::TestWithParam<std::string> {};

TEST_P(Checksum, EveryVariantOfTheFrameIsTheStoredMeshBitForBit) {
  if (test::large_for_sanitizers(GetParam())) GTEST_SKIP() << "a large frame: the Release run has it";
  const ParticleSet ps = read_particles(test::data_file("ply/" + GetParam()));
  const std::string frame = GetParam().substr(0, GetParam().find('.'));
  for (const test::ChecksumVariant& v : test::checksum_variants()) {
    // Decimation costs more than the surfacing itself: the frames under 8,000 particles carry it.
    if (v.params.decimate > 0 && ps.size() >= 8000) continue;
    Params p = v.params;
    if (v.transfer_all)
      for (const Attribute& a : ps.attributes) p.transfer.push_back(a.name);
    const Result r = reconstruct(ps, p);
    test::expect_stored_checksum(fmt::format("cpu/{}/{}", frame, v.name), r.mesh);
  }
}

INSTANTIATE_TEST_SUITE_P(Data, Checksum, ::testing::ValuesIn(test::real_frames()),
                         [](const auto& test_param) { return test_param.param.substr(0, test_param.param.find('.')); });

}  // namespace
}  // namespace meniscus
