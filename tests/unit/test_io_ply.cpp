// meniscus tests — PLY reader and writer: exact round trips, every encoding and scalar type, bad input.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <sstream>
#include <string>
#include <vector>
#include <zlib.h>

#include <fmt/format.h>

#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "support/io_helpers.hpp"
#include "support/test_support.hpp"
#include "io/ply.hpp"

namespace meniscus {
namespace {

using test::write_file;
using test::read_file;
using test::expect_format_error;
using test::same_bits;

using test::TempDir;

void gzip_file(const std::string& path, const std::string& bytes) {
  gzFile gz = gzopen(path.c_str(), "wb");
  ASSERT_NE(gz, nullptr);
  ASSERT_EQ(gzwrite(gz, bytes.data(), unsigned(bytes.size())), int(bytes.size()));
  ASSERT_EQ(gzclose(gz), Z_OK);
}

// Appends values in a chosen byte order, to hand-write binary PLY bodies.
struct Encoder {
  bool big = false;
  std::string bytes;
  template <class T>
  Encoder& put(T value) {
    unsigned char raw[sizeof(T)];
    std::memcpy(raw, &value, sizeof(T));
    if (big != (std::endian::native == std::endian::big))
      for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(raw[i], raw[sizeof(T) - 1 - i]);
    bytes.append(reinterpret_cast<const char*>(raw), sizeof(T));
    return *this;
  }
};

// Runs `body`, expects a FormatError whose message contains every fragment.
const Attribute& attribute(const std::vector<Attribute>& attributes, const std::string& name) {
  for (const Attribute& a : attributes)
    if (a.name == name) return a;
  throw std::runtime_error("no attribute " + name);
}

TriangleMesh sample_mesh() {
  TriangleMesh mesh;
  // Values that would lose bits through any text or double detour.
  mesh.vertices = {{0.1f, -0.2f, 0.3f},
                   {1e-38f, -0.0f, 3.4e38f},
                   {std::nextafter(1.0f, 2.0f), 123456.789f, -7.0f},
                   {0.333333343f, 2.5f, -1e-5f}};
  mesh.normals = {{0, 0, 1}, {0, 1, 0}, {1, 0, 0}, {0.6f, 0.8f, 0}};
  mesh.triangles = {{0, 1, 2}, {0, 2, 3}, {3, 2, 1}};
  Attribute color{"color", 3, false, {}};
  for (int i = 0; i < 12; ++i) color.values.push_back(float(i * 20) / 255.0f);
  Attribute velocity{"velocity", 3, false, {1.5f, -2.25f, 0.1f, 0, 0, 0, 1e-7f, 3, 4, -1, -2, -3}};
  Attribute stress{"stress", 3, false, {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12}};
  Attribute temperature{"temperature", 1, false, {293.15f, 300.0f, -1.5f, 0.125f}};
  Attribute id{"id", 1, true, {0, 7, -3, 1000000}};
  Attribute uv{"uv", 2, false, {0, 1, 0.5f, 0.25f, 1, 0, 0.75f, 0.125f}};
  mesh.attributes = {color, velocity, stress, temperature, id, uv};
  return mesh;
}

void expect_same_attributes(const std::vector<Attribute>& expected, const std::vector<Attribute>& actual) {
  ASSERT_EQ(actual.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    SCOPED_TRACE(expected[i].name);
    EXPECT_EQ(actual[i].name, expected[i].name);
    EXPECT_EQ(actual[i].components, expected[i].components);
    EXPECT_EQ(actual[i].integer, expected[i].integer);
    ASSERT_EQ(actual[i].values.size(), expected[i].values.size());
    for (std::size_t k = 0; k < expected[i].values.size(); ++k)
      EXPECT_TRUE(same_bits(actual[i].values[k], expected[i].values[k]))
          << k << ": " << actual[i].values[k] << " vs " << expected[i].values[k];
  }
}

// ------------------------------------------------------------------------------------------------

TEST(PlyRoundTrip, MeshComesBackBitExact) {
  TempDir dir;
  const TriangleMesh mesh = sample_mesh();
  const std::string path = dir.file("mesh.ply");
  write_mesh(path, mesh);
  const TriangleMesh back = read_mesh(path);

  ASSERT_EQ(back.vertices.size(), mesh.vertices.size());
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
    for (int c = 0; c < 3; ++c) EXPECT_TRUE(same_bits(back.vertices[i][c], mesh.vertices[i][c])) << i << "," << c;
  ASSERT_EQ(back.normals.size(), mesh.normals.size());
  for (std::size_t i = 0; i < mesh.normals.size(); ++i) EXPECT_EQ(back.normals[i], mesh.normals[i]);
  EXPECT_EQ(back.triangles, mesh.triangles);
  expect_same_attributes(mesh.attributes, back.attributes);
}

// The PLY written in parts (an MPI run's streamed gather) is the whole mesh's file byte for byte;
// a writer dropped before commit leaves no file; parts out of order or short counts are refused.
TEST(PlyRoundTrip, WrittenInPartsIsTheSameFile) {
  TempDir dir;
  const TriangleMesh mesh = sample_mesh();
  ASSERT_GE(mesh.vertices.size(), 3u);
  write_mesh(dir.file("whole.ply"), mesh);
  {
    io::PlyMeshWriter w(dir.file("parts.ply"), mesh.vertices.size(), mesh.triangles.size(), mesh);
    for (std::size_t first = 0; first < mesh.vertices.size(); first += 2) {
      TriangleMesh part;
      const std::size_t n = std::min<std::size_t>(2, mesh.vertices.size() - first);
      part.vertices.assign(mesh.vertices.begin() + std::ptrdiff_t(first), mesh.vertices.begin() + std::ptrdiff_t(first + n));
      part.normals.assign(mesh.normals.begin() + std::ptrdiff_t(first), mesh.normals.begin() + std::ptrdiff_t(first + n));
      for (const Attribute& a : mesh.attributes) {
        const std::size_t k = std::size_t(a.components);
        part.attributes.push_back({a.name, a.components, a.integer,
                                   {a.values.begin() + std::ptrdiff_t(first * k), a.values.begin() + std::ptrdiff_t((first + n) * k)}});
      }
      if (first == 0) {
        EXPECT_THROW(w.add_triangles(mesh.triangles.data(), 1), InvalidParameter) << "before the vertices";
      }
      w.add_vertices(part);
    }
    for (const Triangle& t : mesh.triangles) w.add_triangles(&t, 1);
    w.commit();
  }
  const auto bytes = [](const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  EXPECT_EQ(bytes(dir.file("parts.ply")), bytes(dir.file("whole.ply")));
  {
    io::PlyMeshWriter w(dir.file("short.ply"), mesh.vertices.size(), mesh.triangles.size(), mesh);
    w.add_vertices(mesh);
    EXPECT_THROW(w.commit(), InvalidParameter) << "the triangles are missing";
  }
  EXPECT_FALSE(std::filesystem::exists(dir.file("short.ply")));
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(dir.path)) ++files;
  EXPECT_EQ(files, 2u) << "whole.ply and parts.ply, no temporary left behind";
}

// A binary PLY of particles read in parts (each MPI rank its byte range) gives what the whole
// read gives, part by part; files that cannot be read in parts say so with 0 records.
TEST(ParticleRanges, PartsOfABinaryPlyAndARawXyzAreTheWholeRead) {
  const std::string ply = test::data_file("ply/dam_break_frame_9_6859_particles.ply");
  const ParticleSet whole = read_particles(ply);
  ASSERT_EQ(particle_records(ply), whole.size());
  std::size_t at = 0;
  for (std::size_t count : {std::size_t(1000), std::size_t(0), std::size_t(3000), whole.size() - 4000}) {
    const ParticleSet part = read_particle_range(ply, at, count);
    ASSERT_EQ(part.size(), count);
    for (std::size_t i = 0; i < count; ++i) ASSERT_EQ(part.positions[i], whole.positions[at + i]) << at + i;
    if (count > 0) {
      ASSERT_EQ(part.attributes.size(), whole.attributes.size());
      for (std::size_t a = 0; a < whole.attributes.size(); ++a) {
        const std::size_t k = std::size_t(whole.attributes[a].components);
        EXPECT_EQ(part.attributes[a].name, whole.attributes[a].name);
        EXPECT_TRUE(std::equal(part.attributes[a].values.begin(), part.attributes[a].values.end(),
                               whole.attributes[a].values.begin() + std::ptrdiff_t(at * k)));
      }
    }
    at += count;
  }
  EXPECT_THROW(read_particle_range(ply, 6000, 1000), InvalidParameter);
  // Compressed, text, other formats: whole reads only.
  EXPECT_EQ(particle_records(test::data_file("dam_break_frame_9_6859_particles.bgeo")), 0u);
  EXPECT_EQ(particle_records(test::data_file("sphysics_dam_break_IPART_29814_particles.txt.gz")), 0u);

  // Raw .xyz, with a NaN at particle 5: named by its index in the file, or dropped and counted.
  TempDir dir;
  const std::string xyz = dir.file("p.xyz");
  {
    std::ofstream out(xyz, std::ios::binary);
    for (int i = 0; i < 10; ++i) {
      const float v[3] = {float(i), i == 5 ? NAN : 0.5f * float(i), 1.0f};
      out.write(reinterpret_cast<const char*>(v), sizeof v);
    }
  }
  EXPECT_EQ(particle_records(xyz), 10u);
  EXPECT_EQ(read_particle_range(xyz, 6, 4).positions[0], (Vec3f{6.0f, 3.0f, 1.0f}));
  try {
    read_particle_range(xyz, 3, 5);
    ADD_FAILURE() << "a NaN coordinate was accepted";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("particle 5"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("p.xyz"), std::string::npos) << e.what();
  }
  ReadOptions drop;
  drop.drop_invalid = true;
  ReadReport report;
  EXPECT_EQ(read_particle_range(xyz, 3, 5, drop, &report).size(), 4u);
  EXPECT_EQ(report.dropped_invalid, 1u);
}

TEST(PlyRoundTrip, ParticlesReadFromWrittenMeshKeepAttributes) {
  TempDir dir;
  TriangleMesh mesh = sample_mesh();
  mesh.normals.clear();
  const std::string path = dir.file("points.ply");
  write_mesh(path, mesh);
  ReadReport report;
  const ParticleSet particles = read_particles(path, {}, &report);
  EXPECT_EQ(report.format, "ply (binary little endian)");
  EXPECT_EQ(report.dropped_invalid, 0u);
  ASSERT_EQ(particles.size(), mesh.vertices.size());
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
    for (int c = 0; c < 3; ++c) EXPECT_TRUE(same_bits(particles.positions[i][c], mesh.vertices[i][c]));
  expect_same_attributes(mesh.attributes, particles.attributes);
}

TEST(PlyRoundTrip, HeaderUsesTheDocumentedPropertyNamesAndTypes) {
  TempDir dir;
  const std::string path = dir.file("mesh.ply");
  write_mesh(path, sample_mesh());
  const std::string text = read_file(path);
  const std::string header = text.substr(0, text.find("end_header\n"));
  for (const char* line :
       {"ply\nformat binary_little_endian 1.0\n", "element vertex 4\n",
        "property float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n",
        "property uchar red\nproperty uchar green\nproperty uchar blue\n",
        "property float vx\nproperty float vy\nproperty float vz\n",
        "property float stress_x\nproperty float stress_y\nproperty float stress_z\n",
        "property float temperature\n", "property int id\n", "property float uv_0\nproperty float uv_1\n",
        "element face 3\nproperty list uchar uint vertex_indices\n"})
    EXPECT_NE(header.find(line), std::string::npos) << line;
  // 4 vertices × (6 floats, 3 uchar, 3 + 3 + 1 floats, 1 int, 2 floats) + 3 faces × 13 bytes.
  EXPECT_EQ(text.size(), header.size() + std::strlen("end_header\n") + 4 * (6 * 4 + 3 + 7 * 4 + 4 + 2 * 4) + 3 * 13);
}

TEST(PlyRoundTrip, ColorIsClampedAndRoundedToBytes) {
  TempDir dir;
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}};
  mesh.attributes = {Attribute{"color", 3, false, {-0.5f, 1.7f, 0.5f, 0.2f, std::nanf(""), 1.0f}}};
  const std::string path = dir.file("c.ply");
  write_mesh(path, mesh);
  const ParticleSet back = read_particles(path);
  const Attribute& color = attribute(back.attributes, "color");
  EXPECT_FALSE(color.integer);
  const std::vector<float> expected = {0.0f, 1.0f, 128.0f / 255.0f, 51.0f / 255.0f, 0.0f, 1.0f};
  EXPECT_EQ(color.values, expected);
}

TEST(PlyRoundTrip, EmptyMeshWithoutTrianglesIsWritten) {
  TempDir dir;
  TriangleMesh mesh;
  mesh.vertices = {{1, 2, 3}};
  const std::string path = dir.file("one.ply");
  write_mesh(path, mesh);
  const TriangleMesh back = read_mesh(path);
  EXPECT_EQ(back.vertices.size(), 1u);
  EXPECT_TRUE(back.triangles.empty());
  EXPECT_TRUE(back.normals.empty());
}

TEST(PlyRoundTrip, WriterRefusesInconsistentMeshesBeforeCreatingTheFile) {
  TempDir dir;
  const std::string path = dir.file("bad.ply");
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  mesh.triangles = {{0, 1, 3}};
  EXPECT_THROW(write_mesh(path, mesh), InvalidParameter);
  mesh.triangles = {{0, 1, 2}};
  mesh.attributes = {Attribute{"density", 1, false, {1, 2}}};
  EXPECT_THROW(write_mesh(path, mesh), InvalidParameter);
  mesh.attributes = {Attribute{"two words", 1, false, {1, 2, 3}}};
  EXPECT_THROW(write_mesh(path, mesh), InvalidParameter);
  mesh.attributes = {Attribute{"x", 1, false, {1, 2, 3}}};  // collides with the position property
  EXPECT_THROW(write_mesh(path, mesh), InvalidParameter);
  mesh.attributes = {Attribute{"id", 1, true, {1, 2, 3e10f}}};
  EXPECT_THROW(write_mesh(path, mesh), InvalidParameter);
  EXPECT_TRUE(std::filesystem::is_empty(dir.path));
}

TEST(PlyRoundTrip, UnknownOutputExtensionIsInvalidParameter) {
  TempDir dir;
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}};
  try {
    write_mesh(dir.file("mesh.stl"), mesh);
    FAIL() << "expected InvalidParameter";
  } catch (const InvalidParameter& e) {
    EXPECT_NE(std::string(e.what()).find(".stl"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find(".ply"), std::string::npos);
  }
  EXPECT_NO_THROW(write_mesh(dir.file("MESH.PLY"), mesh));  // extensions are case-insensitive
}

// ------------------------------------------------------------------------------------------------

constexpr const char* kAllTypesProperties =
    "property float x\nproperty float32 y\nproperty double z\n"
    "property char a\nproperty uchar b\nproperty short c\nproperty ushort d\n"
    "property int e\nproperty uint f\nproperty float g\nproperty double h\n"
    "property int8 a8\nproperty uint8 b8\nproperty int16 c16\nproperty uint16 d16\n"
    "property int32 e32\nproperty uint32 f32\nproperty float64 h64\n";

void expect_all_types(const ParticleSet& p) {
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(p.positions[0], (Vec3f{1.5f, -2.5f, 0.1f}));
  EXPECT_EQ(p.positions[1], (Vec3f{0.0f, 1e-3f, 1e30f}));
  struct Expect {
    const char* name;
    bool integer;
    float v0, v1;
  };
  const Expect expected[] = {
      {"a", true, -128, 127},          {"b", true, 0, 255},
      {"c", true, -32768, 32767},      {"d", true, 0, 65535},
      {"e", true, -2147483648.0f, 2147483647.0f},
      {"f", true, 0, 4294967295.0f},   {"g", false, 0.25f, -3.5e-8f},
      {"h", false, float(1.0 / 3.0), -2.0f},
      {"a8", true, -1, 1},             {"b8", true, 17, 200},
      {"c16", true, -2, 2},            {"d16", true, 3, 40000},
      {"e32", true, -5, 5},            {"f32", true, 6, 3000000000.0f},
      {"h64", false, 0.5f, -0.75f},
  };
  ASSERT_EQ(p.attributes.size(), std::size(expected));
  for (std::size_t i = 0; i < std::size(expected); ++i) {
    SCOPED_TRACE(expected[i].name);
    EXPECT_EQ(p.attributes[i].name, expected[i].name);  // file order is kept
    EXPECT_EQ(p.attributes[i].components, 1);
    EXPECT_EQ(p.attributes[i].integer, expected[i].integer);
    ASSERT_EQ(p.attributes[i].values.size(), 2u);
    EXPECT_EQ(p.attributes[i].values[0], expected[i].v0);
    EXPECT_EQ(p.attributes[i].values[1], expected[i].v1);
  }
}

TEST(PlyAscii, ReadsEveryScalarTypeAndSkipsOtherElements) {
  TempDir dir;
  const std::string path = dir.file("all.ply");
  write_file(path, std::string("ply\r\nformat ascii 1.0\ncomment made by hand\nobj_info nothing here\n"
                               "element material 2\nproperty list uchar int ids\nproperty float shine\n"
                               "property list ushort double weights\n"
                               "element vertex 2\n") +
                       kAllTypesProperties +
                       "element face 2\nproperty list uchar uint vertex_indices\nproperty int flags\n"
                       "end_header\n"
                       "3 1 2 3 0.5 2 0.25 0.75\n"
                       "0 1.0 0\n"
                       "1.5 -2.5 0.1 -128 0 -32768 0 -2147483648 0 0.25 0.333333333333333333 -1 17 -2 3 -5 6 0.5\n"
                       "0 1e-3 1e30 127 255 32767 65535 2147483647 4294967295 -3.5e-8 -2 1 200 2 40000 5 "
                       "3000000000 -0.75\n"
                       "3 0 1 1 7\n"
                       "4 1 0 1 0 -1\n");
  ReadReport report;
  const ParticleSet p = read_particles(path, {}, &report);
  EXPECT_EQ(report.format, "ply (ascii)");
  expect_all_types(p);
}

TEST(PlyAscii, AcceptsPlusSignsWholeFloatsForIntegersAndCrlf) {
  TempDir dir;
  const std::string path = dir.file("loose.ply");
  write_file(path,
             "ply\r\nformat ascii 1.0\r\nelement vertex 1\r\nproperty float x\r\nproperty float y\r\n"
             "property float z\r\nproperty int id\r\nend_header\r\n+1.0 2 -3e0 4.0\r\n");
  const ParticleSet p = read_particles(path);
  EXPECT_EQ(p.positions[0], (Vec3f{1, 2, -3}));
  EXPECT_EQ(attribute(p.attributes, "id").values, std::vector<float>{4});
}

std::string all_types_binary(bool big) {
  std::string header = std::string("ply\nformat ") + (big ? "binary_big_endian" : "binary_little_endian") +
                       " 1.0\ncomment hand written\n"
                       "element material 2\nproperty list uchar int ids\nproperty float shine\n"
                       "property list ushort double weights\n"
                       "element vertex 2\n" +
                       kAllTypesProperties +
                       "element face 2\nproperty list uchar uint vertex_indices\nproperty list uint float uv\n"
                       "property short flags\nelement edge 1\nproperty int a\nproperty int b\nend_header\n";
  Encoder e{big, header};
  // material: lists of int and double around a float
  e.put<uint8_t>(3).put<int32_t>(1).put<int32_t>(2).put<int32_t>(3).put<float>(0.5f);
  e.put<uint16_t>(2).put<double>(0.25).put<double>(0.75);
  e.put<uint8_t>(0).put<float>(1.0f).put<uint16_t>(0);
  // vertices
  e.put<float>(1.5f).put<float>(-2.5f).put<double>(0.1);
  e.put<int8_t>(-128).put<uint8_t>(0).put<int16_t>(-32768).put<uint16_t>(0);
  e.put<int32_t>(std::numeric_limits<int32_t>::min()).put<uint32_t>(0).put<float>(0.25f).put<double>(1.0 / 3.0);
  e.put<int8_t>(-1).put<uint8_t>(17).put<int16_t>(-2).put<uint16_t>(3).put<int32_t>(-5).put<uint32_t>(6);
  e.put<double>(0.5);
  e.put<float>(0.0f).put<float>(1e-3f).put<double>(1e30);
  e.put<int8_t>(127).put<uint8_t>(255).put<int16_t>(32767).put<uint16_t>(65535);
  e.put<int32_t>(std::numeric_limits<int32_t>::max()).put<uint32_t>(4294967295u).put<float>(-3.5e-8f);
  e.put<double>(-2.0);
  e.put<int8_t>(1).put<uint8_t>(200).put<int16_t>(2).put<uint16_t>(40000).put<int32_t>(5).put<uint32_t>(3000000000u);
  e.put<double>(-0.75);
  // faces: a triangle and a quad, each with a float list and a short after the indices
  e.put<uint8_t>(3).put<uint32_t>(0).put<uint32_t>(1).put<uint32_t>(1);
  e.put<uint32_t>(2).put<float>(0.5f).put<float>(0.5f).put<int16_t>(7);
  e.put<uint8_t>(4).put<uint32_t>(1).put<uint32_t>(0).put<uint32_t>(1).put<uint32_t>(0);
  e.put<uint32_t>(0).put<int16_t>(-1);
  // edge
  e.put<int32_t>(0).put<int32_t>(1);
  return e.bytes;
}

class PlyBinary : public ::testing::TestWithParam<bool> {};

TEST_P(PlyBinary, ReadsEveryScalarTypeAndSkipsListElements) {
  const bool big = GetParam();
  TempDir dir;
  const std::string path = dir.file("all.ply");
  write_file(path, all_types_binary(big));
  ReadReport report;
  const ParticleSet p = read_particles(path, {}, &report);
  EXPECT_EQ(report.format, big ? "ply (binary big endian)" : "ply (binary little endian)");
  expect_all_types(p);

  // The same file as a mesh: the quad is fanned into two triangles, extra face lists skipped.
  const TriangleMesh mesh = read_mesh(path);
  EXPECT_EQ(mesh.vertices.size(), 2u);
  const std::vector<Triangle> expected = {{0, 1, 1}, {1, 0, 1}, {1, 1, 0}};
  EXPECT_EQ(mesh.triangles, expected);
}

TEST_P(PlyBinary, TruncatedListReportsByteOffsetAndExpectation) {
  const bool big = GetParam();
  TempDir dir;
  const std::string path = dir.file("cut.ply");
  std::string bytes = all_types_binary(big);
  bytes.resize(bytes.size() - 8 - 2 - 4 - 4 - 4);  // cut inside the quad's index list
  write_file(path, bytes);
  expect_format_error([&] { read_mesh(path); },
                      {path, "byte " + std::to_string(bytes.size() - 8), "expected 4 list items of 4 bytes",
                       "'vertex_indices' of face 1", "only 8 bytes are left"});
  // Particles skip the faces, but skipping must still not run past the end.
  expect_format_error([&] { read_particles(path); }, {path, "byte " + std::to_string(bytes.size() - 8)});
}

INSTANTIATE_TEST_SUITE_P(Endianness, PlyBinary, ::testing::Bool(),
                         [](const ::testing::TestParamInfo<bool>& param) {
                           return param.param ? "BigEndian" : "LittleEndian";
                         });

TEST(PlyGroups, KnownAndSuffixedPropertiesBecomeVectorAttributes) {
  TempDir dir;
  const std::string path = dir.file("groups.ply");
  write_file(path,
             "ply\nformat ascii 1.0\nelement vertex 1\n"
             "property float x\nproperty float y\nproperty float z\n"
             "property float vy\nproperty float vx\nproperty float vz\n"  // out of order on purpose
             "property float nx\nproperty float ny\nproperty float nz\n"
             "property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\n"
             "property float accel_x\nproperty float accel_y\nproperty float accel_z\n"
             "property float w_x\nproperty float w_y\n"  // incomplete: stays scalar
             "property int id\n"
             "end_header\n"
             "0 0 0  2 1 3  0 0 1  255 0 51 7  4 5 6  8 9  42\n");
  const ParticleSet p = read_particles(path);
  std::vector<std::string> names;
  for (const Attribute& a : p.attributes) names.push_back(a.name);
  EXPECT_EQ(names, (std::vector<std::string>{"velocity", "normal", "color", "alpha", "accel", "w_x", "w_y", "id"}));
  EXPECT_EQ(attribute(p.attributes, "velocity").values, (std::vector<float>{1, 2, 3}));
  EXPECT_EQ(attribute(p.attributes, "velocity").components, 3);
  EXPECT_EQ(attribute(p.attributes, "normal").values, (std::vector<float>{0, 0, 1}));
  EXPECT_EQ(attribute(p.attributes, "color").values, (std::vector<float>{1.0f, 0.0f, 51.0f / 255.0f}));
  EXPECT_FALSE(attribute(p.attributes, "color").integer);
  EXPECT_EQ(attribute(p.attributes, "accel").values, (std::vector<float>{4, 5, 6}));
  EXPECT_EQ(attribute(p.attributes, "w_x").values, (std::vector<float>{8}));
  EXPECT_TRUE(attribute(p.attributes, "id").integer);
  EXPECT_TRUE(attribute(p.attributes, "alpha").integer);

  // velocity_x/_y/_z is the other common spelling; a mesh takes nx ny nz as its normals.
  const std::string path2 = dir.file("groups2.ply");
  write_file(path2,
             "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
             "property float nx\nproperty float ny\nproperty float nz\n"
             "property double velocity_x\nproperty double velocity_y\nproperty double velocity_z\nend_header\n"
             "1 2 3 0 1 0 7 8 9\n");
  const TriangleMesh mesh = read_mesh(path2);
  ASSERT_EQ(mesh.normals.size(), 1u);
  EXPECT_EQ(mesh.normals[0], (Vec3f{0, 1, 0}));
  ASSERT_EQ(mesh.attributes.size(), 1u);
  EXPECT_EQ(mesh.attributes[0].name, "velocity");
  EXPECT_EQ(mesh.attributes[0].values, (std::vector<float>{7, 8, 9}));
}

// The 6,859-particle frame as an ASCII PLY: x y z and every component of its attributes.
std::string frame_as_ascii_ply(const ParticleSet& p) {
  std::string header = fmt::format("ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\n"
                                   "property float z\n",
                                   p.size());
  for (const Attribute& a : p.attributes)
    for (int c = 0; c < a.components; ++c)
      header += a.components == 1 ? "property float " + a.name + "\n"
                                  : fmt::format("property float {}_{}\n", a.name, "xyz"[c]);
  std::string body;
  for (std::size_t i = 0; i < p.size(); ++i) {
    body += fmt::format("{} {} {}", p.positions[i].x, p.positions[i].y, p.positions[i].z);
    for (const Attribute& a : p.attributes)
      for (int c = 0; c < a.components; ++c) body += fmt::format(" {}", a.values[i * std::size_t(a.components) + std::size_t(c)]);
    body += "\n";
  }
  return header + "end_header\n" + body;
}

// 100,000 vertex properties, ASCII and binary: lonely vector-like names (a_x without a_y, b_0
// without b_1) among plain ones, and one vector at the end. The header costs about what text of
// its size costs to read (the frame's ASCII PLY, per byte), not the square of its properties.
TEST(PlyWideHeaders, AHundredThousandPropertiesReadInTimeLinearInTheirSize) {
  TempDir dir;
  const ParticleSet frame = read_particles(test::data_file("ply/dam_break_frame_9_6859_particles.ply"));
  const std::string reference = frame_as_ascii_ply(frame);
  write_file(dir.file("frame.ply"), reference);
  const double t_frame = test::fastest_seconds(3, [&] { EXPECT_EQ(read_particles(dir.file("frame.ply")).size(), 6859u); });

  constexpr std::size_t kProperties = 100000, kVertices = 2;
  std::vector<std::string> names;
  for (std::size_t i = 0; names.size() + 3 < kProperties; ++i)
    names.push_back(i % 4 == 0 ? fmt::format("a{}_x", i) : i % 4 == 1 ? fmt::format("b{}_0", i) : fmt::format("p{}", i));
  for (const char* n : {"v_x", "v_y", "v_z"}) names.push_back(n);
  for (const bool binary : {false, true}) {
    SCOPED_TRACE(binary ? "binary" : "ascii");
    std::string text = fmt::format("ply\nformat {} 1.0\nelement vertex {}\nproperty float x\nproperty float y\n"
                                   "property float z\n",
                                   binary ? "binary_little_endian" : "ascii", kVertices);
    for (const std::string& n : names) text += "property float " + n + "\n";
    text += "end_header\n";
    Encoder body;
    for (std::size_t v = 0; v < kVertices; ++v) {
      for (int c = 0; c < 3; ++c) binary ? void(body.put(float(v))) : void(body.bytes += fmt::format("{} ", v));
      for (std::size_t k = 0; k < names.size(); ++k)
        binary ? void(body.put(float((k + v) % 7))) : void(body.bytes += fmt::format("{} ", (k + v) % 7));
      if (!binary) body.bytes += "\n";
    }
    text += body.bytes;
    write_file(dir.file("wide.ply"), text);

    ParticleSet p;
    const double t_wide = test::fastest_seconds(3, [&] { p = read_particles(dir.file("wide.ply")); });
    ASSERT_EQ(p.size(), kVertices);
    ASSERT_EQ(p.attributes.size(), names.size() - 2);  // v_x v_y v_z are one attribute
    for (const std::size_t k : {std::size_t(0), std::size_t(1), std::size_t(2), std::size_t(54321)}) {
      EXPECT_EQ(p.attributes[k].name, names[k]);
      EXPECT_EQ(p.attributes[k].values, (std::vector<float>{float(k % 7), float((k + 1) % 7)}));
    }
    const Attribute& v = p.attributes.back();
    EXPECT_EQ(v.name, "v");
    EXPECT_EQ(v.components, 3);
    const std::size_t vx = names.size() - 3;
    EXPECT_EQ(v.values, (std::vector<float>{float(vx % 7), float((vx + 1) % 7), float((vx + 2) % 7),
                                            float((vx + 1) % 7), float((vx + 2) % 7), float((vx + 3) % 7)}));
    // Per byte, within a bound of the frame's text: a name costs a few allocations and lookups where
    // a value costs a parse, so the bound leaves room for many times the frame's cost a byte (more
    // under ASan, whose allocator is slower); a scan per name costs the square of the names.
    const double per_byte = (t_wide / double(text.size())) / (t_frame / double(reference.size()));
    RecordProperty(binary ? "seconds_wide_binary" : "seconds_wide_ascii", std::to_string(t_wide));
    EXPECT_LT(per_byte, test::kSanitized ? 100.0 : 40.0)
        << t_wide << " s for the " << text.size() << " bytes of the wide file, " << t_frame << " s for the "
        << reference.size() << " bytes of the frame";
  }
  RecordProperty("seconds_frame", std::to_string(t_frame));
}

TEST(PlyWideHeaders, AnAbsurdPropertyCountIsRefusedWithItsLine) {
  TempDir dir;
  const std::string path = dir.file("many.ply");
  std::string text = "ply\nformat binary_little_endian 1.0\nelement vertex 0\n";
  for (std::size_t i = 0; i < 1'000'000; ++i) text += fmt::format("property uchar p{}\n", i);
  write_file(path, text + "end_header\n");
  // The element is an entry too: the millionth property is the 1,000,001st.
  expect_format_error([&] { read_particles(path); }, {path, "line 1000003", "at most 1000000 elements and properties"});
}

TEST(PlyGzip, ReadsCompressedFilesByContentNotName) {
  TempDir dir;
  const TriangleMesh mesh = sample_mesh();
  const std::string plain = dir.file("plain.ply");
  write_mesh(plain, mesh);
  const std::string bytes = read_file(plain);

  for (const std::string name : {"mesh.ply.gz", "mesh_gzipped_but_named.ply", "MESH.PLY.GZ"}) {
    SCOPED_TRACE(name);
    const std::string path = dir.file(name);
    gzip_file(path, bytes);
    ASSERT_NE(read_file(path), bytes);  // really compressed
    ReadReport report;
    const ParticleSet p = read_particles(path, {}, &report);
    EXPECT_EQ(report.format, "ply (binary little endian), gzip-compressed");
    ASSERT_EQ(p.size(), mesh.vertices.size());
    for (std::size_t i = 0; i < p.size(); ++i) EXPECT_EQ(p.positions[i], mesh.vertices[i]);
    const TriangleMesh back = read_mesh(path);
    EXPECT_EQ(back.triangles, mesh.triangles);
    expect_same_attributes(mesh.attributes, back.attributes);
  }

  const std::string ascii = dir.file("ascii.ply.gz");
  gzip_file(ascii, "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
                   "end_header\n1 2 3\n4 5 6\n");
  EXPECT_EQ(read_particles(ascii).positions, (std::vector<Vec3f>{{1, 2, 3}, {4, 5, 6}}));
}

TEST(PlyGzip, TruncatedGzipIsAFormatError) {
  TempDir dir;
  const std::string plain = dir.file("plain.ply");
  write_mesh(plain, sample_mesh());
  const std::string path = dir.file("cut.ply.gz");
  gzip_file(path, read_file(plain));
  std::string compressed = read_file(path);
  compressed.resize(compressed.size() / 2);
  write_file(path, compressed);
  expect_format_error([&] { read_particles(path); }, {path, "byte ", "expected more gzip-compressed data"});
}

// ------------------------------------------------------------------------------------------------

const std::string kXyzHeader =
    "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n";

TEST(PlyErrors, MissingMagic) {
  TempDir dir;
  const std::string path = dir.file("nomagic.ply");
  write_file(path, "plx\nformat ascii 1.0\nelement vertex 0\nend_header\n");
  expect_format_error([&] { read_particles(path); }, {path, "line 1", "expected the PLY magic line 'ply'"});
}

TEST(PlyErrors, BadFormatLine) {
  TempDir dir;
  const std::string path = dir.file("format.ply");
  write_file(path, "ply\ncomment ok\nformat binary_middle_endian 1.0\nelement vertex 0\nend_header\n");
  expect_format_error([&] { read_particles(path); },
                      {path, "line 3", "expected 'format ascii|binary_little_endian|binary_big_endian 1.0'",
                       "binary_middle_endian"});
  write_file(path, "ply\nformat ascii 2.0\nelement vertex 0\nend_header\n");
  expect_format_error([&] { read_particles(path); }, {path, "line 2", "expected 'format ascii"});
  write_file(path, "ply\nelement vertex 1\nproperty float x\nend_header\n");
  expect_format_error([&] { read_particles(path); }, {path, "line 2", "expected a 'format' line"});
}

TEST(PlyErrors, BadHeaderLines) {
  TempDir dir;
  const std::string path = dir.file("header.ply");
  write_file(path, "ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n");
  expect_format_error([&] { read_particles(path); }, {path, "line 4", "expected a property type", "float128"});
  write_file(path, "ply\nformat ascii 1.0\nelement vertex -1\nend_header\n");
  expect_format_error([&] { read_particles(path); }, {path, "line 3", "expected a non-negative integer element count"});
  write_file(path, "ply\nformat ascii 1.0\nelement vertex 1\nproperty list float int idx\nend_header\n");
  expect_format_error([&] { read_particles(path); }, {path, "line 4", "expected an integer list count type"});
  write_file(path, "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float x\nend_header\n");
  expect_format_error([&] { read_particles(path); }, {path, "line 5", "expected distinct property names"});
  write_file(path, "ply\nformat ascii 1.0\nelemnt vertex 1\nend_header\n");
  expect_format_error([&] { read_particles(path); }, {path, "line 3", "expected 'format', 'element'", "elemnt"});
  write_file(path, kXyzHeader);
  expect_format_error([&] { read_particles(path); }, {path, "line 7", "expected 'end_header'"});
  write_file(path, "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n");
  expect_format_error([&] { read_particles(path); }, {path, "line 3", "expected scalar properties x, y and z"});
  write_file(path, "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n3 0 1 2\n");
  expect_format_error([&] { read_particles(path); }, {path, "expected an element 'vertex'"});
}

TEST(PlyErrors, CountLargerThanTheFileIsRefusedBeforeAllocating) {
  TempDir dir;
  const std::string path = dir.file("huge.ply");
  const std::string header =
      "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000000\nproperty float x\nproperty float y\n"
      "property float z\nend_header\n";
  Encoder e{false, header};
  e.put<float>(1).put<float>(2).put<float>(3);
  write_file(path, e.bytes);
  expect_format_error([&] { read_particles(path); },
                      {path, "byte " + std::to_string(header.size()), "4000000000000 × 12 bytes",
                       "larger than the file can hold"});

  // Near 2^64 so a careless count × size would overflow.
  const std::string path2 = dir.file("huge2.ply");
  write_file(path2,
             "ply\nformat binary_big_endian 1.0\nelement junk 18446744073709551615\nproperty double a\n"
             "element vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n" +
                 std::string(20, '\0'));
  expect_format_error([&] { read_particles(path2); }, {path2, "byte ", "larger than the file can hold"});

  const std::string path3 = dir.file("huge3.ply");
  write_file(path3, "ply\nformat ascii 1.0\nelement vertex 1000000\nproperty float x\nproperty float y\n"
                    "property float z\nend_header\n1 2 3\n");
  expect_format_error([&] { read_particles(path3); }, {path3, "line 8", "1000000 records of 3 values",
                                                       "larger than the file can hold"});

  const std::string path4 = dir.file("huge4.ply");
  Encoder f{false, "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                   "property float z\nelement face 1\nproperty list uint uint vertex_indices\nend_header\n"};
  f.put<float>(1).put<float>(2).put<float>(3).put<uint32_t>(4000000000u).put<uint32_t>(0);
  write_file(path4, f.bytes);
  expect_format_error([&] { read_mesh(path4); },
                      {path4, "byte " + std::to_string(f.bytes.size() - 4), "expected 4000000000 list items"});
}

TEST(PlyErrors, TruncatedBinaryBody) {
  TempDir dir;
  const std::string path = dir.file("short.ply");
  const std::string header =
      "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
      "property float z\nend_header\n";
  Encoder e{false, header};
  e.put<float>(1).put<float>(2).put<float>(3).put<float>(4);
  write_file(path, e.bytes);
  expect_format_error([&] { read_particles(path); },
                      {path, "byte " + std::to_string(header.size()), "2 × 12 bytes", "element 'vertex'"});

  // A list whose items run past the end.
  const std::string path2 = dir.file("short2.ply");
  Encoder f{false, "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                   "property float z\nelement face 1\nproperty list uchar int vertex_indices\nproperty float q\n"
                   "end_header\n"};
  f.put<float>(1).put<float>(2).put<float>(3).put<uint8_t>(1).put<int32_t>(0);
  write_file(path2, f.bytes);
  expect_format_error([&] { read_mesh(path2); },
                      {path2, "byte " + std::to_string(f.bytes.size()), "expected a float value for property 'q' of face 0",
                       "truncated"});
}

TEST(PlyErrors, ACountTooLowLeavesDataAndIsRefused) {
  TempDir dir;
  const std::string path = dir.file("low.ply");
  const std::string header =
      "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
      "property float z\nend_header\n";
  Encoder e{false, header};
  e.put<float>(1).put<float>(2).put<float>(3).put<float>(4).put<float>(5).put<float>(6);
  write_file(path, e.bytes);
  expect_format_error([&] { read_particles(path); },
                      {path, "byte " + std::to_string(header.size() + 12), "found 12 more bytes",
                       "do the counts match the data?"});
  // A final newline or CR-LF after the data is no data.
  write_file(path, e.bytes.substr(0, header.size() + 12) + "\r\n");
  EXPECT_EQ(read_particles(path).size(), 1u);
  // ASCII: a value after the counted ones.
  write_file(path, kXyzHeader + "end_header\n1 2 3\n4 5 6\n7 8 9\n");
  expect_format_error([&] { read_particles(path); }, {path, "line 10", "found '7'"});
  write_file(path, kXyzHeader + "end_header\n1 2 3\n4 5 6\n\n  \n");
  EXPECT_EQ(read_particles(path).size(), 2u);
}

TEST(PlyErrors, AsciiNonNumericAndTruncated) {
  TempDir dir;
  const std::string path = dir.file("text.ply");
  write_file(path, kXyzHeader + "end_header\n1 2 3\n4.0 abc 6\n");
  expect_format_error([&] { read_particles(path); },
                      {path, "line 9", "expected a float value for property 'y' of vertex 1", "found 'abc'"});
  write_file(path, kXyzHeader + "end_header\n1 2 3\n4 5             \n");
  expect_format_error([&] { read_particles(path); },
                      {path, "line 9", "expected a float value for property 'z' of vertex 1", "end of the file"});
  write_file(path, kXyzHeader + "property uchar tag\nend_header\n1 2 3 4\n1 2 3 300\n");
  expect_format_error([&] { read_particles(path); },
                      {path, "line 10", "expected a uchar value for property 'tag' of vertex 1", "0..255", "'300'"});
  write_file(path, kXyzHeader + "property int tag\nend_header\n1 2 3 4\n1 2 3 4.5\n");
  expect_format_error([&] { read_particles(path); }, {path, "line 10", "expected an int value", "'4.5'"});
}

TEST(PlyErrors, FaceIndexOutOfRange) {
  TempDir dir;
  const std::string path = dir.file("faces.ply");
  write_file(path, kXyzHeader + "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
                                "0 0 0\n1 0 0\n3 0 1 0\n3 0 1 2\n");
  expect_format_error([&] { read_mesh(path); }, {path, "line 13", "expected a vertex index in 0..1 for face 1, found 2"});
  write_file(path, kXyzHeader + "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                                "0 0 0\n1 0 0\n3 0 -1 1\n");
  expect_format_error([&] { read_mesh(path); }, {path, "line 12", "found -1"});
  write_file(path, kXyzHeader + "element face 1\nproperty list uchar float vertex_indices\nend_header\n");
  expect_format_error([&] { read_mesh(path); }, {path, "line 7", "expected an integer list property 'vertex_indices'"});
}

TEST(PlyErrors, NonFiniteCoordinatesAreRefusedOrDropped) {
  TempDir dir;
  const std::string path = dir.file("nan.ply");
  Encoder e{false, "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                   "property float z\nproperty float vx\nproperty float vy\nproperty float vz\nproperty int id\n"
                   "end_header\n"};
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const float rows[4][3] = {{0, 0, 0}, {1, nan, 1}, {2, 2, 2}, {-inf, 3, 3}};
  for (int i = 0; i < 4; ++i)
    e.put<float>(rows[i][0]).put<float>(rows[i][1]).put<float>(rows[i][2])
        .put<float>(float(10 * i)).put<float>(float(10 * i + 1)).put<float>(float(10 * i + 2)).put<int32_t>(i);
  write_file(path, e.bytes);
  expect_format_error([&] { read_particles(path); }, {path, "particle 1", "expected finite coordinates", "drop_invalid"});

  ReadOptions options;
  options.drop_invalid = true;
  ReadReport report;
  const ParticleSet p = read_particles(path, options, &report);
  EXPECT_EQ(report.dropped_invalid, 2u);
  EXPECT_EQ(p.positions, (std::vector<Vec3f>{{0, 0, 0}, {2, 2, 2}}));
  EXPECT_EQ(attribute(p.attributes, "velocity").values, (std::vector<float>{0, 1, 2, 20, 21, 22}));
  EXPECT_EQ(attribute(p.attributes, "id").values, (std::vector<float>{0, 2}));

  const std::string path2 = dir.file("inf.ply");
  write_file(path2, kXyzHeader + "end_header\ninf 0 0\nnan 1 1\n");
  expect_format_error([&] { read_particles(path2); }, {path2, "particle 0", "expected finite coordinates"});
  expect_format_error([&] { read_particles(path2, options); }, {path2, "contains no particles"});
  expect_format_error([&] { read_mesh(path2); }, {path2, "vertex 0", "expected finite coordinates"});
}

TEST(PlyErrors, ZeroParticlesIsAnError) {
  TempDir dir;
  const std::string path = dir.file("empty.ply");
  write_file(path, "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\n"
                   "end_header\n");
  expect_format_error([&] { read_particles(path); }, {path, "contains no particles"});
}

TEST(PlyErrors, UnknownFormatAndMissingFile) {
  TempDir dir;
  const std::string path = dir.file("particles.dat");
  write_file(path, "hello world");
  expect_format_error([&] { read_particles(path); }, {path, "unknown particle format", "'.dat'", ".ply", ".xyz"});
  try {
    read_particles(dir.file("missing.ply"));
    FAIL() << "expected IoError";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find(dir.file("missing.ply")), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("No such file"), std::string::npos) << e.what();
  }
  EXPECT_THROW(read_particles(dir.path.string()), IoError);  // a directory
}

TEST(PlyErrors, MagicWinsOverTheExtension) {
  TempDir dir;
  const std::string path = dir.file("actually_ply.xyz");
  write_file(path, kXyzHeader + "end_header\n1 2 3\n4 5 6\n");
  ReadReport report;
  EXPECT_EQ(read_particles(path, {}, &report).size(), 2u);
  EXPECT_EQ(report.format, "ply (ascii)");
}

}  // namespace
}  // namespace meniscus
