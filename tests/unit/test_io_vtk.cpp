// meniscus tests — legacy VTK and VTK XML (.vtu) particle readers: real frames, every encoding, bad input.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <initializer_list>
#include <sstream>
#include <string>
#include <vector>
#include <zlib.h>

#include <fmt/format.h>

#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "support/io_helpers.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

using test::write_file;
using test::expect_format_error;
using test::same_bits;

using test::TempDir;

const Attribute* find(const ParticleSet& p, const std::string& name) { return p.find(name); }

void expect_all_finite(const ParticleSet& p) {
  for (std::size_t i = 0; i < p.size(); ++i)
    ASSERT_TRUE(std::isfinite(p.positions[i].x) && std::isfinite(p.positions[i].y) && std::isfinite(p.positions[i].z))
        << i;
}

// Positions and the named attributes must equal the PLY conversion of the same frame bit for bit
// (tools/convert_frames.py rounds doubles to float32 the same way the readers do).
void expect_same_as_ply(const ParticleSet& p, const std::string& ply_name, std::initializer_list<std::string> names) {
  const ParticleSet ply = read_particles(test::data_file("ply/" + ply_name));
  ASSERT_EQ(p.size(), ply.size());
  for (std::size_t i = 0; i < p.size(); ++i)
    for (int c = 0; c < 3; ++c) ASSERT_TRUE(same_bits(p.positions[i][c], ply.positions[i][c])) << i << "," << c;
  for (const std::string& n : names) {
    SCOPED_TRACE(n);
    const Attribute* a = p.find(n);
    const Attribute* b = ply.find(n);
    ASSERT_NE(a, nullptr);
    ASSERT_NE(b, nullptr);
    ASSERT_EQ(a->components, b->components);
    ASSERT_EQ(a->values.size(), b->values.size());
    for (std::size_t k = 0; k < a->values.size(); ++k) ASSERT_TRUE(same_bits(a->values[k], b->values[k])) << k;
  }
}

// Appends values in big- or little-endian order.
struct Encoder {
  bool big = true;
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

// ------------------------------------------------------------------------------------------------
// Real legacy VTK frames (SPlisHSPlasH / splashsurf)

TEST(VtkLegacyRealFiles, BunnyHas7706ParticlesWithIdAndVelocity) {
  ReadReport report;
  const ParticleSet p = read_particles(test::data_file("bunny_frame_14_7705_particles.vtk"), {}, &report);
  EXPECT_EQ(p.size(), 7706u);
  ASSERT_EQ(p.attributes.size(), 2u);
  EXPECT_EQ(p.attributes[0].name, "id");
  EXPECT_TRUE(p.attributes[0].integer);
  EXPECT_EQ(p.attributes[0].components, 1);
  EXPECT_EQ(p.attributes[1].name, "velocity");
  EXPECT_EQ(p.attributes[1].components, 3);
  EXPECT_FALSE(p.attributes[1].integer);
  EXPECT_NE(report.format.find("binary"), std::string::npos) << report.format;
  expect_all_finite(p);
  expect_same_as_ply(p, "bunny_frame_14_7705_particles.ply", {"id", "velocity"});
}

TEST(VtkLegacyRealFiles, DoubleDamBreak) {
  const ParticleSet p = read_particles(test::data_file("double_dam_break_frame_26_4732_particles.vtk"));
  EXPECT_EQ(p.size(), 4732u);
  ASSERT_NE(find(p, "id"), nullptr);
  ASSERT_NE(find(p, "velocity"), nullptr);
  expect_all_finite(p);
  expect_same_as_ply(p, "double_dam_break_frame_26_4732_particles.ply", {"id", "velocity"});
}

TEST(VtkLegacyRealFiles, CubeWithBlankLineAndEmptyPointData) {
  const ParticleSet p = read_particles(test::data_file("cube_2366_particles.vtk"));
  EXPECT_EQ(p.size(), 2366u);
  EXPECT_TRUE(p.attributes.empty());
  expect_all_finite(p);
  expect_same_as_ply(p, "cube_2366_particles.ply", {});
}

TEST(VtkLegacyRealFiles, FreeParticles) {
  const ParticleSet p = read_particles(test::data_file("free_particles_1000_particles.vtk"));
  EXPECT_EQ(p.size(), 1000u);
  expect_all_finite(p);
  expect_same_as_ply(p, "free_particles_1000_particles.ply", {});
}

// ------------------------------------------------------------------------------------------------
// Hand-written variants: the same five particles in every layout must read identically.

const std::vector<float> kXyz = {0.5f, 1.25f, -2.0f, 3.0f, 0.125f, 7.5f, -1.0f, 0.0f, 2.5f,
                                 100.0f, -0.25f, 0.75f, 4.0f, 8.0f, -16.0f};
const std::vector<int> kIds = {10, 11, 12, 13, 14};
const std::vector<float> kVel = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
const std::vector<float> kRho = {1000, 1001.5f, 999.25f, 1000.125f, 998};

struct Layout {
  std::string name;
  bool binary;
  bool doubles;
  bool unstructured;
  bool v5;
};

std::string legacy_file(const Layout& l) {
  Encoder e{true, {}};
  const bool b = l.binary;
  auto text = [&](const std::string& s) { e.bytes += s; };
  auto floats = [&](const std::vector<float>& v, bool as_double) {
    if (b) {
      for (const float f : v) as_double ? (void)e.put(double(f)) : (void)e.put(f);
      text("\n");
    } else {
      for (std::size_t i = 0; i < v.size(); ++i) text(fmt::format("{}{}", v[i], i % 3 == 2 ? "\n" : " "));
      text("\n");
    }
  };
  auto ints = [&](const std::vector<int64_t>& v, bool as_64) {
    if (b) {
      for (const int64_t x : v) as_64 ? (void)e.put(x) : (void)e.put(int32_t(x));
      text("\n");
    } else {
      for (const int64_t x : v) text(fmt::format("{} ", x));
      text("\n");
    }
  };
  text(fmt::format("# vtk DataFile Version {}\ntest {}\n{}\n\nDATASET {}\n", l.v5 ? "5.1" : "4.1", l.name,
                   b ? "BINARY" : "ASCII", l.unstructured ? "UNSTRUCTURED_GRID" : "POLYDATA"));
  text(fmt::format("FIELD FieldData 1\nTIME 1 1 double\n"));
  floats({0.5f}, true);
  text(fmt::format("POINTS 5 {}\n", l.doubles ? "double" : "float"));
  floats(kXyz, l.doubles);
  text("METADATA\nINFORMATION 0\n\n");
  const char* cells = l.unstructured ? "CELLS" : "VERTICES";
  if (l.v5) {
    text(fmt::format("{} 6 5\nOFFSETS vtktypeint64\n", cells));
    ints({0, 1, 2, 3, 4, 5}, true);
    text("CONNECTIVITY vtktypeint64\n");
    ints({0, 1, 2, 3, 4}, true);
  } else {
    text(fmt::format("{} 5 10\n", cells));
    ints({1, 0, 1, 1, 1, 2, 1, 3, 1, 4}, false);
  }
  if (l.unstructured) {
    text("CELL_TYPES 5\n");
    ints({1, 1, 1, 1, 1}, false);
  }
  text("CELL_DATA 5\nSCALARS cellscalar int 1\nLOOKUP_TABLE default\n");
  ints({1, 2, 3, 4, 5}, false);
  text("POINT_DATA 5\nSCALARS id int 1\nLOOKUP_TABLE default\n");
  ints({kIds.begin(), kIds.end()}, false);
  text(fmt::format("VECTORS velocity {}\n", l.doubles ? "double" : "float"));
  floats(kVel, l.doubles);
  text("FIELD FieldData 1\n");
  text(fmt::format("rho 1 5 {}\n", l.doubles ? "double" : "float"));
  floats(kRho, l.doubles);
  return e.bytes;
}

TEST(VtkLegacyVariants, EveryLayoutReadsTheSameParticles) {
  TempDir dir;
  const Layout layouts[] = {
      {"ascii-float-polydata", false, false, false, false}, {"ascii-double-ugrid", false, true, true, false},
      {"binary-float-polydata", true, false, false, false}, {"binary-double-ugrid", true, true, true, false},
      {"ascii-v51-ugrid", false, false, true, true},        {"binary-v51-polydata", true, true, false, true},
      {"binary-v51-ugrid", true, false, true, true},
  };
  for (const Layout& l : layouts) {
    SCOPED_TRACE(l.name);
    const std::string path = dir.file(l.name + ".vtk");
    write_file(path, legacy_file(l));
    ReadReport report;
    const ParticleSet p = read_particles(path, {}, &report);
    EXPECT_NE(report.format.find(l.binary ? "binary" : "ascii"), std::string::npos) << report.format;
    ASSERT_EQ(p.size(), 5u);
    for (std::size_t i = 0; i < 5; ++i)
      for (int c = 0; c < 3; ++c) EXPECT_EQ(p.positions[i][c], kXyz[3 * i + std::size_t(c)]);
    ASSERT_EQ(p.attributes.size(), 3u);  // id, velocity, rho; cell data and the 1-tuple TIME are skipped
    EXPECT_EQ(p.attributes[0].name, "id");
    EXPECT_TRUE(p.attributes[0].integer);
    for (std::size_t i = 0; i < 5; ++i) EXPECT_EQ(p.attributes[0].values[i], float(kIds[i]));
    EXPECT_EQ(p.attributes[1].name, "velocity");
    EXPECT_EQ(p.attributes[1].components, 3);
    EXPECT_EQ(p.attributes[1].values, kVel);
    EXPECT_EQ(p.attributes[2].name, "rho");
    EXPECT_FALSE(p.attributes[2].integer);
    EXPECT_EQ(p.attributes[2].values, kRho);
  }
}

TEST(VtkLegacyVariants, ScalarsWithComponentsNormalsAndMissingLookupTable) {
  TempDir dir;
  const std::string path = dir.file("s.vtk");
  write_file(path,
             "# vtk DataFile Version 3.0\n\nASCII\nDATASET POLYDATA\nPOINTS 2 float\n0 0 0 1 1 1\n"
             "POINT_DATA 2\nSCALARS pair float 2\nLOOKUP_TABLE default\n1 2 3 4\n"
             "SCALARS flag unsigned_char\n7 8\nNORMALS n float\n0 0 1 0 1 0\n");
  const ParticleSet p = read_particles(path);
  ASSERT_EQ(p.size(), 2u);
  ASSERT_EQ(p.attributes.size(), 3u);
  EXPECT_EQ(p.attributes[0].components, 2);
  EXPECT_EQ(p.attributes[0].values, (std::vector<float>{1, 2, 3, 4}));
  EXPECT_EQ(p.attributes[1].name, "flag");
  EXPECT_TRUE(p.attributes[1].integer);
  EXPECT_EQ(p.attributes[1].values, (std::vector<float>{7, 8}));
  EXPECT_EQ(p.attributes[2].name, "n");
  EXPECT_EQ(p.attributes[2].components, 3);
}

// ------------------------------------------------------------------------------------------------
// Bad legacy input: FormatError naming the file and the line (ascii) or byte (binary)

TEST(VtkLegacyErrors, WrongMagicAndDataset) {
  TempDir dir;
  const std::string a = dir.file("a.vtk");
  write_file(a, "# vtk DataFile Versoin 4.1\nx\nASCII\nDATASET POLYDATA\n");
  expect_format_error([&] { read_particles(a); }, {a, "line 1", "magic"});
  const std::string b = dir.file("b.vtk");
  write_file(b, "# vtk DataFile Version 4.1\nx\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 2 2 2\n");
  expect_format_error([&] { read_particles(b); }, {b, "line 4", "STRUCTURED_POINTS"});
  const std::string c = dir.file("c.vtk");
  write_file(c, "# vtk DataFile Version 4.1\nx\nTEXT\nDATASET POLYDATA\n");
  expect_format_error([&] { read_particles(c); }, {c, "line 3", "ASCII or BINARY"});
}

TEST(VtkLegacyErrors, TruncatedBinaryAndCountsLargerThanTheFile) {
  TempDir dir;
  const std::string full = legacy_file({"t", true, false, true, false});
  const std::string cut = dir.file("cut.vtk");
  write_file(cut, full.substr(0, full.find("POINTS 5 float\n") + 15 + 20));
  expect_format_error([&] { read_particles(cut); }, {cut, "byte ", "POINTS", "left"});

  std::string huge = full;
  huge.replace(huge.find("POINTS 5 float"), 14, "POINTS 4000000000 float");
  const std::string big = dir.file("big.vtk");
  write_file(big, huge);
  expect_format_error([&] { read_particles(big); }, {big, "byte ", "4000000000"});

  const std::string overflow = dir.file("overflow.vtk");
  write_file(overflow, "# vtk DataFile Version 4.1\nx\nBINARY\nDATASET POLYDATA\nPOINTS 18446744073709551615 float\n");
  expect_format_error([&] { read_particles(overflow); }, {overflow, "overflows"});

  std::string mismatch = full;
  mismatch.replace(mismatch.find("POINT_DATA 5"), 12, "POINT_DATA 6");
  const std::string pd = dir.file("pd.vtk");
  write_file(pd, mismatch);
  expect_format_error([&] { read_particles(pd); }, {pd, "POINT_DATA 5"});
}

TEST(VtkLegacyErrors, AsciiBadTokenAndUnknownKeyword) {
  TempDir dir;
  const std::string a = dir.file("a.vtk");
  write_file(a, "# vtk DataFile Version 4.1\nx\nASCII\nDATASET POLYDATA\nPOINTS 2 float\n0 0 0\n1 oops 1\n");
  expect_format_error([&] { read_particles(a); }, {a, "line 7", "'oops'"});
  const std::string b = dir.file("b.vtk");
  write_file(b, "# vtk DataFile Version 4.1\nx\nASCII\nDATASET POLYDATA\nPOINTS 1 float\n0 0 0\nBOGUS 3\n");
  expect_format_error([&] { read_particles(b); }, {b, "line 7", "BOGUS"});
  const std::string c = dir.file("c.vtk");
  write_file(c, "# vtk DataFile Version 4.1\nx\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0\n");
  expect_format_error([&] { read_particles(c); }, {c, "line 6", "expected 9 values"});
  const std::string d = dir.file("d.vtk");
  write_file(d, "# vtk DataFile Version 4.1\nx\nASCII\nDATASET POLYDATA\nPOINTS 1 quaternion\n0 0 0\n");
  expect_format_error([&] { read_particles(d); }, {d, "line 5", "quaternion"});
}

TEST(VtkLegacyErrors, NanCoordinatesAreRefusedOrDroppedByTheIoLayer) {
  TempDir dir;
  const std::string a = dir.file("nan.vtk");
  write_file(a, "# vtk DataFile Version 4.1\nx\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0\nnan 1 1\n2 2 2\n");
  expect_format_error([&] { read_particles(a); }, {a, "particle 1", "finite"});
  ReadOptions options;
  options.drop_invalid = true;
  ReadReport report;
  const ParticleSet p = read_particles(a, options, &report);
  EXPECT_EQ(p.size(), 2u);
  EXPECT_EQ(report.dropped_invalid, 1u);
}

TEST(VtkLegacyErrors, EveryPrefixOfABinaryFileFailsCleanly) {
  // Truncation anywhere must be a FormatError (never a crash or an accepted short file).
  TempDir dir;
  const std::string full = legacy_file({"p", true, true, true, true});
  const std::string path = dir.file("prefix.vtk");
  for (std::size_t n = 0; n < full.size(); n += 7) {
    write_file(path, full.substr(0, n));
    try {
      const ParticleSet p = read_particles(path);
      // A cut inside trailing data sections may leave a complete, smaller file: still 5 particles.
      EXPECT_EQ(p.size(), 5u) << n;
    } catch (const FormatError&) {
    }
  }
}

// ------------------------------------------------------------------------------------------------
// VTK XML

TEST(VtuRealFiles, Fluid250AppendedRawZlibUInt64) {
  ReadReport report;
  const ParticleSet p = read_particles(test::data_file("fluid_250_particles.vtu"), {}, &report);
  EXPECT_EQ(p.size(), 250u);
  ASSERT_EQ(p.attributes.size(), 4u);
  EXPECT_EQ(p.attributes[0].name, "velocity");
  EXPECT_EQ(p.attributes[0].components, 3);
  EXPECT_EQ(p.attributes[1].name, "pressure");
  EXPECT_EQ(p.attributes[2].name, "density");
  EXPECT_EQ(p.attributes[3].name, "index");
  EXPECT_TRUE(p.attributes[3].integer);
  EXPECT_NE(report.format.find("zlib"), std::string::npos) << report.format;
  expect_all_finite(p);
  expect_same_as_ply(p, "fluid_250_particles.ply", {"velocity", "pressure", "density"});
  const Attribute* index = p.find("index");
  const ParticleSet ply = read_particles(test::data_file("ply/fluid_250_particles.ply"));
  EXPECT_EQ(index->values, ply.find("index")->values);
}

std::string base64(const std::string& bytes) {
  static const char* table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t v = uint32_t(uint8_t(bytes[i])) << 16 | uint32_t(uint8_t(bytes[i + 1])) << 8 | uint8_t(bytes[i + 2]);
    for (int k = 3; k >= 0; --k) out.push_back(table[(v >> (6 * k)) & 63]);
  }
  if (i < bytes.size()) {
    uint32_t v = uint32_t(uint8_t(bytes[i])) << 16;
    if (i + 1 < bytes.size()) v |= uint32_t(uint8_t(bytes[i + 1])) << 8;
    out.push_back(table[(v >> 18) & 63]);
    out.push_back(table[(v >> 12) & 63]);
    out.push_back(i + 1 < bytes.size() ? table[(v >> 6) & 63] : '=');
    out.push_back('=');
  }
  return out;
}

struct VtuCase {
  std::string format;  // ascii, binary, appended-raw, appended-base64
  bool zlib;
  bool uint64;
  bool doubles;
  bool big_endian;
};

struct Blob {
  std::string header, data;
};

// vtkXMLWriter's blob: [count][data], or with zlib [blocks, block size, last size, sizes…][blocks]
// with deliberately small 40-byte blocks so several blocks and a partial last one are exercised.
Blob make_blob(const std::string& raw, const VtuCase& c) {
  Encoder e{c.big_endian, {}};
  auto head = [&](uint64_t v) { c.uint64 ? (void)e.put(v) : (void)e.put(uint32_t(v)); };
  if (!c.zlib) {
    head(raw.size());
    return {e.bytes, raw};
  }
  const std::size_t block = 40;
  const std::size_t blocks = (raw.size() + block - 1) / block;
  std::string data;
  std::vector<uint64_t> sizes;
  for (std::size_t b = 0; b < blocks; ++b) {
    const std::string part = raw.substr(b * block, block);
    uLongf n = compressBound(uLong(part.size()));
    std::string out(n, '\0');
    EXPECT_EQ(compress(reinterpret_cast<Bytef*>(out.data()), &n, reinterpret_cast<const Bytef*>(part.data()),
                       uLong(part.size())),
              Z_OK);
    data += out.substr(0, n);
    sizes.push_back(n);
  }
  head(blocks);
  head(block);
  head(raw.size() % block);
  for (const uint64_t s : sizes) head(s);
  return {e.bytes, data};
}

std::string vtu_file(const VtuCase& c) {
  struct Array {
    std::string name, section;
    int components;
    bool integer;
    std::vector<float> values;
  };
  const std::vector<Array> arrays = {
      {"Points", "Points", 3, false, kXyz}, {"id", "PointData", 1, true, {10, 11, 12, 13, 14}},
      {"velocity", "PointData", 3, false, kVel}, {"rho", "PointData", 1, false, kRho}};
  std::string xml = fmt::format(
      "<?xml version=\"1.0\"?>\n<!-- a comment with <tags> -->\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" "
      "byte_order=\"{}\" header_type=\"{}\"{}>\n  <UnstructuredGrid>\n    <Piece NumberOfPoints=\"5\" "
      "NumberOfCells=\"0\">\n",
      c.big_endian ? "BigEndian" : "LittleEndian", c.uint64 ? "UInt64" : "UInt32",
      c.zlib ? " compressor=\"vtkZLibDataCompressor\"" : "");
  std::string appended;
  std::string section;
  for (const Array& a : arrays) {
    if (a.section != section) {
      if (!section.empty()) xml += fmt::format("      </{}>\n", section);
      section = a.section;
      xml += fmt::format("      <{}>\n", section);
    }
    const std::string type = a.integer ? "Int32" : c.doubles ? "Float64" : "Float32";
    Encoder raw{c.big_endian, {}};
    for (const float v : a.values) a.integer ? (void)raw.put(int32_t(v)) : c.doubles ? (void)raw.put(double(v)) : (void)raw.put(v);
    const Blob blob = make_blob(raw.bytes, c);
    const std::string encoded = c.zlib ? base64(blob.header) + base64(blob.data) : base64(blob.header + blob.data);
    std::string attrs = fmt::format("type=\"{}\" Name=\"{}\" NumberOfComponents=\"{}\"", type, a.name, a.components);
    if (c.format == "ascii") {
      std::string text;
      for (const float v : a.values) text += fmt::format(" {}", v);
      xml += fmt::format("        <DataArray {} format=\"ascii\">\n{}\n        </DataArray>\n", attrs, text);
    } else if (c.format == "binary") {
      xml += fmt::format("        <DataArray {} format=\"binary\">\n          {}\n        </DataArray>\n", attrs, encoded);
    } else {
      xml += fmt::format("        <DataArray {} format=\"appended\" offset=\"{}\"/>\n", attrs, appended.size());
      appended += c.format == "appended-raw" ? blob.header + blob.data : encoded;
    }
  }
  xml += fmt::format("      </{}>\n    </Piece>\n  </UnstructuredGrid>\n", section);
  if (c.format.starts_with("appended"))
    xml += fmt::format("  <AppendedData encoding=\"{}\">\n   _{}\n  </AppendedData>\n",
                       c.format == "appended-raw" ? "raw" : "base64", appended);
  xml += "</VTKFile>\n";
  return xml;
}

TEST(VtuEncodings, EveryEncodingReadsTheSameParticles) {
  TempDir dir;
  int n = 0;
  for (const std::string format : {"ascii", "binary", "appended-raw", "appended-base64"})
    for (const bool zlib : {false, true})
      for (const bool uint64 : {false, true})
        for (const bool doubles : {false, true})
          for (const bool big : {false, true}) {
            if (format == "ascii" && (zlib || uint64 || big)) continue;
            const VtuCase c{format, zlib, uint64, doubles, big};
            SCOPED_TRACE(fmt::format("{} zlib={} uint64={} doubles={} big={}", format, zlib, uint64, doubles, big));
            const std::string path = dir.file(fmt::format("case{}.vtu", n++));
            write_file(path, vtu_file(c));
            ReadReport report;
            ParticleSet p;
            ASSERT_NO_THROW(p = read_particles(path, {}, &report));
            ASSERT_EQ(p.size(), 5u);
            for (std::size_t i = 0; i < 5; ++i)
              for (int k = 0; k < 3; ++k) EXPECT_EQ(p.positions[i][k], kXyz[3 * i + std::size_t(k)]);
            ASSERT_EQ(p.attributes.size(), 3u);
            EXPECT_EQ(p.attributes[0].name, "id");
            EXPECT_TRUE(p.attributes[0].integer);
            EXPECT_EQ(p.attributes[0].values, (std::vector<float>{10, 11, 12, 13, 14}));
            EXPECT_EQ(p.attributes[1].values, kVel);
            EXPECT_EQ(p.attributes[2].values, kRho);
            EXPECT_EQ(report.format.find("zlib") != std::string::npos, zlib) << report.format;
          }
  EXPECT_EQ(n, 2 + 3 * 16);
}

TEST(VtuErrors, TruncatedAndOversizedData) {
  TempDir dir;
  const std::string raw = vtu_file({"appended-raw", true, true, false, false});
  const std::string cut = dir.file("cut.vtu");
  write_file(cut, raw.substr(0, raw.size() - 60));
  expect_format_error([&] { read_particles(cut); }, {cut, "byte ", "rho"});

  std::string more = vtu_file({"appended-raw", false, false, false, false});
  more.replace(more.find("NumberOfPoints=\"5\""), 18, "NumberOfPoints=\"500000000\"");
  const std::string big = dir.file("big.vtu");
  write_file(big, more);
  expect_format_error([&] { read_particles(big); }, {big, "byte ", "Points"});

  const std::string b64 = vtu_file({"binary", true, false, true, false});
  const std::string b64cut = dir.file("b64cut.vtu");
  std::string broken = b64;
  const std::size_t at = broken.find("format=\"binary\">") + 30;
  broken[at] = '*';
  write_file(b64cut, broken);
  expect_format_error([&] { read_particles(b64cut); }, {b64cut, "byte ", "base64"});
}

TEST(VtuErrors, CompressionHeaderCannotForceAHugeAllocation) {
  TempDir dir;
  Encoder header{false, {}};
  header.put(uint64_t(1)).put(uint64_t(12000000000)).put(uint64_t(12000000000)).put(uint64_t(10));
  const std::string path = dir.file("bomb.vtu");
  write_file(path, "<VTKFile type=\"PolyData\" byte_order=\"LittleEndian\" header_type=\"UInt64\" "
                   "compressor=\"vtkZLibDataCompressor\"><PolyData><Piece NumberOfPoints=\"1000000000\"><Points>"
                   "<DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"appended\" offset=\"0\"/></Points>"
                   "</Piece></PolyData><AppendedData encoding=\"raw\">_" +
                       header.bytes + std::string(10, 'x') + "</AppendedData></VTKFile>");
  expect_format_error([&] { read_particles(path); }, {path, "byte ", "cannot inflate to the 12000000000 bytes"});
}

TEST(VtuErrors, UnsupportedCompressorMissingPointsAndBadXml) {
  TempDir dir;
  std::string lz4 = vtu_file({"binary", true, false, false, false});
  lz4.replace(lz4.find("vtkZLibDataCompressor"), 21, "vtkLZ4DataCompressor");
  const std::string a = dir.file("lz4.vtu");
  write_file(a, lz4);
  expect_format_error([&] { read_particles(a); }, {a, "byte ", "vtkLZ4DataCompressor"});

  const std::string b = dir.file("nopoints.vtu");
  write_file(b, "<VTKFile type=\"PolyData\"><PolyData><Piece NumberOfPoints=\"1\"></Piece></PolyData></VTKFile>");
  expect_format_error([&] { read_particles(b); }, {b, "byte ", "<Points>"});

  const std::string c = dir.file("bad.vtu");
  write_file(c, "<VTKFile type=\"PolyData\"><PolyData><Piece NumberOfPoints=\"1\"></PolyData></VTKFile>");
  expect_format_error([&] { read_particles(c); }, {c, "byte ", "</Piece>"});

  const std::string d = dir.file("ascii.vtu");
  write_file(d, "<VTKFile type=\"PolyData\"><PolyData><Piece NumberOfPoints=\"2\"><Points><DataArray type=\"Float32\" "
                "NumberOfComponents=\"3\" format=\"ascii\">0 0 0 1 1</DataArray></Points></Piece></PolyData></VTKFile>");
  expect_format_error([&] { read_particles(d); }, {d, "byte ", "expected 6"});
}

TEST(VtuErrors, EveryPrefixFailsCleanly) {
  TempDir dir;
  const std::string full = vtu_file({"appended-raw", true, false, true, true});
  const std::string path = dir.file("prefix.vtu");
  for (std::size_t n = 0; n < full.size(); n += 5) {
    write_file(path, full.substr(0, n));
    try {
      const ParticleSet p = read_particles(path);
      EXPECT_EQ(p.size(), 5u);
    } catch (const FormatError&) {
    }
  }
}

}  // namespace
}  // namespace meniscus
