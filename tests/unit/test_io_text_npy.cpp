// meniscus tests — delimited text (.csv/.txt) and NumPy .npy particle readers.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <initializer_list>
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

void gzip_file(const std::string& path, const std::string& bytes) {
  gzFile gz = gzopen(path.c_str(), "wb");
  ASSERT_NE(gz, nullptr);
  ASSERT_EQ(gzwrite(gz, bytes.data(), unsigned(bytes.size())), int(bytes.size()));
  ASSERT_EQ(gzclose(gz), Z_OK);
}

void expect_positions(const ParticleSet& p, const std::vector<float>& xyz) {
  ASSERT_EQ(p.size() * 3, xyz.size());
  for (std::size_t i = 0; i < p.size(); ++i)
    for (int c = 0; c < 3; ++c) EXPECT_EQ(p.positions[i][c], xyz[3 * i + std::size_t(c)]) << i << "," << c;
}

// ------------------------------------------------------------------------------------------------
// CSV / TXT

TEST(CsvRealFiles, SphysicsIpartWithColumnsOption) {
  ReadOptions options;
  options.columns = {"x", "y", "z", "vx", "vy", "vz", "rho", "p", "mass"};
  ReadReport report;
  const ParticleSet p = read_particles(test::data_file("sphysics_dam_break_IPART_29814_particles.txt.gz"), options, &report);
  EXPECT_EQ(p.size(), 29814u);
  ASSERT_EQ(p.attributes.size(), 4u);
  EXPECT_EQ(p.attributes[0].name, "velocity");
  EXPECT_EQ(p.attributes[0].components, 3);
  EXPECT_EQ(p.attributes[1].name, "rho");
  EXPECT_EQ(p.attributes[2].name, "p");
  EXPECT_EQ(p.attributes[3].name, "mass");
  EXPECT_NE(report.format.find("gzip"), std::string::npos) << report.format;
  // The PLY conversion (numpy float64 → float32) must agree bit for bit.
  const ParticleSet ply = read_particles(test::data_file("ply/sphysics_dam_break_IPART_29814_particles.ply"));
  ASSERT_EQ(ply.size(), p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    ASSERT_TRUE(std::isfinite(p.positions[i].x) && std::isfinite(p.positions[i].y) && std::isfinite(p.positions[i].z));
    for (int c = 0; c < 3; ++c) ASSERT_TRUE(same_bits(p.positions[i][c], ply.positions[i][c])) << i;
  }
  EXPECT_EQ(p.find("velocity")->values, ply.find("velocity")->values);
  EXPECT_EQ(p.find("rho")->values, ply.find("density")->values);
  EXPECT_EQ(p.find("mass")->values, ply.find("mass")->values);
}

TEST(CsvRealFiles, HeaderlessWithoutColumnsNamesTheFix) {
  expect_format_error([] { read_particles(test::data_file("sphysics_dam_break_IPART_29814_particles.txt.gz")); },
                      {"line 1", "header", "give columns = x,y,z"});
}

TEST(CsvHeader, CommaSemicolonWhitespaceAndParaViewNames) {
  TempDir dir;
  struct Case {
    std::string name, text;
  };
  const Case cases[] = {
      {"comma.csv", "x,y,z,vx,vy,vz,id\n0.5,1,2,0.1,0.2,0.3,7\n-1,-2.5e1,3,1,2,3,8\n"},
      {"quoted.csv", "\"X\", \"Y\", \"Z\", \"vx\", \"vy\", \"vz\", \"id\"\r\n0.5, 1, 2, 0.1, 0.2, 0.3, 7\r\n-1, -25, 3, 1, 2, 3, 8\r\n"},
      {"semi.csv", "x;y;z;u;v;w;id\n0.5;1;2;0.1;0.2;0.3;7\n\n-1;-25;+3;1;2;3;8\n"},
      {"space.txt", "# x y z vx vy vz id\n0.5 1 2 0.1 0.2 0.3 7\n# a comment\n  -1\t-25  3 1 2 3 8  \n"},
      {"paraview.csv", "\"Points:0\",\"Points:1\",\"Points:2\",\"velocity:0\",\"velocity:1\",\"velocity:2\",\"id\"\n"
                       "0.5,1,2,0.1,0.2,0.3,7\n-1,-25,3,1,2,3,8\n"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string path = dir.file(c.name);
    write_file(path, c.text);
    const ParticleSet p = read_particles(path);
    expect_positions(p, {0.5f, 1, 2, -1, -25, 3});
    ASSERT_EQ(p.attributes.size(), 2u);
    EXPECT_EQ(p.attributes[0].name, "velocity");
    EXPECT_EQ(p.attributes[0].components, 3);
    EXPECT_FALSE(p.attributes[0].integer);
    EXPECT_EQ(p.attributes[0].values, (std::vector<float>{0.1f, 0.2f, 0.3f, 1, 2, 3}));
    EXPECT_EQ(p.attributes[1].name, "id");
    EXPECT_TRUE(p.attributes[1].integer);
    EXPECT_EQ(p.attributes[1].values, (std::vector<float>{7, 8}));
  }
}

TEST(CsvHeader, ColumnsOptionOverridesAHeaderAndGzipIsTransparent) {
  TempDir dir;
  const std::string path = dir.file("data.csv.gz");
  gzip_file(path, "a,b,c,d\n1,2,3,4\n5,6,7,8\n");
  ReadOptions options;
  options.columns = {"x", "y", "z", "density"};
  const ParticleSet p = read_particles(path, options);
  expect_positions(p, {1, 2, 3, 5, 6, 7});
  ASSERT_EQ(p.attributes.size(), 1u);
  EXPECT_EQ(p.attributes[0].name, "density");
  EXPECT_EQ(p.attributes[0].values, (std::vector<float>{4, 8}));
}

// Names that differ only in case group as before: each group takes the first column of each
// lower-case name still free, in column order.
TEST(CsvHeader, CaseVariantsOfAVectorGroupInColumnOrder) {
  TempDir dir;
  const std::string path = dir.file("cases.csv");
  write_file(path, "x,y,z,A_x,a_x,A_y,a_Y,A_z,a_z,B:0,b:0,B:1\n0,0,0,1,2,3,4,5,6,7,8,9\n");
  const ParticleSet p = read_particles(path);
  std::vector<std::string> names;
  for (const Attribute& a : p.attributes) names.push_back(a.name + "/" + std::to_string(a.components));
  EXPECT_EQ(names, (std::vector<std::string>{"A/3", "a/3", "B/2", "b:0/1"}));
  EXPECT_EQ(p.find("A")->values, (std::vector<float>{1, 3, 5}));
  EXPECT_EQ(p.find("a")->values, (std::vector<float>{2, 4, 6}));
  EXPECT_EQ(p.find("B")->values, (std::vector<float>{7, 9}));
}

// The 6,859-particle frame as CSV text: x,y,z and every component of its attributes.
std::string frame_as_csv(const ParticleSet& p) {
  std::string text = "x,y,z";
  for (const Attribute& a : p.attributes)
    for (int c = 0; c < a.components; ++c)
      text += a.components == 1 ? "," + a.name : fmt::format(",{}_{}", a.name, "xyz"[c]);
  text += "\n";
  for (std::size_t i = 0; i < p.size(); ++i) {
    text += fmt::format("{},{},{}", p.positions[i].x, p.positions[i].y, p.positions[i].z);
    for (const Attribute& a : p.attributes)
      for (int c = 0; c < a.components; ++c) text += fmt::format(",{}", a.values[i * std::size_t(a.components) + std::size_t(c)]);
    text += "\n";
  }
  return text;
}

// A header of 12,000 columns named like vector components that never complete a vector
// (a0_x, a1_x, …): reading it costs about what reading text of its size costs (the frame's, per
// byte), not the square of its columns.
TEST(CsvHeader, AWideHeaderReadsInTimeLinearInItsSize) {
  TempDir dir;
  const ParticleSet frame = read_particles(test::data_file("ply/dam_break_frame_9_6859_particles.ply"));
  const std::string reference = frame_as_csv(frame);
  write_file(dir.file("frame.csv"), reference);
  constexpr std::size_t kColumns = 12000, kRows = 4;
  std::string wide = "x,y,z";
  for (std::size_t c = 0; c < kColumns; ++c) wide += fmt::format(",a{}_x", c);
  wide += "\n";
  for (std::size_t r = 0; r < kRows; ++r) {
    wide += fmt::format("{},0,0", r);
    for (std::size_t c = 0; c < kColumns; ++c) wide += fmt::format(",{}", (c + r) % 10);
    wide += "\n";
  }
  write_file(dir.file("wide.csv"), wide);

  ParticleSet p;
  const double t_frame = test::fastest_seconds(3, [&] { EXPECT_EQ(read_particles(dir.file("frame.csv")).size(), 6859u); });
  const double t_wide = test::fastest_seconds(3, [&] { p = read_particles(dir.file("wide.csv")); });
  ASSERT_EQ(p.size(), kRows);
  ASSERT_EQ(p.attributes.size(), kColumns);
  for (const std::size_t c : {std::size_t(0), std::size_t(4321), kColumns - 1}) {
    EXPECT_EQ(p.attributes[c].name, fmt::format("a{}_x", c));
    EXPECT_EQ(p.attributes[c].values, (std::vector<float>{float(c % 10), float((c + 1) % 10), float((c + 2) % 10),
                                                          float((c + 3) % 10)}));
  }
  // Per byte, within a bound of the frame's text: a name costs a few allocations and lookups where
  // a value costs a parse, so the bound leaves room for many times the frame's cost a byte (more
  // under ASan, whose allocator is slower); a scan per name costs the square of the names.
  const double per_byte = (t_wide / double(wide.size())) / (t_frame / double(reference.size()));
  RecordProperty("seconds_frame", std::to_string(t_frame));
  RecordProperty("seconds_wide", std::to_string(t_wide));
  EXPECT_LT(per_byte, test::kSanitized ? 100.0 : 40.0)
      << t_wide << " s for the " << wide.size() << " bytes of the wide header, " << t_frame << " s for the "
      << reference.size() << " bytes of the frame";
}

TEST(CsvErrors, AnAbsurdColumnCountIsRefusedWithItsNumber) {
  TempDir dir;
  const std::string path = dir.file("columns.csv");
  // A million and one empty names fit in a short line: refused before any is made.
  write_file(path, "x,y,z" + std::string(1'000'001, ',') + "a\n0,0,0\n");
  expect_format_error([&] { read_particles(path); }, {path, "line 1", "at most 1000000 columns, found 1000004"});
}

TEST(CsvErrors, BadTokenNamesLineAndColumn) {
  TempDir dir;
  const std::string path = dir.file("bad.csv");
  write_file(path, "x,y,z\n1,2,3\n4,abc,6\n");
  expect_format_error([&] { read_particles(path); }, {path, "line 3, column 2", "'y'", "'abc'"});
  const std::string empty_field = dir.file("empty.csv");
  write_file(empty_field, "x,y,z\n1,,3\n");
  expect_format_error([&] { read_particles(empty_field); }, {empty_field, "line 2, column 2"});
}

TEST(CsvErrors, MissingColumnShortRowDuplicateNamesAndEmptyFile) {
  TempDir dir;
  const std::string a = dir.file("a.csv");
  write_file(a, "x,y,vx\n1,2,3\n");
  expect_format_error([&] { read_particles(a); }, {a, "line 1", "x, y and z", "vx"});
  const std::string b = dir.file("b.csv");
  write_file(b, "x,y,z,rho\n1,2,3,4\n1,2,3\n");
  expect_format_error([&] { read_particles(b); }, {b, "line 3", "expected 4 fields", "found 3"});
  const std::string c = dir.file("c.csv");
  write_file(c, "x,y,z,x\n1,2,3,4\n");
  expect_format_error([&] { read_particles(c); }, {c, "line 1", "'x' appears twice"});
  const std::string d = dir.file("d.csv");
  write_file(d, "\n\n");
  expect_format_error([&] { read_particles(d); }, {d, "no text lines"});
  const std::string e = dir.file("e.csv");
  write_file(e, "x,y,z\n");
  expect_format_error([&] { read_particles(e); }, {e, "no particles"});
  ReadOptions options;
  options.columns = {"x", "y"};
  const std::string f = dir.file("f.txt");
  write_file(f, "1 2\n");
  expect_format_error([&] { read_particles(f, options); }, {f, "found columns (x, y)"});
}

TEST(CsvErrors, NanIsHandledByTheIoLayer) {
  TempDir dir;
  const std::string path = dir.file("nan.csv");
  write_file(path, "x,y,z\n1,2,3\nnan,0,0\ninf,1,1\n4,5,6\n");
  expect_format_error([&] { read_particles(path); }, {path, "particle 1", "finite"});
  ReadOptions options;
  options.drop_invalid = true;
  const ParticleSet p = read_particles(path, options);
  expect_positions(p, {1, 2, 3, 4, 5, 6});
}

// ------------------------------------------------------------------------------------------------
// NPY

struct Npy {
  std::string header;  // the dict text
  std::string data;
  int major = 1;

  std::string bytes() const {
    std::string out("\x93NUMPY", 6);
    out.push_back(char(major));
    out.push_back(0);
    const std::size_t prefix = 6 + 2 + (major == 1 ? 2 : 4);
    std::string dict = header;
    // numpy pads the header with spaces to a multiple of 64 and ends it with '\n'.
    while ((prefix + dict.size() + 1) % 64 != 0) dict.push_back(' ');
    dict.push_back('\n');
    const std::size_t n = dict.size();
    if (major == 1) {
      out.push_back(char(n & 0xff));
      out.push_back(char(n >> 8));
    } else {
      for (int i = 0; i < 4; ++i) out.push_back(char((n >> (8 * i)) & 0xff));
    }
    return out + dict + data;
  }
};

template <class T>
void put(std::string& out, T v, bool big = false) {
  unsigned char raw[sizeof(T)];
  std::memcpy(raw, &v, sizeof(T));
  if (big != (std::endian::native == std::endian::big))
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(raw[i], raw[sizeof(T) - 1 - i]);
  out.append(reinterpret_cast<const char*>(raw), sizeof(T));
}

const std::vector<float> kXyz = {0.5f, 1, 2, 3, -4, 5.25f, 6, 7, -8};

TEST(NpyArrays, Float32AndFloat64EitherEndianAndEveryVersion) {
  TempDir dir;
  int n = 0;
  for (const bool doubles : {false, true})
    for (const bool big : {false, true})
      for (const int major : {1, 2, 3}) {
        SCOPED_TRACE(fmt::format("doubles={} big={} v{}", doubles, big, major));
        Npy npy;
        npy.major = major;
        npy.header = fmt::format("{{'descr': '{}{}', 'fortran_order': False, 'shape': (3, 3), }}", big ? '>' : '<',
                                 doubles ? "f8" : "f4");
        for (const float v : kXyz) doubles ? put(npy.data, double(v), big) : put(npy.data, v, big);
        const std::string path = dir.file(fmt::format("a{}.npy", n++));
        write_file(path, npy.bytes());
        const ParticleSet p = read_particles(path);
        expect_positions(p, kXyz);
        EXPECT_TRUE(p.attributes.empty());
      }
}

TEST(NpyArrays, ExtraColumnsAndFortranOrder) {
  TempDir dir;
  // (2, 5) array: x y z a b per row.
  const std::vector<float> rows = {1, 2, 3, 10, 20, 4, 5, 6, 40, 50};
  Npy c;
  c.header = "{'descr': '<f4', 'fortran_order': False, 'shape': (2, 5), }";
  for (const float v : rows) put(c.data, v);
  Npy f;
  f.header = "{'descr': '<f4', 'fortran_order': True, 'shape': (2, 5), }";
  for (std::size_t col = 0; col < 5; ++col)
    for (std::size_t row = 0; row < 2; ++row) put(f.data, rows[row * 5 + col]);
  for (const Npy* npy : {&c, &f}) {
    const std::string path = dir.file(npy == &c ? "c.npy" : "f.npy");
    write_file(path, npy->bytes());
    const ParticleSet p = read_particles(path);
    expect_positions(p, {1, 2, 3, 4, 5, 6});
    ASSERT_EQ(p.attributes.size(), 1u);
    EXPECT_EQ(p.attributes[0].name, "values");
    EXPECT_EQ(p.attributes[0].components, 2);
    EXPECT_EQ(p.attributes[0].values, (std::vector<float>{10, 20, 40, 50}));
  }
}

TEST(NpyStructured, FieldsXyzAndPositionSubarray) {
  TempDir dir;
  Npy a;
  a.header = "{'descr': [('x', '<f4'), ('y', '<f4'), ('z', '<f4'), ('vx', '<f8'), ('vy', '<f8'), ('vz', '<f8'), "
             "('id', '<i8'), ('', '|V4')], 'fortran_order': False, 'shape': (3,), }";
  for (std::size_t i = 0; i < 3; ++i) {
    for (int c = 0; c < 3; ++c) put(a.data, kXyz[3 * i + std::size_t(c)]);
    for (int c = 0; c < 3; ++c) put(a.data, double(i) + 0.5 * c);
    put(a.data, int64_t(100 + i));
    put(a.data, int32_t(0));  // padding
  }
  const std::string pa = dir.file("a.npy");
  write_file(pa, a.bytes());
  const ParticleSet p = read_particles(pa);
  expect_positions(p, kXyz);
  ASSERT_EQ(p.attributes.size(), 2u);
  EXPECT_EQ(p.attributes[0].name, "velocity");
  EXPECT_EQ(p.attributes[0].values, (std::vector<float>{0, 0.5f, 1, 1, 1.5f, 2, 2, 2.5f, 3}));
  EXPECT_EQ(p.attributes[1].name, "id");
  EXPECT_TRUE(p.attributes[1].integer);
  EXPECT_EQ(p.attributes[1].values, (std::vector<float>{100, 101, 102}));

  Npy b;
  b.major = 2;
  b.header = "{'descr': [('P', '>f8', (3,)), ('density', '>f4')], 'fortran_order': True, 'shape': (3,), }";
  for (std::size_t i = 0; i < 3; ++i) {
    for (int c = 0; c < 3; ++c) put(b.data, double(kXyz[3 * i + std::size_t(c)]), true);
    put(b.data, 1000.0f + float(i), true);
  }
  const std::string pb = dir.file("b.npy");
  write_file(pb, b.bytes());
  const ParticleSet q = read_particles(pb);
  expect_positions(q, kXyz);
  ASSERT_EQ(q.attributes.size(), 1u);
  EXPECT_EQ(q.attributes[0].name, "density");
  EXPECT_EQ(q.attributes[0].values, (std::vector<float>{1000, 1001, 1002}));
}

TEST(NpyErrors, TruncatedShapeMismatchAndBadHeaders) {
  TempDir dir;
  Npy good;
  good.header = "{'descr': '<f4', 'fortran_order': False, 'shape': (3, 3), }";
  for (const float v : kXyz) put(good.data, v);
  const std::string full = good.bytes();

  const std::string cut = dir.file("cut.npy");
  write_file(cut, full.substr(0, full.size() - 5));
  expect_format_error([&] { read_particles(cut); }, {cut, "byte 128", "9 × 4 bytes", "only 31 bytes"});

  Npy longer = good;
  longer.header = "{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3), }";
  const std::string mismatch = dir.file("mismatch.npy");
  write_file(mismatch, longer.bytes());
  expect_format_error([&] { read_particles(mismatch); }, {mismatch, "byte 128", "shape does not match"});

  Npy huge = good;
  huge.header = "{'descr': '<f4', 'fortran_order': False, 'shape': (4611686018427387904, 3), }";
  const std::string big = dir.file("big.npy");
  write_file(big, huge.bytes());
  expect_format_error([&] { read_particles(big); }, {big, "byte"});

  const std::string magic = dir.file("magic.npy");
  write_file(magic, "\x93NUMPZ" + full.substr(6));
  expect_format_error([&] { read_particles(magic); }, {magic, "byte 0", "magic"});

  struct Bad {
    std::string header, fragment;
  };
  const Bad bads[] = {
      {"{'descr': '<i4', 'fortran_order': False, 'shape': (3, 3), }", "float32 or float64"},
      {"{'descr': '<f4', 'fortran_order': False, 'shape': (9,), }", "2-D shape"},
      {"{'descr': '<f4', 'shape': (3, 3), }", "fortran_order"},
      {"{'descr': '<f4', 'fortran_order': False, 'shape': (3, 3), ", "expected"},
      {"{'descr': [('a', '<f4'), ('b', '<f4'), ('c', '<f4')], 'fortran_order': False, 'shape': (3,), }", "fields x, y, z"},
      {"{'descr': '<c8', 'fortran_order': False, 'shape': (3, 3), }", "numeric dtype"},
      {std::string(30, '('), "nesting"},
  };
  int n = 0;
  for (const Bad& bad : bads) {
    SCOPED_TRACE(bad.header);
    Npy npy = good;
    npy.header = bad.header;
    const std::string path = dir.file(fmt::format("bad{}.npy", n++));
    write_file(path, npy.bytes());
    expect_format_error([&] { read_particles(path); }, {path, "byte", bad.fragment});
  }
}

TEST(NpyErrors, EveryPrefixFailsCleanly) {
  TempDir dir;
  Npy npy;
  npy.major = 3;
  npy.header = "{'descr': [('P', '<f4', (3,)), ('id', '<u4')], 'fortran_order': False, 'shape': (3,), }";
  for (std::size_t i = 0; i < 3; ++i) {
    for (int c = 0; c < 3; ++c) put(npy.data, kXyz[3 * i + std::size_t(c)]);
    put(npy.data, uint32_t(i));
  }
  const std::string full = npy.bytes();
  const std::string path = dir.file("p.npy");
  write_file(path, full);
  ASSERT_NO_THROW(read_particles(path));
  for (std::size_t n = 0; n < full.size(); ++n) {
    write_file(path, full.substr(0, n));
    EXPECT_THROW(read_particles(path), FormatError) << n;
  }
}

// numpy itself, when the system Python has it: the files users actually produce.
TEST(NpyNumpy, FilesWrittenByNumpyRead) {
  if (std::system("/usr/bin/python3 -c 'import numpy' >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "SKIPPED: /usr/bin/python3 has no numpy (apt-get install python3-numpy)";
  TempDir dir;
  const std::string script = fmt::format(
      "import numpy as np\n"
      "a = np.arange(30, dtype='<f8').reshape(10, 3) * 0.25\n"
      "np.save('{0}/plain.npy', a)\n"
      "np.save('{0}/fortran.npy', np.asfortranarray(a.astype('>f4')))\n"
      "s = np.zeros(10, dtype=[('x','<f4'),('y','<f4'),('z','<f4'),('mass','<f8'),('flag','u1')])\n"
      "s['x'], s['y'], s['z'] = a[:,0], a[:,1], a[:,2]\n"
      "s['mass'] = 2.5; s['flag'] = 3\n"
      "np.save('{0}/structured.npy', s)\n",
      dir.path.string());
  write_file(dir.file("make.py"), script);
  std::string output;
  ASSERT_EQ(test::run_command("/usr/bin/python3 " + dir.file("make.py"), &output), 0) << output;
  std::vector<float> expected;
  for (int i = 0; i < 30; ++i) expected.push_back(float(i) * 0.25f);
  for (const char* name : {"plain.npy", "fortran.npy", "structured.npy"}) {
    SCOPED_TRACE(name);
    const ParticleSet p = read_particles(dir.file(name));
    expect_positions(p, expected);
  }
  const ParticleSet s = read_particles(dir.file("structured.npy"));
  ASSERT_EQ(s.attributes.size(), 2u);
  EXPECT_EQ(s.attributes[0].name, "mass");
  EXPECT_EQ(s.attributes[0].values, std::vector<float>(10, 2.5f));
  EXPECT_EQ(s.attributes[1].name, "flag");
  EXPECT_TRUE(s.attributes[1].integer);
}

}  // namespace
}  // namespace meniscus
