// meniscus tests — Houdini bgeo: classic reader/writer, binary-JSON reader, .bgeo.sc container and mesh writer, bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <initializer_list>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <blosc.h>
#include <fmt/format.h>

#include "io/blosc_container.hpp"
#include "io/file_bytes.hpp"
#include "io/format_registry.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "meniscus/reconstruct.hpp"
#include "support/io_helpers.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

using test::write_file;
using test::read_file;
using test::expect_format_error;
using test::same_bits;

using test::data_file;
using test::TempDir;

std::string gunzipped(const std::string& path) {
  const io::ByteBuffer b = io::read_file_content(path);
  return std::string(b.begin(), b.end());
}

// Big-endian decoding written independently of the reader (byte arithmetic, no ByteCursor).
uint32_t be_u32(const std::string& b, std::size_t at) {
  return uint32_t(uint8_t(b[at])) << 24 | uint32_t(uint8_t(b[at + 1])) << 16 | uint32_t(uint8_t(b[at + 2])) << 8 |
         uint32_t(uint8_t(b[at + 3]));
}
int32_t be_i32(const std::string& b, std::size_t at) { return std::bit_cast<int32_t>(be_u32(b, at)); }
float be_f32(const std::string& b, std::size_t at) { return std::bit_cast<float>(be_u32(b, at)); }
uint16_t be_u16(const std::string& b, std::size_t at) { return uint16_t(uint8_t(b[at]) << 8 | uint8_t(b[at + 1])); }

const Attribute& attribute(const std::vector<Attribute>& attributes, const std::string& name) {
  for (const Attribute& a : attributes)
    if (a.name == name) return a;
  throw std::runtime_error("no attribute " + name);
}

std::vector<std::string> names(const std::vector<Attribute>& attributes) {
  std::vector<std::string> out;
  for (const Attribute& a : attributes) out.push_back(a.name);
  return out;
}

// Runs `body`, expects a FormatError whose message contains every fragment.
// ---------------------------------------------------------------------------------------------
// Classic bgeo: real files

TEST(BgeoClassic, SplishSplashFramesReadWithTheirCounts) {
  ReadReport report;
  const ParticleSet a = read_particles(data_file("dam_break_frame_23_24389_particles.bgeo"), {}, &report);
  EXPECT_EQ(a.size(), 24389u);
  EXPECT_EQ(report.format, "bgeo (classic), gzip-compressed");

  const std::string path = data_file("dam_break_frame_9_6859_particles.bgeo");
  const ParticleSet b = read_particles(path);
  ASSERT_EQ(b.size(), 6859u);
  const std::string raw = gunzipped(path);
  EXPECT_EQ(be_i32(raw, 9), 6859);
  // The point block starts after the dictionary; check particle 0 and the last one bit for bit.
  const int32_t point_attributes = be_i32(raw, 25);
  std::size_t at = 41, words = 4;
  for (int32_t i = 0; i < point_attributes; ++i) {
    const uint16_t name_length = be_u16(raw, at);
    const uint16_t size = be_u16(raw, at + 2 + name_length);
    at += 2 + name_length + 2 + 4 + 4u * size;
    words += size;
  }
  for (const std::size_t i : {std::size_t(0), std::size_t(6858)}) {
    EXPECT_TRUE(same_bits(b.positions[i].x, be_f32(raw, at + i * words * 4)));
    EXPECT_TRUE(same_bits(b.positions[i].z, be_f32(raw, at + i * words * 4 + 8)));
  }
  const Attribute& id = attribute(b.attributes, "id");
  EXPECT_TRUE(id.integer);
  EXPECT_EQ(id.components, 1);
  const Attribute& velocity = attribute(b.attributes, "velocity");
  EXPECT_EQ(velocity.components, 3);
  EXPECT_FALSE(velocity.integer);
  EXPECT_EQ(attribute(b.attributes, "density").components, 1);
  std::set<float> ids(id.values.begin(), id.values.end());
  EXPECT_EQ(ids.size(), 6859u);
}

TEST(BgeoClassic, PartioBaseAttributesAndDetails) {
  const std::string path = data_file("partio_base.bgeo");
  const std::string raw = read_file(path);
  const ParticleSet p = read_particles(path);
  ASSERT_EQ(p.size(), 5u);
  EXPECT_EQ(names(p.attributes), (std::vector<std::string>{"life", "id"}));
  // Dictionary: "life" FLOAT 2 (2+4+2+4+8 bytes), "id" INT 1 (2+2+2+4+4): points start at 75,
  // 7 words each (P.xyzw, life ×2, id).
  const std::size_t start = 41 + 20 + 14;
  for (std::size_t i = 0; i < 5; ++i) {
    const std::size_t at = start + i * 28;
    EXPECT_TRUE(same_bits(p.positions[i].x, be_f32(raw, at)));
    EXPECT_TRUE(same_bits(p.positions[i].y, be_f32(raw, at + 4)));
    EXPECT_TRUE(same_bits(p.positions[i].z, be_f32(raw, at + 8)));
    EXPECT_TRUE(same_bits(attribute(p.attributes, "life").values[2 * i + 1], be_f32(raw, at + 20)));
    EXPECT_EQ(attribute(p.attributes, "id").values[i], float(be_i32(raw, at + 24)));
    EXPECT_EQ(attribute(p.attributes, "id").values[i], float(i));
  }
  EXPECT_TRUE(attribute(p.attributes, "id").integer);
}

TEST(BgeoClassic, PartioIndexedStringsPartPrimitiveAndDefaults) {
  // partio_json: an INDEX attribute "someString" with the strings Hello, World.
  const ParticleSet json = read_particles(data_file("partio_json.bgeo"));
  ASSERT_EQ(json.size(), 5u);
  const Attribute& s = attribute(json.attributes, "someString");
  EXPECT_TRUE(s.integer);
  EXPECT_EQ(s.components, 1);
  const std::set<float> used(s.values.begin(), s.values.end());
  EXPECT_EQ(used, (std::set<float>{0.0f, 1.0f}));  // indices into the two strings

  // partio_test: one Part primitive with 5 vertices and a primitive attribute, read past cleanly.
  const std::string raw = read_file(data_file("partio_test.bgeo"));
  ASSERT_EQ(be_i32(raw, 13), 1);  // nPrims
  const ParticleSet test = read_particles(data_file("partio_test.bgeo"));
  EXPECT_EQ(test.size(), 5u);

  // partio_scatter: id has the default −1 in the file (bytes 51..54), Cd FLOAT 3, an INDEX "test"
  // with three strings (the first empty).
  const std::string scatter = read_file(data_file("partio_scatter.bgeo"));
  EXPECT_EQ(scatter.substr(43, 2), "id");
  EXPECT_EQ(be_i32(scatter, 51), -1);
  const ParticleSet p = read_particles(data_file("partio_scatter.bgeo"));
  ASSERT_EQ(p.size(), 25u);
  EXPECT_EQ(names(p.attributes), (std::vector<std::string>{"id", "Cd", "test"}));
  EXPECT_EQ(attribute(p.attributes, "Cd").components, 3);
  EXPECT_FALSE(attribute(p.attributes, "Cd").integer);
  // Dictionary: id 14, Cd 2+2+2+4+12 = 22, test 2+4+2+4+4+(2+0)+(2+4)+(2+5) = 31 → points at 108,
  // 4 + 1 + 3 + 1 words each.
  const std::size_t start = 41 + 14 + 22 + 31;
  for (std::size_t i = 0; i < 25; ++i) {
    const std::size_t at = start + i * 36;
    EXPECT_TRUE(same_bits(p.positions[i].x, be_f32(scatter, at)));
    EXPECT_EQ(attribute(p.attributes, "id").values[i], float(be_i32(scatter, at + 16)));
    EXPECT_TRUE(same_bits(attribute(p.attributes, "Cd").values[3 * i + 2], be_f32(scatter, at + 28)));
    EXPECT_EQ(attribute(p.attributes, "test").values[i], float(be_i32(scatter, at + 32)));
  }
  EXPECT_EQ(be_u16(scatter, scatter.size() - 2), 0x00FF);
}

// ---------------------------------------------------------------------------------------------
// Classic bgeo: bad input

TEST(BgeoClassic, TruncatedAtEveryPlaceIsAFormatError) {
  const std::string raw = gunzipped(data_file("dam_break_frame_9_6859_particles.bgeo"));
  TempDir dir;
  const std::string path = dir.file("cut.bgeo");
  std::vector<std::size_t> cuts;
  for (std::size_t n = 0; n < 200; ++n) cuts.push_back(n);
  for (std::size_t n = 200; n + 2 < raw.size(); n += 4099) cuts.push_back(n);
  cuts.push_back(raw.size() - 3);
  for (const std::size_t n : cuts) {
    SCOPED_TRACE(n);
    write_file(path, raw.substr(0, n));
    expect_format_error([&] { read_particles(path); }, {path, "byte "});
  }
  // Only the 00 FF trailer is optional.
  write_file(path, raw.substr(0, raw.size() - 2));
  EXPECT_EQ(read_particles(path).size(), 6859u);
}

TEST(BgeoClassic, WrongMagicVersionHugeCountsAndStringType) {
  std::string raw = read_file(data_file("partio_base.bgeo"));
  TempDir dir;
  const std::string path = dir.file("bad.bgeo");
  auto put_be = [](std::string& b, std::size_t at, uint32_t v) {
    for (int k = 0; k < 4; ++k) b[at + std::size_t(k)] = char(uint8_t(v >> (24 - 8 * k)));
  };

  std::string magic = raw;
  magic[4] = 'X';  // "BgeoX": no longer sniffed, still chosen by the extension
  write_file(path, magic);
  expect_format_error([&] { read_particles(path); }, {path, "byte 0", "BgeoV"});

  std::string version = raw;
  put_be(version, 5, 4);
  write_file(path, version);
  expect_format_error([&] { read_particles(path); }, {path, "byte 5", "version 5"});

  std::string points = raw;
  put_be(points, 9, 0x7FFFFFFF);
  write_file(path, points);
  expect_format_error([&] { read_particles(path); }, {path, "byte 75", "larger than the file"});

  std::string attributes = raw;
  put_be(attributes, 25, 0x10000000);
  write_file(path, attributes);
  expect_format_error([&] { read_particles(path); }, {path, "byte 41", "larger than the file"});

  std::string negative = raw;
  put_be(negative, 13, 0xFFFFFFFF);
  write_file(path, negative);
  expect_format_error([&] { read_particles(path); }, {path, "byte 13", "non-negative"});

  std::string string_type = raw;
  put_be(string_type, 41 + 2 + 4 + 2, 2);  // "life" becomes STRING
  write_file(path, string_type);
  expect_format_error([&] { read_particles(path); }, {path, "byte 41", "STRING"});
}

TEST(BgeoClassic, CountsThatLeaveBytesOverAreRefused) {
  // One point too few in the header: the last point's bytes are left over after the detail
  // attributes, where only the 00 FF trailer may stand.
  const std::string raw = gunzipped(data_file("dam_break_frame_9_6859_particles.bgeo"));
  TempDir dir;
  const std::string path = dir.file("short.bgeo");
  std::string shorter = raw;
  shorter[12] = char(uint8_t(shorter[12]) - 1);  // 6859 → 6858 (big-endian int32 at byte 9)
  ASSERT_EQ(be_i32(shorter, 9), 6858);
  write_file(path, shorter);
  expect_format_error([&] { read_particles(path); }, {path, "expected the end of the file after the 6858 points",
                                                      "more bytes"});
  // Anything after the trailer too.
  write_file(path, raw + "x");
  expect_format_error([&] { read_particles(path); }, {path, "found 3 more bytes"});  // 00 ff x
  write_file(path, raw);
  EXPECT_EQ(read_particles(path).size(), 6859u);
}

// ---------------------------------------------------------------------------------------------
// Writer

TriangleMesh small_mesh() {
  TriangleMesh m;
  m.vertices = {{0.1f, 0.2f, 0.3f}, {1.5f, -2.25f, 3.0f}, {0.0f, 1e-7f, -4.0f}, {7.0f, 8.0f, 9.0f}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  m.normals = {{0, 0, 1}, {0, 1, 0}, {1, 0, 0}, {0.6f, 0.8f, 0}};
  m.attributes.push_back({"color", 3, false, {0.1f, 0.2f, 0.3f, 0.4f, 0.5f, 0.6f, 0.7f, 0.8f, 0.9f, 1, 0, 0.5f}});
  m.attributes.push_back({"velocity", 3, false, {1, 2, 3, 4, 5, 6, 7, 8, 9, -1, -2, -3.5f}});
  m.attributes.push_back({"temperature", 1, false, {300, 301.5f, 302, 303}});
  m.attributes.push_back({"label", 2, true, {1, -2, 3, 4, 5, 6, 70000, 8}});
  return m;
}

TEST(BgeoWriter, HeaderBytesAreAtTheirOffsets) {
  TempDir dir;
  const std::string path = dir.file("mesh.bgeo");
  const TriangleMesh m = small_mesh();
  write_mesh(path, m);
  const std::string b = read_file(path);
  EXPECT_EQ(b.substr(0, 5), "BgeoV");
  EXPECT_EQ(be_i32(b, 5), 5);
  EXPECT_EQ(be_i32(b, 9), 4);   // points
  EXPECT_EQ(be_i32(b, 13), 2);  // primitives
  EXPECT_EQ(be_i32(b, 17), 0);
  EXPECT_EQ(be_i32(b, 21), 0);
  EXPECT_EQ(be_i32(b, 25), 5);  // N, Cd, v, temperature, label
  EXPECT_EQ(be_i32(b, 29), 0);
  EXPECT_EQ(be_i32(b, 33), 0);
  EXPECT_EQ(be_i32(b, 37), 0);
  // First dictionary entry: N, VECTOR 3 with zero defaults.
  EXPECT_EQ(be_u16(b, 41), 1);
  EXPECT_EQ(b.substr(43, 1), "N");
  EXPECT_EQ(be_u16(b, 44), 3);
  EXPECT_EQ(be_i32(b, 46), 5);
  // Second: Cd, FLOAT 3 with white defaults.
  EXPECT_EQ(be_u16(b, 62), 2);
  EXPECT_EQ(b.substr(64, 2), "Cd");
  EXPECT_EQ(be_u16(b, 66), 3);
  EXPECT_EQ(be_i32(b, 68), 0);
  EXPECT_EQ(be_f32(b, 72), 1.0f);
  // Dictionary (nameLen, name, size, type, defaults): N 21, Cd 22, v 21, temperature 23, label 21.
  const std::size_t points_at = 41 + 21 + 22 + 21 + 23 + 21;
  const std::size_t point_words = 4 + 3 + 3 + 3 + 1 + 2;
  EXPECT_TRUE(same_bits(be_f32(b, points_at + 4), 0.2f));
  EXPECT_EQ(be_f32(b, points_at + 12), 1.0f);  // w
  const std::size_t prims_at = points_at + 4 * point_words * 4;
  EXPECT_EQ(be_u32(b, prims_at), 0xFFFFFFFFu);  // a run
  EXPECT_EQ(be_u16(b, prims_at + 4), 2);
  EXPECT_EQ(be_i32(b, prims_at + 6), 1);  // Poly
  EXPECT_EQ(be_i32(b, prims_at + 10), 3);
  EXPECT_EQ(uint8_t(b[prims_at + 14]), 1);  // closed
  // Triangle (0, 1, 2) is written clockwise for Houdini: 0, 2, 1 as uint16.
  EXPECT_EQ(be_u16(b, prims_at + 15), 0);
  EXPECT_EQ(be_u16(b, prims_at + 17), 2);
  EXPECT_EQ(be_u16(b, prims_at + 19), 1);
  EXPECT_EQ(b.size(), prims_at + 10 + 2 * 11 + 2);
  EXPECT_EQ(be_u16(b, b.size() - 2), 0x00FF);
}

TEST(BgeoWriter, RoundTripThroughOurReaders) {
  TempDir dir;
  const std::string path = dir.file("mesh.bgeo");
  const TriangleMesh m = small_mesh();
  write_mesh(path, m);

  const ParticleSet p = read_particles(path);
  ASSERT_EQ(p.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_TRUE(same_bits(p.positions[i].x, m.vertices[i].x));
    EXPECT_TRUE(same_bits(p.positions[i].y, m.vertices[i].y));
    EXPECT_TRUE(same_bits(p.positions[i].z, m.vertices[i].z));
  }
  EXPECT_EQ(names(p.attributes), (std::vector<std::string>{"N", "Cd", "v", "temperature", "label"}));
  EXPECT_EQ(attribute(p.attributes, "N").values, (std::vector<float>{0, 0, 1, 0, 1, 0, 1, 0, 0, 0.6f, 0.8f, 0}));
  EXPECT_EQ(attribute(p.attributes, "Cd").values, m.attributes[0].values);
  EXPECT_EQ(attribute(p.attributes, "v").values, m.attributes[1].values);
  EXPECT_EQ(attribute(p.attributes, "temperature").values, m.attributes[2].values);
  EXPECT_EQ(attribute(p.attributes, "label").values, m.attributes[3].values);
  EXPECT_TRUE(attribute(p.attributes, "label").integer);

  const TriangleMesh back = read_mesh(path);
  EXPECT_EQ(back.triangles, m.triangles);
  ASSERT_EQ(back.normals.size(), 4u);
  EXPECT_TRUE(same_bits(back.normals[3].y, 0.8f));
  EXPECT_EQ(names(back.attributes), (std::vector<std::string>{"color", "velocity", "temperature", "label"}));
}

TEST(BgeoWriter, LargeMeshUsesInt32IndicesAndSeveralRuns) {
  // 300 × 240 vertices (> 65536: int32 indices), 142,922 triangles (three runs of ≤ 65535).
  const uint32_t nx = 300, ny = 240;
  const TriangleMesh m = test::grid_mesh(nx, ny, [](uint32_t x, uint32_t y) { return float(x ^ y) * 0.5f; });
  TempDir dir;
  const std::string path = dir.file("big.bgeo");
  write_mesh(path, m);
  const std::string b = read_file(path);
  EXPECT_EQ(b.size(), 41 + m.vertices.size() * 16 + 3 * 10 + m.triangles.size() * (4 + 1 + 12) + 2);
  const TriangleMesh back = read_mesh(path);
  EXPECT_EQ(back.vertices.size(), m.vertices.size());
  EXPECT_EQ(back.triangles, m.triangles);
}

TEST(BgeoWriter, RefusesClashingNames) {
  TempDir dir;
  TriangleMesh m = small_mesh();
  m.attributes.push_back({"Cd", 1, false, {0, 0, 0, 0}});
  EXPECT_THROW(write_mesh(dir.file("clash.bgeo"), m), InvalidParameter);
  EXPECT_FALSE(std::filesystem::exists(dir.file("clash.bgeo")));
}

// ---------------------------------------------------------------------------------------------
// Binary JSON: a tiny encoder for hand-built streams

struct BinaryJsonEncoder {
  bool big = false;
  std::string b;
  explicit BinaryJsonEncoder(bool big_endian = false) : big(big_endian) {
    b = big ? std::string("\x7F" "bJSN", 5) : std::string("\x7F" "NSJb", 5);
  }
  template <class T>
  BinaryJsonEncoder& raw(T value) {
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    if (big != (std::endian::native == std::endian::big))
      for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
    b.append(reinterpret_cast<const char*>(bytes), sizeof(T));
    return *this;
  }
  BinaryJsonEncoder& token(uint8_t t) { return raw(t); }
  BinaryJsonEncoder& length(uint64_t n) {
    if (n < 0xF1) return raw(uint8_t(n));
    if (n <= 0xFFFF) return raw(uint8_t(0xF2)).raw(uint16_t(n));
    return raw(uint8_t(0xF4)).raw(uint32_t(n));
  }
  BinaryJsonEncoder& str(const std::string& s) {
    token(0x27).length(s.size());
    b += s;
    return *this;
  }
  BinaryJsonEncoder& define(uint64_t id, const std::string& s) {
    token(0x2B).length(id).length(s.size());
    b += s;
    return *this;
  }
  BinaryJsonEncoder& ref(uint64_t id) { return token(0x26).length(id); }
  BinaryJsonEncoder& i8(int8_t v) { return token(0x11).raw(v); }
  BinaryJsonEncoder& i32(int32_t v) { return token(0x13).raw(v); }
  BinaryJsonEncoder& i64(int64_t v) { return token(0x14).raw(v); }
  BinaryJsonEncoder& f32(float v) { return token(0x19).raw(v); }
  BinaryJsonEncoder& f64(double v) { return token(0x1A).raw(v); }
  BinaryJsonEncoder& begin() { return token(0x5B); }
  BinaryJsonEncoder& end() { return token(0x5D); }
  BinaryJsonEncoder& map_begin() { return token(0x7B); }
  BinaryJsonEncoder& map_end() { return token(0x7D); }
  BinaryJsonEncoder& uniform_f32(const std::vector<float>& v) {
    token(0x40).token(0x19).length(v.size());
    for (const float x : v) raw(x);
    return *this;
  }
  BinaryJsonEncoder& uniform_i32(const std::vector<int32_t>& v) {
    token(0x40).token(0x13).length(v.size());
    for (const int32_t x : v) raw(x);
    return *this;
  }
  BinaryJsonEncoder& uniform_bool(const std::vector<bool>& v) {
    token(0x40).token(0x10).length(v.size());
    for (std::size_t w = 0; w < (v.size() + 31) / 32; ++w) {
      uint32_t word = 0;
      for (std::size_t i = 0; i < 32 && w * 32 + i < v.size(); ++i)
        if (v[w * 32 + i]) word |= 1u << i;
      raw(word);
    }
    return *this;
  }

  // [[def], [size, T, storage, S, defaults [...], values [size, T, storage, S, <payload>]]]
  BinaryJsonEncoder& attribute(const std::string& name, int tuple, const std::string& storage,
                               const std::function<void(BinaryJsonEncoder&)>& payload, const std::string& type = "numeric") {
    begin();
    begin().str("scope").str("public").str("type").str(type).str("name").str(name).str("options").map_begin().map_end().end();
    begin().str("size").i32(tuple).str("storage").str(storage);
    str("defaults").begin().str("size").i32(1).str("storage").str("fpreal64").str("values").token(0x40).token(0x1A).length(1).raw(0.0).end();
    str("values").begin().str("size").i32(tuple).str("storage").str(storage);
    payload(*this);
    end();
    end();
    return end();
  }
};

// A geometry with `points` points, some things to skip, then the point attributes.
std::string geometry(int points, const std::function<void(BinaryJsonEncoder&)>& attributes, bool big = false) {
  BinaryJsonEncoder e(big);
  e.begin();
  e.define(0, "fileversion").ref(0).str("18.5.506");
  e.define(1, "pointcount").ref(1).i64(points);
  e.str("info").map_begin().str("software").str("test").str("bounds").uniform_f32({0, 1, 0, 1, 0, 1}).map_end();
  e.str("topology").begin().str("pointref").begin().str("indices").uniform_i32({0, 1, 2}).end().end();
  e.str("attributes").begin();
  e.str("vertexattributes").begin().attribute("N", 3, "fpreal32", [](BinaryJsonEncoder& x) {
    x.str("tuples").begin().uniform_f32({0, 0, 1}).end();
  }).end();
  e.str("pointattributes").begin();
  attributes(e);
  e.end();
  e.end();
  e.str("primitives").begin().begin().begin().str("type").str("Poly").end().map_begin().map_end().end().end();
  e.token(0x2D).length(0);  // undefine "fileversion": not a value
  e.end();
  return e.b;
}

ParticleSet read_stream(const std::string& bytes, const std::string& name = "stream.bgeo") {
  TempDir dir;
  const std::string path = dir.file(name);
  write_file(path, bytes);
  return read_particles(path);
}

TEST(BgeoJson, TuplesAndArraysLayouts) {
  for (const bool big : {false, true}) {
    SCOPED_TRACE(big ? "big-endian" : "little-endian");
    const std::string bytes = geometry(3, [](BinaryJsonEncoder& e) {
      e.attribute("P", 3, "fpreal32", [](BinaryJsonEncoder& x) {
        x.str("tuples").begin().uniform_f32({1, 2, 3}).begin().f32(4).f64(5).i8(6).end().uniform_f32({7, 8, 9}).end();
      });
      e.attribute("id", 1, "int32", [](BinaryJsonEncoder& x) {
        x.str("arrays").begin().uniform_i32({10, 11, -12}).end();
      });
      e.attribute("v", 2, "fpreal64", [](BinaryJsonEncoder& x) {
        x.str("arrays").begin().uniform_f32({1, 2, 3}).uniform_f32({-1, -2, -3}).end();
      });
      e.attribute("name", 1, "int32", [](BinaryJsonEncoder& x) { x.str("indices").uniform_i32({0, 0, 0}); }, "string");
    }, big);
    ReadReport report;
    TempDir dir;
    write_file(dir.file("g.geo"), bytes);  // sniffed by magic, not by name
    const ParticleSet p = read_particles(dir.file("g.geo"), {}, &report);
    EXPECT_EQ(report.format, "bgeo (binary JSON)");
    ASSERT_EQ(p.size(), 3u);
    EXPECT_EQ(p.positions[1].x, 4.0f);
    EXPECT_EQ(p.positions[1].y, 5.0f);
    EXPECT_EQ(p.positions[1].z, 6.0f);
    EXPECT_EQ(p.positions[2].z, 9.0f);
    EXPECT_EQ(names(p.attributes), (std::vector<std::string>{"id", "v"}));
    EXPECT_EQ(attribute(p.attributes, "id").values, (std::vector<float>{10, 11, -12}));
    EXPECT_TRUE(attribute(p.attributes, "id").integer);
    EXPECT_EQ(attribute(p.attributes, "v").values, (std::vector<float>{1, -1, 2, -2, 3, -3}));
    EXPECT_FALSE(attribute(p.attributes, "v").integer);
  }
}

// Encodes `values` (points × tuple, element-major) the way FORMATS.md B describes rawpagedata.
std::vector<float> encode_pages(const std::vector<float>& values, std::size_t tuple, const std::vector<std::size_t>& packing,
                                std::size_t page_size, const std::vector<std::vector<bool>>& constant) {
  const std::size_t n = values.size() / tuple;
  std::vector<float> raw;
  for (std::size_t first = 0; first < n; first += page_size) {
    const std::size_t length = std::min(page_size, n - first);
    std::size_t offset = 0;
    for (std::size_t j = 0; j < packing.size(); ++j) {
      const bool is_constant = !constant.empty() && constant[j][first / page_size];
      for (std::size_t i = 0; i < (is_constant ? 1 : length); ++i)
        for (std::size_t k = 0; k < packing[j]; ++k) raw.push_back(values[(first + i) * tuple + offset + k]);
      offset += packing[j];
    }
  }
  return raw;
}

TEST(BgeoJson, RawPageDataWithPackingAndConstantPages) {
  // 5 points, pages of 2 (2, 2, 1). Cd packed [1, 2]: sub-vector 0 constant on page 0, sub-vector
  // 1 constant on pages 1 and 2.
  const std::vector<float> cd = {0.5f, 1, 2,  0.5f, 3, 4,  0.25f, 7, 8,  0.75f, 7, 8,  0.1f, 9, 9};
  const std::vector<std::vector<bool>> flags = {{true, false, false}, {false, true, true}};
  const std::vector<float> raw = encode_pages(cd, 3, {1, 2}, 2, flags);
  EXPECT_EQ(raw.size(), 1u + 4 + 2 + 2 + 1 + 2);  // the constant runs hold one sub-tuple
  const std::vector<float> positions = {0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3, 4, 4, 4};
  const std::string bytes = geometry(5, [&](BinaryJsonEncoder& e) {
    e.attribute("P", 3, "fpreal32", [&](BinaryJsonEncoder& x) {
      x.str("pagesize").i32(2).str("rawpagedata").uniform_f32(encode_pages(positions, 3, {3}, 2, {}));
    });
    e.attribute("Cd", 3, "fpreal32", [&](BinaryJsonEncoder& x) {
      x.str("packing").begin().i32(1).i32(2).end().str("pagesize").i32(2);
      x.str("constantpageflags").begin().uniform_bool(flags[0]).uniform_bool(flags[1]).end();
      x.str("rawpagedata").uniform_f32(raw);
    });
    e.attribute("dead", 1, "int32", [&](BinaryJsonEncoder& x) {
      // Every page constant: three values for five points.
      x.str("pagesize").i32(2).str("constantpageflags").begin().uniform_bool({true, true, true}).end();
      x.str("rawpagedata").uniform_i32({7, 8, 9});
    });
  });
  const ParticleSet p = read_stream(bytes);
  ASSERT_EQ(p.size(), 5u);
  EXPECT_EQ(p.positions[3].y, 3.0f);
  EXPECT_EQ(attribute(p.attributes, "Cd").values, cd);
  EXPECT_EQ(attribute(p.attributes, "dead").values, (std::vector<float>{7, 7, 8, 8, 9}));

  // One raw value short: the count check names the attribute and where its values start.
  const std::string short_bytes = geometry(5, [&](BinaryJsonEncoder& e) {
    e.attribute("P", 3, "fpreal32", [&](BinaryJsonEncoder& x) {
      x.str("pagesize").i32(2).str("rawpagedata").uniform_f32(std::vector<float>(14, 0.0f));
    });
  });
  expect_format_error([&] { read_stream(short_bytes); }, {"stream.bgeo", "byte ", "expected 15 raw page values", "'P'"});
}

TEST(BgeoJson, MalformedStreamsAreFormatErrors) {
  const std::string good = geometry(2, [](BinaryJsonEncoder& e) {
    e.attribute("P", 3, "fpreal32", [](BinaryJsonEncoder& x) { x.str("tuples").begin().uniform_f32({1, 2, 3}).uniform_f32({4, 5, 6}).end(); });
  });
  ASSERT_EQ(read_stream(good).size(), 2u);
  for (std::size_t n = 0; n < good.size(); ++n) {
    SCOPED_TRACE(n);
    expect_format_error([&] { read_stream(good.substr(0, n)); }, {"stream.bgeo"});
  }
  std::string bad_ref = good;
  bad_ref[bad_ref.find("\x26\x01")] = 0x26;
  bad_ref[bad_ref.find("\x26\x01") + 1] = 0x09;  // reference to an undefined token
  expect_format_error([&] { read_stream(bad_ref); }, {"byte ", "undefined token 9"});

  BinaryJsonEncoder deep;
  deep.begin().str("info");
  deep.b += std::string(100000, '\x5B');  // skipped structurally, so nesting must be bounded
  expect_format_error([&] { read_stream(deep.b); }, {"byte ", "nested"});

  const std::string huge = geometry(2000000000, [](BinaryJsonEncoder&) {});
  expect_format_error([&] { read_stream(huge); }, {"byte ", "point count"});
}

// A token of 1 MB defined once and referred to 20,000 times (as the keys of a map the reader
// skips): its text is the file's, never copied per reference, so the stream reads in the time of
// its bytes, a small multiple of the time the 6,859-particle frame takes.
TEST(BgeoJson, AStringReferredToManyTimesIsNeverCopied) {
  const double t_frame = test::fastest_seconds(3, [] {
    EXPECT_EQ(read_particles(test::data_file("dam_break_frame_9_6859_particles.bgeo")).size(), 6859u);
  });
  const std::string bytes = geometry(3, [](BinaryJsonEncoder& e) {
    e.attribute("P", 3, "fpreal32", [](BinaryJsonEncoder& x) {
      x.str("tuples").begin().uniform_f32({1, 2, 3}).uniform_f32({4, 5, 6}).uniform_f32({7, 8, 9}).end();
    });
  });
  // The same stream with a map of 20,000 entries keyed by one long token before its geometry.
  BinaryJsonEncoder keys;
  keys.b.clear();
  keys.begin().define(7, std::string(1 << 20, 'k')).str("info").map_begin();
  for (int i = 0; i < 20000; ++i) keys.ref(7).i8(int8_t(i));
  keys.map_end();
  std::string many = bytes;
  many.replace(5, 1, keys.b);  // after the magic, in place of the outer '['
  ParticleSet p;
  const double t_many = test::fastest_seconds(3, [&] { p = read_stream(many); });
  ASSERT_EQ(p.size(), 3u);
  EXPECT_EQ(p.positions[2], (Vec3f{7, 8, 9}));
  EXPECT_LT(t_many, 20 * t_frame) << t_many << " s, the frame " << t_frame << " s";
}

// ---------------------------------------------------------------------------------------------
// .bgeo.sc

TEST(BgeoSc, HoudiniPopSplatterFile) {
  ReadReport report;
  const std::string path = data_file("houdini_pop_splatter_13883_points.bgeo.sc");
  EXPECT_EQ(io::format_extension(path), ".sc");
  const ParticleSet p = read_particles(path, {}, &report);
  EXPECT_NE(report.format.find("bgeo.sc"), std::string::npos);
  ASSERT_EQ(p.size(), 13883u);
  for (const Vec3f& x : p.positions) {
    ASSERT_TRUE(std::isfinite(x.x) && std::isfinite(x.y) && std::isfinite(x.z));
    // The file's info.bounds: x −2.02…2.74, y −1.09…3.34, z −1.95…1.76.
    EXPECT_GE(x.x, -2.03f);
    EXPECT_LE(x.y, 3.35f);
  }
  const Attribute& v = attribute(p.attributes, "v");
  ASSERT_EQ(v.components, 3);
  float max_speed = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const float s = std::sqrt(v.values[3 * i] * v.values[3 * i] + v.values[3 * i + 1] * v.values[3 * i + 1] +
                              v.values[3 * i + 2] * v.values[3 * i + 2]);
    ASSERT_TRUE(std::isfinite(s));
    max_speed = std::max(max_speed, s);
  }
  EXPECT_GT(max_speed, 0.5f);  // the particles move …
  EXPECT_LT(max_speed, 20.0f);  // … at plausible speeds (attribute_ranges: components within ±8.3)
  const Attribute& id = attribute(p.attributes, "id");
  EXPECT_TRUE(id.integer);
  // The ~1,009 free particles have ids 0 … 1008 (nextid = 1009), the other points −1.
  std::set<float> ids;
  std::size_t particles = 0;
  for (const float x : id.values)
    if (x >= 0) {
      ++particles;
      EXPECT_LT(x, 1009.0f);
      ids.insert(x);
    }
  EXPECT_EQ(ids.size(), particles);
  EXPECT_GT(particles, 900u);
  EXPECT_EQ(attribute(p.attributes, "Cd").components, 3);
}

TEST(BgeoSc, CorruptChunksAndIndexAreFormatErrors) {
  const std::string good = read_file(data_file("houdini_pop_splatter_13883_points.bgeo.sc"));
  TempDir dir;
  const std::string path = dir.file("bad.bgeo.sc");
  auto expect_error = [&](const std::string& bytes, std::initializer_list<std::string> fragments) {
    write_file(path, bytes);
    expect_format_error([&] { read_particles(path); }, fragments);
  };
  auto put_be64 = [](std::string& b, std::size_t at, uint64_t v) {
    for (int k = 0; k < 8; ++k) b[at + std::size_t(k)] = char(uint8_t(v >> (56 - 8 * k)));
  };
  const std::size_t n = good.size();

  std::string chunk = good;
  for (std::size_t i = 28; i < 28 + 64; ++i) chunk[i] = char(~chunk[i]);  // inside chunk 0's LZ4 data
  expect_error(chunk, {path, "byte "});

  std::string header = good;
  header[12 + 12] = char(0x7F);  // cbytes of chunk 0 no longer matches the index
  expect_error(header, {path, "byte 12", "chunk 0"});

  std::string index_size = good;
  put_be64(index_size, n - 12, 1u << 30);
  expect_error(index_size, {path, fmt::format("byte {}", n - 12), "index size"});

  std::string offset = good;
  put_be64(offset, n - 12 - 24, uint64_t(n));  // chunk 1 starts past the end
  expect_error(offset, {path, fmt::format("byte {}", n - 36), "chunk 1"});

  std::string last = good;
  put_be64(last, n - 12 - 8, 1u << 21);  // last chunk larger than the chunk size
  expect_error(last, {path, "last chunk"});

  expect_error(good.substr(0, n - 1), {path, "1fcs"});
  expect_error(good.substr(0, 20), {path, "byte "});
  std::string magic = good;
  magic[3] = '2';
  expect_error(magic, {path, "byte 0", "scf1"});  // chosen by the .sc extension, refused by content
}

// Random byte changes anywhere in a file: the read either succeeds or throws FormatError, never
// anything else (the sanitizer build turns a stray read into a failure here).
TEST(BgeoFuzz, RandomByteChangesGiveResultsOrFormatErrors) {
  const std::string json = geometry(5, [](BinaryJsonEncoder& e) {
    e.attribute("P", 3, "fpreal32", [](BinaryJsonEncoder& x) {
      x.str("pagesize").i32(2).str("constantpageflags").begin().uniform_bool({false, true, false}).end();
      x.str("rawpagedata").uniform_f32({0, 0, 0, 1, 1, 1, 2, 2, 2, 4, 4, 4});
    });
  });
  ASSERT_EQ(read_stream(json).size(), 5u);
  const std::vector<std::pair<std::string, std::string>> files = {
      {"scatter.bgeo", read_file(data_file("partio_scatter.bgeo"))},
      {"test.bgeo", read_file(data_file("partio_test.bgeo"))},
      {"json.bgeo", json},
      {"pop.bgeo.sc", read_file(data_file("houdini_pop_splatter_13883_points.bgeo.sc"))}};
  TempDir dir;
  uint64_t state = 12345;
  auto next = [&] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return uint32_t(state >> 33);
  };
  for (const auto& [name, original] : files) {
    const std::string path = dir.file(name);
    const int rounds = name == "pop.bgeo.sc" ? 40 : 400;
    for (int round = 0; round < rounds; ++round) {
      std::string bytes = original;
      const int changes = 1 + int(next() % 4);
      for (int k = 0; k < changes; ++k) {
        // The .sc index and chunk headers live at the ends: aim half of the changes there.
        const std::size_t span = name == "pop.bgeo.sc" && (next() & 1) ? 64 : bytes.size();
        std::size_t at = next() % span;
        if (span == 64 && (next() & 1)) at = bytes.size() - 1 - at;
        bytes[at] = char(next());
      }
      write_file(path, bytes);
      try {
        read_particles(path);
      } catch (const FormatError& e) {
        EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      } catch (const std::exception& e) {
        ADD_FAILURE() << name << " round " << round << ": expected FormatError, got: " << e.what();
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// .bgeo.sc writer and binary-JSON mesh reader

uint64_t be_u64(const std::string& b, std::size_t at) { return uint64_t(be_u32(b, at)) << 32 | be_u32(b, at + 4); }

// A .bgeo.sc taken apart without our reader: the chunks' places from the index, each chunk
// decompressed by c-blosc itself.
struct Container {
  std::vector<std::size_t> starts;  // every chunk's first byte, then where the index starts
  uint64_t chunk_size = 0, last_size = 0, index_size = 0;
  std::string plain;
};

Container open_container(const std::string& b) {
  Container c;
  const std::size_t n = b.size();
  if (n < 40) throw std::runtime_error("too short for a container");
  c.index_size = be_u64(b, n - 12);
  if (c.index_size < 16 || c.index_size > n - 24) throw std::runtime_error("bad index size");
  const std::size_t index_at = n - 12 - std::size_t(c.index_size);
  const std::size_t chunks = std::size_t(c.index_size - 16) / 8 + 1;
  c.starts.push_back(12);
  for (std::size_t i = 1; i < chunks; ++i) c.starts.push_back(12 + std::size_t(be_u64(b, index_at + 8 * (i - 1))));
  c.chunk_size = be_u64(b, index_at + 8 * (chunks - 1));
  c.last_size = be_u64(b, index_at + 8 * chunks);
  c.starts.push_back(index_at);
  for (std::size_t i = 0; i < chunks; ++i) {
    std::size_t nbytes = 0, cbytes = 0, blocksize = 0;
    blosc_cbuffer_sizes(b.data() + c.starts[i], &nbytes, &cbytes, &blocksize);
    std::string out(nbytes, '\0');
    EXPECT_EQ(blosc_decompress_ctx(b.data() + c.starts[i], out.data(), nbytes, 1), int(nbytes)) << "chunk " << i;
    c.plain += out;
  }
  return c;
}

// Little-endian binary JSON decoded into a tree without our reader (the layout checks of the
// writer; the Houdini file's vertex normals).
struct JsonValue {
  enum class Kind { null, boolean, number, string, array, map, uniform, end } kind = Kind::null;
  uint8_t type = 0;  // a number's token, a uniform array's element token
  double number = 0;
  std::string text;
  std::vector<JsonValue> items;  // an array's items; a map's keys and values, alternating
  std::vector<double> values;    // a uniform array's values

  // The value after `key` in a list (or map) of alternating keys and values.
  const JsonValue& at(const std::string& key) const {
    for (std::size_t i = 0; i + 1 < items.size(); i += 2)
      if (items[i].kind == Kind::string && items[i].text == key) return items[i + 1];
    throw std::runtime_error("no key '" + key + "'");
  }
  bool has(const std::string& key) const {
    for (std::size_t i = 0; i + 1 < items.size(); i += 2)
      if (items[i].kind == Kind::string && items[i].text == key) return true;
    return false;
  }
  std::vector<std::string> keys() const {
    std::vector<std::string> out;
    for (std::size_t i = 0; i + 1 < items.size(); i += 2) out.push_back(items[i].text);
    return out;
  }
};

struct JsonDecoder {
  explicit JsonDecoder(const std::string& bytes) : b(bytes) {}
  const std::string& b;
  std::size_t at = 5;
  std::map<uint64_t, std::string> tokens;
  std::size_t plain_strings = 0;  // strings written in place rather than as tokens

  uint64_t le(std::size_t n) {
    if (at + n > b.size()) throw std::runtime_error("past the end");
    uint64_t v = 0;
    for (std::size_t i = 0; i < n; ++i) v |= uint64_t(uint8_t(b[at + i])) << (8 * i);
    at += n;
    return v;
  }
  uint64_t length() {
    const uint64_t first = le(1);
    return first < 0xF1 ? first : le(first == 0xF2 ? 2 : first == 0xF4 ? 4 : 8);
  }
  std::string text(uint64_t n) {
    if (at + n > b.size()) throw std::runtime_error("past the end");
    std::string s = b.substr(at, std::size_t(n));
    at += std::size_t(n);
    return s;
  }
  double scalar(uint8_t t) {
    switch (t) {
      case 0x11: return double(int8_t(le(1)));
      case 0x12: return double(int16_t(le(2)));
      case 0x13: return double(int32_t(le(4)));
      case 0x14: return double(int64_t(le(8)));
      case 0x21: return double(le(1));
      case 0x22: return double(le(2));
      case 0x19: return double(std::bit_cast<float>(uint32_t(le(4))));
      case 0x1A: return std::bit_cast<double>(le(8));
      default: throw std::runtime_error(fmt::format("not a number token: 0x{:02X}", t));
    }
  }
  JsonValue value() {
    for (;;) {
      const uint8_t t = uint8_t(le(1));
      JsonValue v;
      switch (t) {
        case 0x2B: {  // a token definition, not a value
          const uint64_t id = length();
          tokens[id] = text(length());
          continue;
        }
        case 0x2D: tokens.erase(length()); continue;
        case 0x00: return v;
        case 0x30:
        case 0x31: v.kind = JsonValue::Kind::boolean, v.number = t == 0x31; return v;
        case 0x10: v.kind = JsonValue::Kind::boolean, v.number = double(le(1)); return v;
        case 0x26: v.kind = JsonValue::Kind::string, v.text = tokens.at(length()); return v;
        case 0x27: v.kind = JsonValue::Kind::string, v.text = text(length()), ++plain_strings; return v;
        case 0x5D:
        case 0x7D: v.kind = JsonValue::Kind::end; return v;
        case 0x5B:
        case 0x7B:
          v.kind = t == 0x5B ? JsonValue::Kind::array : JsonValue::Kind::map;
          for (JsonValue item = value(); item.kind != JsonValue::Kind::end; item = value()) v.items.push_back(item);
          return v;
        case 0x40: {
          v.kind = JsonValue::Kind::uniform;
          v.type = uint8_t(le(1));
          const uint64_t n = length();
          if (v.type == 0x10) {
            std::vector<uint32_t> words((n + 31) / 32);
            for (uint32_t& w : words) w = uint32_t(le(4));
            for (uint64_t i = 0; i < n; ++i) v.values.push_back((words[i / 32] >> (i % 32)) & 1u);
          } else {
            for (uint64_t i = 0; i < n; ++i) v.values.push_back(scalar(v.type));
          }
          return v;
        }
        default: v.kind = JsonValue::Kind::number, v.type = t, v.number = scalar(t); return v;
      }
    }
  }
};

JsonValue decode_json(const std::string& plain, std::size_t* plain_strings = nullptr) {
  if (plain.substr(0, 5) != std::string("\x7F" "NSJb", 5)) throw std::runtime_error("not little-endian binary JSON");
  JsonDecoder d(plain);
  JsonValue v = d.value();
  EXPECT_EQ(d.at, plain.size()) << "bytes after the geometry";
  if (plain_strings) *plain_strings = d.plain_strings;
  return v;
}

void expect_same_bits(const std::vector<Vec3f>& a, const std::vector<Vec3f>& b, const char* what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  std::size_t different = 0;
  for (std::size_t i = 0; i < a.size(); ++i)
    different += !same_bits(a[i].x, b[i].x) || !same_bits(a[i].y, b[i].y) || !same_bits(a[i].z, b[i].z);
  EXPECT_EQ(different, 0u) << what;
}

TEST(BgeoScWriter, SmallMeshRoundTripsThroughOurReaders) {
  TempDir dir;
  const std::string path = dir.file("mesh.bgeo.sc"), classic = dir.file("mesh.bgeo");
  const TriangleMesh m = small_mesh();
  write_mesh(path, m);
  write_mesh(classic, m);
  EXPECT_EQ(read_file(path).substr(0, 4), "scf1");

  const TriangleMesh back = read_mesh(path);
  expect_same_bits(back.vertices, m.vertices, "vertices");
  EXPECT_EQ(back.triangles, m.triangles);
  EXPECT_EQ(back.triangles, read_mesh(classic).triangles);  // the same winding as the .bgeo round trip
  expect_same_bits(back.normals, m.normals, "normals");
  EXPECT_EQ(names(back.attributes), (std::vector<std::string>{"color", "velocity", "temperature", "label"}));
  for (std::size_t i = 0; i < m.attributes.size() && i < back.attributes.size(); ++i) {
    EXPECT_EQ(back.attributes[i].components, m.attributes[i].components) << m.attributes[i].name;
    EXPECT_EQ(back.attributes[i].integer, m.attributes[i].integer) << m.attributes[i].name;
    EXPECT_EQ(back.attributes[i].values, m.attributes[i].values) << m.attributes[i].name;
  }

  // As particles the file holds Houdini's names, as the classic writer's does.
  ReadReport report;
  const ParticleSet p = read_particles(path, {}, &report);
  EXPECT_NE(report.format.find("bgeo.sc"), std::string::npos);
  EXPECT_EQ(names(p.attributes), (std::vector<std::string>{"N", "Cd", "v", "temperature", "label"}));
  expect_same_bits(p.positions, m.vertices, "positions");
}

TEST(BgeoScWriter, StreamIsBinaryJsonWithHoudinisLayout) {
  TempDir dir;
  const std::string path = dir.file("mesh.bgeo.sc");
  const TriangleMesh m = small_mesh();
  write_mesh(path, m);
  const Container c = open_container(read_file(path));
  std::size_t plain_strings = 1;
  const JsonValue g = decode_json(c.plain, &plain_strings);
  EXPECT_EQ(plain_strings, 0u) << "every string a token, as Houdini writes them";

  EXPECT_EQ(g.keys(), (std::vector<std::string>{"fileversion", "hasindex", "pointcount", "vertexcount",
                                                "primitivecount", "info", "topology", "attributes", "primitives"}));
  EXPECT_EQ(g.at("fileversion").text, "18.5.506");
  EXPECT_EQ(g.at("hasindex").kind, JsonValue::Kind::boolean);
  EXPECT_EQ(g.at("hasindex").number, 0.0);
  EXPECT_EQ(g.at("pointcount").number, 4.0);
  EXPECT_EQ(g.at("vertexcount").number, 6.0);
  EXPECT_EQ(g.at("primitivecount").number, 2.0);
  EXPECT_EQ(g.at("info").kind, JsonValue::Kind::map);
  EXPECT_EQ(g.at("info").at("bounds").values, (std::vector<double>{0, 7, -2.25, 8, -4, 9}));
  // Each triangle's corners clockwise for Houdini: (0, 1, 2) → 0, 2, 1.
  const JsonValue& indices = g.at("topology").at("pointref").at("indices");
  EXPECT_EQ(indices.type, 0x13);  // int32
  EXPECT_EQ(indices.values, (std::vector<double>{0, 2, 1, 0, 3, 2}));

  struct Expected {
    const char* name;
    const char* type_info;
    int size;
    const char* storage;
    double default_value;
    std::vector<float> values;
  };
  std::vector<float> positions, normals;
  for (const Vec3f& v : m.vertices) positions.insert(positions.end(), {v.x, v.y, v.z});
  for (const Vec3f& v : m.normals) normals.insert(normals.end(), {v.x, v.y, v.z});
  const std::vector<Expected> expected = {
      {"P", "point", 3, "fpreal32", 0, positions},
      {"N", "normal", 3, "fpreal32", 0, normals},
      {"Cd", "color", 3, "fpreal32", 1, m.attributes[0].values},
      {"v", "vector", 3, "fpreal32", 0, m.attributes[1].values},
      {"temperature", nullptr, 1, "fpreal32", 0, m.attributes[2].values},
      {"label", nullptr, 2, "int32", 0, m.attributes[3].values}};
  const std::vector<JsonValue>& attributes = g.at("attributes").at("pointattributes").items;
  EXPECT_EQ(g.at("attributes").keys(), (std::vector<std::string>{"pointattributes"}));
  ASSERT_EQ(attributes.size(), expected.size());
  for (std::size_t k = 0; k < expected.size(); ++k) {
    const Expected& e = expected[k];
    const JsonValue& definition = attributes[k].items.at(0);
    const JsonValue& data = attributes[k].items.at(1);
    EXPECT_EQ(definition.keys(), (std::vector<std::string>{"scope", "type", "name", "options"}));
    EXPECT_EQ(definition.at("scope").text, "public");
    EXPECT_EQ(definition.at("type").text, "numeric");
    EXPECT_EQ(definition.at("name").text, e.name);
    const JsonValue& options = definition.at("options");
    EXPECT_EQ(options.kind, JsonValue::Kind::map);
    if (e.type_info) {
      EXPECT_EQ(options.at("type").at("type").text, "string") << e.name;
      EXPECT_EQ(options.at("type").at("value").text, e.type_info) << e.name;
    } else {
      EXPECT_TRUE(options.items.empty()) << e.name;
    }
    EXPECT_EQ(data.keys(), (std::vector<std::string>{"size", "storage", "defaults", "values"}));
    EXPECT_EQ(data.at("size").number, e.size);
    EXPECT_EQ(data.at("storage").text, e.storage);
    EXPECT_EQ(data.at("defaults").at("storage").text, "fpreal64");
    EXPECT_EQ(data.at("defaults").at("values").values, (std::vector<double>{e.default_value})) << e.name;
    const JsonValue& values = data.at("values");
    EXPECT_EQ(values.keys(), (std::vector<std::string>{"size", "storage", "pagesize", "rawpagedata"}));
    EXPECT_EQ(values.at("pagesize").number, 1024.0);
    const JsonValue& raw = values.at("rawpagedata");
    EXPECT_EQ(raw.type, std::string(e.storage) == "int32" ? 0x13 : 0x19) << e.name;
    ASSERT_EQ(raw.values.size(), e.values.size()) << e.name;
    for (std::size_t i = 0; i < raw.values.size(); ++i)
      EXPECT_TRUE(same_bits(float(raw.values[i]), e.values[i])) << e.name << " " << i;
  }

  // One run of closed polygons in Houdini's binary spelling (Polygon_run, startvertex,
  // nprimitives, nvertices_rle).
  const JsonValue& primitives = g.at("primitives");
  ASSERT_EQ(primitives.items.size(), 1u);
  const JsonValue& run = primitives.items[0];
  ASSERT_EQ(run.items.size(), 2u);
  EXPECT_EQ(run.items[0].keys(), (std::vector<std::string>{"type"}));
  EXPECT_EQ(run.items[0].at("type").text, "p_r");
  EXPECT_EQ(run.items[1].keys(), (std::vector<std::string>{"s_v", "n_p", "r_v"}));
  EXPECT_EQ(run.items[1].at("s_v").number, 0.0);
  EXPECT_EQ(run.items[1].at("n_p").number, 2.0);
  EXPECT_EQ(run.items[1].at("r_v").kind, JsonValue::Kind::uniform);
  EXPECT_EQ(run.items[1].at("r_v").values, (std::vector<double>{3, 2}));

  // Houdini 18.5's own stream starts with the same bytes, token for token, up to hasindex's value.
  const io::Bytes houdini = io::decompress_blosc_container(
      io::read_file_bytes(data_file("houdini_pop_splatter_13883_points.bgeo.sc")), "houdini");
  const std::string theirs(houdini.begin(), houdini.end());
  const std::size_t same = theirs.find("hasindex") + 8 + 2;  // the name, then its reference 26 02
  ASSERT_LT(same, 64u);
  EXPECT_EQ(c.plain.substr(0, same), theirs.substr(0, same));

  // Attributes carried over from a Houdini cache keep Houdini's names and get their type info.
  TriangleMesh houdini_names = small_mesh();
  houdini_names.attributes[0].name = "Cd";
  houdini_names.attributes[1].name = "v";
  const std::string renamed = dir.file("houdini_names.bgeo.sc");
  write_mesh(renamed, houdini_names);
  const JsonValue h = decode_json(open_container(read_file(renamed)).plain);
  const std::vector<JsonValue>& written = h.at("attributes").at("pointattributes").items;
  ASSERT_EQ(written.size(), 6u);
  EXPECT_EQ(written[2].items.at(0).at("name").text, "Cd");
  EXPECT_EQ(written[2].items.at(0).at("options").at("type").at("value").text, "color");
  EXPECT_EQ(written[3].items.at(0).at("name").text, "v");
  EXPECT_EQ(written[3].items.at(0).at("options").at("type").at("value").text, "vector");
}

TEST(BgeoScWriter, ContainerLayoutMatchesHoudinis) {
  // 72,000 vertices, 142,922 triangles: about 2.6 MB of stream, three chunks.
  const TriangleMesh m = test::grid_mesh(300, 240, [](uint32_t x, uint32_t y) { return float(x ^ y) * 0.5f; });
  TempDir dir;
  const std::string path = dir.file("grid.bgeo.sc");
  write_mesh(path, m);
  const std::string b = read_file(path);
  ASSERT_GT(b.size(), 64u);
  EXPECT_EQ(b.substr(0, 12), std::string("scf1\0\0\0\0\0\0\0\0", 12));
  EXPECT_EQ(b.substr(b.size() - 4), "1fcs");
  const Container c = open_container(b);
  const std::size_t chunks = c.starts.size() - 1;
  EXPECT_EQ(chunks, 3u);
  EXPECT_EQ(c.index_size, 8 * (chunks - 1) + 16);
  EXPECT_EQ(c.starts.back() + c.index_size + 12, b.size());  // chunks, index, its size, "1fcs": nothing else
  EXPECT_EQ(c.chunk_size, uint64_t(1) << 20);
  EXPECT_EQ(c.plain.size(), (chunks - 1) * c.chunk_size + c.last_size);
  EXPECT_EQ(c.plain.substr(0, 5), std::string("\x7F" "NSJb", 5));
  for (std::size_t i = 0; i < chunks; ++i) {
    const char* chunk = b.data() + c.starts[i];
    std::size_t nbytes = 0, cbytes = 0, blocksize = 0, typesize = 0;
    int flags = 0;
    blosc_cbuffer_sizes(chunk, &nbytes, &cbytes, &blocksize);
    blosc_cbuffer_metainfo(chunk, &typesize, &flags);
    EXPECT_EQ(uint8_t(chunk[0]), 2) << "Blosc format version, chunk " << i;
    EXPECT_EQ(uint8_t(chunk[2]), 0x21) << "byte shuffle + LZ4, as Houdini's chunks, chunk " << i;
    EXPECT_STREQ(blosc_cbuffer_complib(chunk), "LZ4") << i;
    EXPECT_EQ(typesize, 4u) << i;
    EXPECT_TRUE(flags & BLOSC_DOSHUFFLE) << i;
    EXPECT_EQ(cbytes, c.starts[i + 1] - c.starts[i]) << "the index agrees with the chunk header, chunk " << i;
    EXPECT_EQ(nbytes, i + 1 < chunks ? c.chunk_size : c.last_size) << i;
    EXPECT_EQ(blocksize, nbytes - nbytes % 4) << "one block per chunk, chunk " << i;
    std::size_t validated = 0;
    EXPECT_EQ(blosc_cbuffer_validate(chunk, cbytes, &validated), 0) << i;
    EXPECT_LT(cbytes, nbytes) << "chunk " << i << " compressed";
  }
  const TriangleMesh back = read_mesh(path);
  expect_same_bits(back.vertices, m.vertices, "vertices");
  EXPECT_EQ(back.triangles, m.triangles);
}

// A real surface: the dam-break frame reconstructed with the default parameters (and the
// particles' velocity carried over), back bit for bit from .bgeo.sc and with the .bgeo's winding.
TEST(BgeoScWriter, DamBreakSurfaceRoundTripsBitForBit) {
  const ParticleSet particles = read_particles(data_file("dam_break_frame_9_6859_particles.bgeo"));
  Params params;
  params.transfer = {"velocity"};
  const TriangleMesh m = reconstruct(particles, params).mesh;
  ASSERT_GT(m.triangles.size(), 10000u);
  ASSERT_EQ(m.normals.size(), m.vertices.size());
  TempDir dir;
  const std::string sc = dir.file("frame.bgeo.sc"), classic = dir.file("frame.bgeo");
  write_mesh(sc, m);
  write_mesh(classic, m);
  const TriangleMesh back = read_mesh(sc);
  expect_same_bits(back.vertices, m.vertices, "vertices");
  EXPECT_EQ(back.triangles, m.triangles);
  EXPECT_EQ(back.triangles, read_mesh(classic).triangles);
  expect_same_bits(back.normals, m.normals, "normals");
  ASSERT_EQ(names(back.attributes), std::vector<std::string>{"velocity"});
  const std::vector<float>& velocity = attribute(m.attributes, "velocity").values;
  ASSERT_EQ(back.attributes[0].values.size(), velocity.size());
  std::size_t different = 0;
  for (std::size_t i = 0; i < velocity.size(); ++i) different += !same_bits(back.attributes[0].values[i], velocity[i]);
  EXPECT_EQ(different, 0u);
  // Compressed: well below the plain classic file.
  EXPECT_LT(std::filesystem::file_size(sc), std::filesystem::file_size(classic) * 7 / 10);
}

TEST(BgeoScWriter, NamesChooseTheWriter) {
  TempDir dir;
  const TriangleMesh m = small_mesh();
  for (const char* name : {"a.bgeo.sc", "b.sc", "C.BGEO.SC"}) {
    write_mesh(dir.file(name), m);
    EXPECT_EQ(read_file(dir.file(name)).substr(0, 4), "scf1") << name;
    EXPECT_EQ(read_mesh(dir.file(name)).triangles, m.triangles) << name;
  }
  // .bgeo stays classic, and .bgeo.gz gzip of classic bgeo.
  write_mesh(dir.file("d.bgeo"), m);
  EXPECT_EQ(read_file(dir.file("d.bgeo")).substr(0, 5), "BgeoV");
  write_mesh(dir.file("e.bgeo.gz"), m);
  EXPECT_EQ(read_file(dir.file("e.bgeo.gz")).substr(0, 2), "\x1f\x8b");
  EXPECT_EQ(gunzipped(dir.file("e.bgeo.gz")).substr(0, 5), "BgeoV");
  const std::vector<std::string> formats = mesh_formats();
  for (const char* ext : {".bgeo", ".bgeo.sc", ".sc"})
    EXPECT_NE(std::find(formats.begin(), formats.end(), ext), formats.end()) << ext;
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(dir.path)) ++files;
  EXPECT_EQ(files, 5u) << "no temporary file left";
}

TEST(BgeoScWriter, RefusesBadMeshesBeforeCreatingAFile) {
  TempDir dir;
  const std::string path = dir.file("bad.bgeo.sc");
  TriangleMesh clash = small_mesh();
  clash.attributes.push_back({"Cd", 1, false, {0, 0, 0, 0}});
  EXPECT_THROW(write_mesh(path, clash), InvalidParameter);
  TriangleMesh position = small_mesh();
  position.attributes.push_back({"P", 1, false, {0, 0, 0, 0}});
  EXPECT_THROW(write_mesh(path, position), InvalidParameter);
  TriangleMesh huge = small_mesh();
  huge.attributes.push_back({"count", 1, true, {0, 3e9f, 0, 0}});
  EXPECT_THROW(write_mesh(path, huge), InvalidParameter);
  TriangleMesh index = small_mesh();
  index.triangles.push_back({0, 1, 4});
  EXPECT_THROW(write_mesh(path, index), InvalidParameter);
  EXPECT_TRUE(std::filesystem::is_empty(dir.path)) << "neither the file nor a temporary";
}

TEST(BgeoScMesh, TruncatedOrCorruptFilesAreFormatErrors) {
  TempDir dir;
  const std::string good_path = dir.file("good.bgeo.sc");
  write_mesh(good_path, small_mesh());
  const std::string good = read_file(good_path);
  const std::size_t n = good.size();
  const std::string path = dir.file("bad.bgeo.sc");
  for (const std::size_t keep : {n - 1, n - 12, n / 2, std::size_t(40), std::size_t(13)}) {
    write_file(path, good.substr(0, keep));
    expect_format_error([&] { read_mesh(path); }, {path, "byte "});
  }
  std::string flipped = good;
  for (std::size_t i = 12 + 16; i < 12 + 48; ++i) flipped[i] = char(~flipped[i]);  // inside the chunk's data
  write_file(path, flipped);
  expect_format_error([&] { read_mesh(path); }, {path, "byte "});

  // A sound container around a stream whose run needs more vertices than the topology has: the
  // offset counts bytes of the decompressed stream.
  BinaryJsonEncoder e;
  e.begin().str("pointcount").i32(3).str("topology").begin().str("pointref").begin().str("indices");
  e.uniform_i32({0, 1, 2}).end().end();
  e.str("attributes").begin().str("pointattributes").begin();
  e.attribute("P", 3, "fpreal32", [](BinaryJsonEncoder& x) {
    x.str("tuples").begin().uniform_f32({0, 0, 0}).uniform_f32({1, 0, 0}).uniform_f32({0, 1, 0}).end();
  });
  e.end().end();
  e.str("primitives").begin().begin().begin().str("type").str("p_r").end();
  e.begin().str("s_v").i8(0).str("n_p").i8(2).str("r_v").uniform_i32({3, 2}).end().end().end();
  e.end();
  {
    io::BloscContainerWriter out(path);
    out.write(io::ByteView(reinterpret_cast<const uint8_t*>(e.b.data()), e.b.size()));
    out.commit();
  }
  EXPECT_EQ(read_mesh(good_path).triangles.size(), 2u);
  expect_format_error([&] { read_mesh(path); }, {path, "of the decompressed data", "fit the 3 vertices"});
}

// A mesh stream of 6 points, with the given topology and primitives (hand-built as Houdini
// writes them in its several versions).
std::string mesh_stream(const std::vector<int32_t>& pointref, const std::function<void(BinaryJsonEncoder&)>& primitives,
                        int64_t vertexcount = -1) {
  BinaryJsonEncoder e;
  e.begin().str("fileversion").str("18.5.506").str("pointcount").i32(6);
  if (vertexcount >= 0) e.str("vertexcount").i64(vertexcount);
  e.str("topology").begin().str("pointref").begin().str("indices").uniform_i32(pointref).end().end();
  e.str("attributes").begin().str("pointattributes").begin();
  e.attribute("P", 3, "fpreal32", [](BinaryJsonEncoder& x) {
    x.str("pagesize").i32(1024).str("rawpagedata").uniform_f32({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1});
  });
  e.end().end();
  e.str("primitives").begin();
  primitives(e);
  e.end().end();
  return e.b;
}

TriangleMesh read_mesh_stream(const std::string& bytes, const std::string& path) {
  write_file(path, bytes);
  return read_mesh(path);
}

TEST(BgeoJsonMesh, HoudiniPolygonLayouts) {
  TempDir dir;
  const std::string path = dir.file("mesh.bgeo");
  // Vertices 0-2: a triangle; 3-6: a quad; 7-9: a triangle; 10-11: an open curve.
  const std::vector<int32_t> ref = {0, 1, 2, 0, 2, 3, 4, 5, 4, 1, 3, 5};
  auto run = [](BinaryJsonEncoder& e, const char* type, const std::function<void(BinaryJsonEncoder&)>& data) {
    e.begin().begin().str("type").str(type).end();
    data(e);
    e.end();
  };
  // A triangle (0, 1, 2) clockwise in Houdini is (0, 2, 1) for us; a quad fans from its first corner.
  const std::vector<Triangle> expected = {{0, 2, 1}, {0, 3, 2}, {0, 4, 3}, {5, 1, 4}};

  // Houdini 18+ binary spelling, run-length encoded sizes; then the open curve and a sphere.
  const TriangleMesh a = read_mesh_stream(mesh_stream(ref, [&](BinaryJsonEncoder& e) {
    run(e, "p_r", [](BinaryJsonEncoder& x) {
      x.begin().str("s_v").i8(0).str("n_p").i8(3).str("r_v").uniform_i32({3, 1, 4, 1, 3, 1}).end();
    });
    run(e, "c_r", [](BinaryJsonEncoder& x) { x.begin().str("s_v").i8(10).str("n_p").i8(1).str("n_v").begin().i8(2).end().end(); });
    run(e, "Sphere", [](BinaryJsonEncoder& x) { x.begin().str("vertex").i8(0).end(); });
  }, 12), path);
  EXPECT_EQ(a.triangles, expected);
  EXPECT_EQ(a.vertices.size(), 6u);
  EXPECT_TRUE(same_bits(a.vertices[5].z, 1.0f));

  // The ASCII spelling (also valid in binary), sizes listed; two runs.
  const TriangleMesh b = read_mesh_stream(mesh_stream(ref, [&](BinaryJsonEncoder& e) {
    run(e, "Polygon_run", [](BinaryJsonEncoder& x) {
      x.begin().str("startvertex").i8(0).str("nprimitives").i8(2).str("nvertices").begin().i8(3).i8(4).end().end();
    });
    run(e, "Polygon_run", [](BinaryJsonEncoder& x) {
      x.begin().str("startvertex").i8(7).str("nprimitives").i8(1).str("nvertices_rle").begin().i8(3).i8(1).end().end();
    });
  }), path);
  EXPECT_EQ(b.triangles, expected);

  // Single polygons (an open one skipped) and a Houdini 12 run of polygons.
  const TriangleMesh c = read_mesh_stream(mesh_stream(ref, [&](BinaryJsonEncoder& e) {
    run(e, "Poly", [](BinaryJsonEncoder& x) { x.begin().str("vertex").uniform_i32({0, 1, 2}).str("closed").token(0x31).end(); });
    run(e, "Poly", [](BinaryJsonEncoder& x) { x.begin().str("vertex").uniform_i32({10, 11}).str("closed").token(0x30).end(); });
    e.begin();
    e.begin().str("type").str("run").str("runtype").str("Poly").str("varyingfields").begin().str("vertex").end();
    e.str("uniformfields").map_begin().str("closed").token(0x31).map_end().end();
    e.begin().begin().uniform_i32({3, 4, 5, 6}).end().begin().uniform_i32({7, 8, 9}).end().end();
    e.end();
  }), path);
  EXPECT_EQ(c.triangles, expected);
}

TEST(BgeoJsonMesh, MalformedTopologyAndRunsAreFormatErrors) {
  TempDir dir;
  const std::string path = dir.file("bad.bgeo");
  auto runs = [](std::vector<int32_t> rle, int n_p, int s_v = 0) {
    return [=](BinaryJsonEncoder& e) {
      e.begin().begin().str("type").str("p_r").end();
      e.begin().str("s_v").i32(s_v).str("n_p").i32(n_p).str("r_v").uniform_i32(rle).end().end();
    };
  };
  auto expect_error = [&](const std::string& bytes, std::initializer_list<std::string> fragments) {
    write_file(path, bytes);
    expect_format_error([&] { read_mesh(path); }, fragments);
  };
  const std::vector<int32_t> six = {0, 1, 2, 3, 4, 5};
  expect_error(mesh_stream({0, 1, 9}, runs({3, 1}, 1)), {path, "byte ", "point of vertex 2", "below 6", "9"});
  expect_error(mesh_stream(six, runs({3, 3}, 3)), {path, "byte ", "fit the 6 vertices"});
  expect_error(mesh_stream(six, runs({3, 1}, 1, 5)), {path, "byte ", "fit the 6 vertices", "from vertex 5"});
  expect_error(mesh_stream(six, runs({3, 1, 3}, 2)), {path, "byte ", "pairs"});
  expect_error(mesh_stream(six, runs({2, 3}, 3)), {path, "byte ", "from 3 to 6", "found 2"});
  expect_error(mesh_stream(six, runs({3, 1}, 2)), {path, "byte ", "all 2 primitives", "1 have none"});
  expect_error(mesh_stream(six, runs({3, 2}, 1)), {path, "byte ", "at most the 1 primitives left"});
  expect_error(mesh_stream(six, runs({3, 2}, 2, 7)), {path, "byte ", "starting at a vertex from 0 to 6", "7"});
  expect_error(mesh_stream(six, runs({3, 2}, 2), 7), {path, "byte ", "vertex count", "6 topology indices", "7"});
  expect_error(mesh_stream(six, [](BinaryJsonEncoder& e) {
    e.begin().begin().str("type").str("Poly").end().begin().str("vertex").uniform_i32({0, 1, 99}).end().end();
  }), {path, "byte ", "polygon vertices below the vertex count 6", "99"});
  expect_error(mesh_stream(six, [](BinaryJsonEncoder& e) {
    e.begin().begin().str("type").str("Poly").end().begin().str("vertex").uniform_i32({0, 1}).end().end();
  }), {path, "byte ", "at least 3 vertices", "found 2"});
  // Polygons without a topology to map their vertices to points.
  BinaryJsonEncoder e;
  e.begin().str("pointcount").i32(0).str("primitives").begin();
  runs({3, 1}, 1)(e);
  e.end().end();
  expect_error(e.b, {path, "byte ", "'topology'"});
}

// Houdini's own polygons (the rubber toy in the POP file, 12,854 quads): read as triangles whose
// winding agrees with the normals Houdini stored on their vertices, which confirms that its
// polygons run clockwise seen from the front and that the reader turns them around.
TEST(BgeoJsonMesh, HoudiniRubberToyWindingAgreesWithItsNormals) {
  const std::string path = data_file("houdini_pop_splatter_13883_points.bgeo.sc");
  const TriangleMesh m = read_mesh(path);
  ASSERT_EQ(m.vertices.size(), 13883u);
  ASSERT_EQ(m.triangles.size(), 2u * 12854u);
  EXPECT_TRUE(m.normals.empty()) << "the file's N is a vertex attribute, not read";

  const Container c = open_container(read_file(path));
  const JsonValue g = decode_json(c.plain);
  const std::vector<double>& ref = g.at("topology").at("pointref").at("indices").values;
  ASSERT_EQ(ref.size(), 4u * 12854u);
  // The first quad: corners 0, 3, 2, 1 → triangles (0, 2, 3), (0, 1, 2).
  EXPECT_EQ(m.triangles[0], (Triangle{uint32_t(ref[0]), uint32_t(ref[2]), uint32_t(ref[1])}));
  EXPECT_EQ(m.triangles[1], (Triangle{uint32_t(ref[0]), uint32_t(ref[3]), uint32_t(ref[2])}));
  const JsonValue* normals = nullptr;
  for (const JsonValue& a : g.at("attributes").at("vertexattributes").items)
    if (a.items.at(0).at("name").text == "N") normals = &a.items.at(1).at("values");
  ASSERT_NE(normals, nullptr);
  ASSERT_FALSE(normals->has("constantpageflags"));
  const std::vector<double>& n = normals->at("rawpagedata").values;  // element-major, one run per page
  ASSERT_EQ(n.size(), 3 * ref.size());
  std::size_t agree = 0, disagree = 0;
  for (std::size_t q = 0; q < 12854; ++q) {
    double stored[3] = {0, 0, 0};
    for (std::size_t k = 0; k < 4; ++k)
      for (std::size_t d = 0; d < 3; ++d) stored[d] += n[3 * (4 * q + k) + d];
    for (const Triangle& t : {m.triangles[2 * q], m.triangles[2 * q + 1]}) {
      const Vec3f a = m.vertices[t[0]], b = m.vertices[t[1]], e = m.vertices[t[2]];
      const double u[3] = {b.x - a.x, b.y - a.y, b.z - a.z}, w[3] = {e.x - a.x, e.y - a.y, e.z - a.z};
      const double face[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
      const double dot = face[0] * stored[0] + face[1] * stored[1] + face[2] * stored[2];
      if (dot > 0) ++agree;
      else if (dot < 0) ++disagree;
    }
  }
  EXPECT_GE(agree, 25700u);  // measured: all 25,708
  EXPECT_EQ(disagree, 0u) << "counter-clockwise triangles face where Houdini's normals point";
}

// Random byte changes in our own .bgeo.sc and binary-JSON meshes: read_mesh either succeeds or
// throws FormatError naming the file, never anything else.
TEST(BgeoFuzz, MeshReadersGiveMeshesOrFormatErrors) {
  TempDir dir;
  const std::string sc = dir.file("source.bgeo.sc");
  write_mesh(sc, small_mesh());
  const Container c = open_container(read_file(sc));
  const std::vector<std::pair<std::string, std::string>> files = {{"mesh.bgeo.sc", read_file(sc)},
                                                                  {"mesh.bgeo", c.plain}};
  uint64_t state = 987654321;
  auto next = [&] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return uint32_t(state >> 33);
  };
  for (const auto& [name, original] : files) {
    const std::string path = dir.file(name);
    for (int round = 0; round < 300; ++round) {
      std::string bytes = original;
      const int changes = 1 + int(next() % 4);
      for (int k = 0; k < changes; ++k) bytes[next() % bytes.size()] = char(next());
      write_file(path, bytes);
      try {
        read_mesh(path);
      } catch (const FormatError& e) {
        EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      } catch (const std::exception& e) {
        ADD_FAILURE() << name << " round " << round << ": expected FormatError, got: " << e.what();
      }
    }
  }
}

}  // namespace
}  // namespace meniscus
