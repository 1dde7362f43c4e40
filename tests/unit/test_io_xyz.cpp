// meniscus tests — raw float32 XYZ reader and the format table.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <vector>
#include <zlib.h>

#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "support/io_helpers.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

using test::write_file;

using test::TempDir;

// Little-endian float32 triples, as splashsurf writes them on x86.
std::string xyz_bytes(const std::vector<Vec3f>& points) {
  std::string out;
  for (const Vec3f& p : points)
    for (int c = 0; c < 3; ++c) {
      const uint32_t bits = std::bit_cast<uint32_t>(p[c]);
      for (int b = 0; b < 4; ++b) out.push_back(char((bits >> (8 * b)) & 0xffu));
    }
  return out;
}

template <class F>
std::string format_error_message(F&& body) {
  try {
    body();
  } catch (const FormatError& e) {
    return e.what();
  } catch (const std::exception& e) {
    return std::string("wrong exception: ") + e.what();
  }
  return "no exception";
}

const std::vector<Vec3f> kPoints = {{0.1f, 0.2f, 0.3f}, {-1e-39f, -0.0f, 3.4e38f}, {1, 2, 3}, {7.25f, -8.5f, 1e-3f}};

TEST(XyzReader, ReadsPositionsBitExact) {
  TempDir dir;
  const std::string path = dir.file("points.xyz");
  write_file(path, xyz_bytes(kPoints));
  ReadReport report;
  const ParticleSet p = read_particles(path, {}, &report);
  EXPECT_EQ(report.format, "xyz (raw float32)");
  EXPECT_TRUE(p.attributes.empty());
  ASSERT_EQ(p.size(), kPoints.size());
  for (std::size_t i = 0; i < kPoints.size(); ++i)
    for (int c = 0; c < 3; ++c)
      EXPECT_EQ(std::bit_cast<uint32_t>(p.positions[i][c]), std::bit_cast<uint32_t>(kPoints[i][c])) << i << "," << c;
}

TEST(XyzReader, ExtensionIsCaseInsensitiveAndGzipIsDetected) {
  TempDir dir;
  const std::string upper = dir.file("POINTS.XYZ");
  write_file(upper, xyz_bytes(kPoints));
  EXPECT_EQ(read_particles(upper).size(), kPoints.size());

  const std::string gz = dir.file("points.xyz.gz");
  gzFile f = gzopen(gz.c_str(), "wb");
  ASSERT_NE(f, nullptr);
  const std::string bytes = xyz_bytes(kPoints);
  ASSERT_EQ(gzwrite(f, bytes.data(), unsigned(bytes.size())), int(bytes.size()));
  ASSERT_EQ(gzclose(f), Z_OK);
  ReadReport report;
  const ParticleSet p = read_particles(gz, {}, &report);
  EXPECT_EQ(report.format, "xyz (raw float32), gzip-compressed");
  EXPECT_EQ(p.positions[3], kPoints[3]);
}

TEST(XyzReader, SizeNotAMultipleOf12NamesSizeAndOffset) {
  TempDir dir;
  const std::string path = dir.file("partial.xyz");
  write_file(path, xyz_bytes(kPoints) + std::string(5, '\0'));  // 48 + 5 bytes
  const std::string what = format_error_message([&] { read_particles(path); });
  for (const char* fragment : {"byte 48", "file size 53 bytes", "not a multiple of 12", "trailing partial record of 5"})
    EXPECT_NE(what.find(fragment), std::string::npos) << fragment << " not in: " << what;
  EXPECT_NE(what.find(path), std::string::npos) << what;
}

TEST(XyzReader, EmptyFileHasNoParticles) {
  TempDir dir;
  const std::string path = dir.file("empty.xyz");
  write_file(path, "");
  const std::string what = format_error_message([&] { read_particles(path); });
  EXPECT_NE(what.find(path), std::string::npos) << what;
  EXPECT_NE(what.find("no particles"), std::string::npos) << what;
}

TEST(XyzReader, NonFiniteCoordinatesAreRefusedOrDropped) {
  TempDir dir;
  const std::string path = dir.file("nan.xyz");
  std::vector<Vec3f> points = kPoints;
  points[2].y = std::numeric_limits<float>::quiet_NaN();
  write_file(path, xyz_bytes(points));
  const std::string what = format_error_message([&] { read_particles(path); });
  EXPECT_NE(what.find(path + ": particle 2: expected finite coordinates"), std::string::npos) << what;

  ReadOptions options;
  options.drop_invalid = true;
  ReadReport report;
  const ParticleSet p = read_particles(path, options, &report);
  EXPECT_EQ(report.dropped_invalid, 1u);
  EXPECT_EQ(p.positions, (std::vector<Vec3f>{kPoints[0], kPoints[1], kPoints[3]}));
}

TEST(XyzReader, FormatListsComeFromTheTable) {
  const std::vector<std::string> particles = particle_formats();
  EXPECT_NE(std::find(particles.begin(), particles.end(), ".ply"), particles.end());
  EXPECT_NE(std::find(particles.begin(), particles.end(), ".xyz"), particles.end());
  EXPECT_EQ(mesh_formats(), (std::vector<std::string>{".ply", ".bgeo", ".bgeo.sc", ".sc", ".obj", ".vtk", ".vtp", ".usda"}));
  for (const char* ext : {".bgeo", ".sc", ".vtk", ".vtu", ".vtp", ".npy", ".csv", ".txt"})
    EXPECT_NE(std::find(particles.begin(), particles.end(), ext), particles.end()) << ext;
}

}  // namespace
}  // namespace meniscus
