// Bad input through the command line: every case exits non-zero with a message naming the file,
// where in it the problem is and what was expected, and leaves no output file behind.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "support/test_support.hpp"

namespace meniscus {
namespace {

using test::cli;
using test::run_command;
using test::TempDir;

struct BadFile {
  std::string name;                        ///< file name (its extension picks the format)
  std::string bytes;                       ///< its content
  std::vector<std::string> message_parts;  ///< all must appear in the error message
};

std::string ply_header(const std::string& format, std::size_t vertices) {
  return "ply\nformat " + format + " 1.0\nelement vertex " + std::to_string(vertices) +
         "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
}

std::string floats(std::initializer_list<float> values) {
  std::string out(values.size() * 4, '\0');
  std::size_t i = 0;
  for (float v : values) std::memcpy(out.data() + 4 * i++, &v, 4);
  return out;
}

std::string prefix(const std::string& data_name, std::size_t bytes) {
  std::ifstream in(test::data_file(data_name), std::ios::binary);
  std::string content((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return content.substr(0, std::min(bytes, content.size()));
}

std::vector<BadFile> bad_files() {
  return {
      {"empty.ply", "", {"empty.ply"}},
      {"wrong_magic.ply", "solid cube\nfacet normal 0 0 1\n", {"wrong_magic.ply", "ply"}},
      {"truncated.ply", ply_header("binary_little_endian", 1000) + floats({0, 0, 0, 1, 1, 1}),
       {"truncated.ply", "byte"}},
      {"huge_count.ply", ply_header("binary_little_endian", 4000000000u) + floats({0, 0, 0}),
       {"huge_count.ply", "4000000000"}},
      {"nan.ply", ply_header("ascii", 3) + "0 0 0\n1 nan 1\n2 2 2\n", {"nan.ply", "particle 1"}},
      {"bad_token.ply", ply_header("ascii", 2) + "0 0 0\n1 one 1\n", {"bad_token.ply", "line 9"}},
      {"partial.xyz", floats({0, 0, 0, 1, 1, 1}) + "\x01\x02\x03\x04\x05", {"partial.xyz", "byte 24"}},
      {"empty.xyz", "", {"empty.xyz"}},
      {"inf.xyz", floats({0, 0, 0, INFINITY, 1, 1}), {"inf.xyz", "particle 1"}},
      {"noformat.txt_unknown", "1 2 3\n", {"noformat.txt_unknown"}},
      {"truncated.vtk", prefix("bunny_frame_14_7705_particles.vtk", 4000), {"truncated.vtk", "byte"}},
      {"truncated.bgeo", prefix("partio_scatter.bgeo", 300), {"truncated.bgeo", "byte"}},
      {"truncated.bgeo.sc", prefix("houdini_pop_splatter_13883_points.bgeo.sc", 5000), {"truncated.bgeo.sc", "byte"}},
      {"truncated.vtu", prefix("fluid_250_particles.vtu", 3000), {"truncated.vtu"}},
      {"bad_token.csv", "x,y,z\n0,0,0\n1,abc,1\n", {"bad_token.csv", "line 3"}},
      {"wrong_magic.npy", "\x93NUMPX\x01\x00", {"wrong_magic.npy"}},
      {"wrong_magic.bgeo", "Bgeo\x00\x00\x00\x00", {"wrong_magic.bgeo"}},
  };
}

TEST(BadInput, RefusedWithLocationAndNoOutput) {
  for (const BadFile& bad : bad_files()) {
    TempDir tmp;
    {
      std::ofstream f(tmp.file(bad.name), std::ios::binary);
      f << bad.bytes;
    }
    std::string out;
    const int rc = run_command(cli() + " surface " + tmp.file(bad.name) + " -o " + tmp.file("out/mesh.ply") +
                                   " --stats " + tmp.file("out/stats.json") + " --preview " + tmp.file("out/p.png"),
                               &out);
    EXPECT_EQ(rc, 1) << bad.name << ": " << out;
    EXPECT_NE(out.find("error"), std::string::npos) << bad.name << ": " << out;
    for (const std::string& part : bad.message_parts)
      EXPECT_NE(out.find(part), std::string::npos) << bad.name << ": expected '" << part << "' in: " << out;
    EXPECT_FALSE(std::filesystem::exists(tmp.file("out"))) << bad.name << ": output written";
    EXPECT_EQ(out.find("Segmentation"), std::string::npos) << out;
  }
}

TEST(BadInput, DropInvalidDropsAndCounts) {
  TempDir tmp;
  {
    std::ofstream f(tmp.file("nan.xyz"), std::ios::binary);
    std::string body;
    // A small lattice block plus two invalid particles.
    for (int k = 0; k < 6; ++k)
      for (int j = 0; j < 6; ++j)
        for (int i = 0; i < 6; ++i) body += floats({0.1f * float(i), 0.1f * float(j), 0.1f * float(k)});
    body += floats({std::nanf(""), 0, 0, 0, INFINITY, 0});
    f << body;
  }
  std::string out;
  EXPECT_NE(run_command(cli() + " surface " + tmp.file("nan.xyz") + " -o " + tmp.file("m.ply"), &out), 0);
  ASSERT_EQ(run_command(cli() + " surface " + tmp.file("nan.xyz") + " -o " + tmp.file("m.ply") + " --drop-invalid", &out),
            0)
      << out;
  EXPECT_NE(out.find("dropped 2 particles"), std::string::npos) << out;
  EXPECT_NE(out.find("216 particles"), std::string::npos) << out;
  EXPECT_TRUE(std::filesystem::exists(tmp.file("m.ply")));
}

}  // namespace
}  // namespace meniscus
