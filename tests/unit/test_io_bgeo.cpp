// meniscus tests — Houdini bgeo: classic reader/writer, binary-JSON reader, .bgeo.sc container, bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <initializer_list>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "io/file_bytes.hpp"
#include "io/format_registry.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
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
  const io::Bytes b = io::read_file_bytes_gunzipped(path);
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

}  // namespace
}  // namespace meniscus
