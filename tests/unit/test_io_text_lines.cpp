// meniscus tests — what every text reader shares (io/text_lines): binary bytes refused at the first
// one with its line and offset, lines bounded in length, messages that quote a short excerpt.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <string>
#include <vector>
#include <zlib.h>

#include <fmt/format.h>

#include "io/text_lines.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "meniscus/messages.hpp"
#include "support/io_helpers.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

using test::TempDir;
using test::write_file;

/// What a message may hold beside the file's path: the location, the expectation and an excerpt.
constexpr std::size_t kMessageBytes = 400;

/// The read of `path` (particles, or a mesh for .obj) must fail with a FormatError whose message
/// holds every fragment and is short.
void expect_refused(const std::string& path, const std::vector<std::string>& fragments) {
  SCOPED_TRACE(path);
  try {
    if (path.ends_with(".obj")) read_mesh(path);
    else read_particles(path);
    FAIL() << "read";
  } catch (const FormatError& e) {
    const std::string what = e.what();
    for (const std::string& f : fragments) EXPECT_NE(what.find(f), std::string::npos) << "'" << f << "' not in: " << what;
    EXPECT_LT(what.size(), path.size() + kMessageBytes) << what;
  }
}

std::string ply_header(const std::string& format, std::size_t vertices, const std::string& extra = "") {
  return "ply\nformat " + format + " 1.0\n" + extra + "element vertex " + std::to_string(vertices) +
         "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
}

std::string big_endian_floats(std::initializer_list<float> values) {
  std::string out;
  for (const float v : values) {
    uint32_t u = 0;
    std::memcpy(&u, &v, 4);
    for (int b = 3; b >= 0; --b) out.push_back(char(u >> (8 * b)));
  }
  return out;
}

std::string npy_v1(const std::string& header) {
  std::string out = std::string("\x93NUMPY\x01\x00", 8);
  out.push_back(char(header.size() & 0xff));
  out.push_back(char(header.size() >> 8));
  return out + header;
}

// One case per text part of every reader: where the first binary byte lies, and what the
// message must say of it ("line N, byte M" where lines mean something, the byte alone between
// binary blocks). Offsets are found in the bytes, as a reader must find them.
struct BinaryCase {
  std::string name, bytes;
  char bad;
  bool lines = true;
};

std::vector<BinaryCase> binary_cases() {
  const std::string vtk_binary = "# vtk DataFile Version 4.1\nx\nBINARY\nDATASET POLYDATA\nPOINTS 1 float\n" +
                                 big_endian_floats({0, 0, 0}) + "\nPOINT_DATA 1\nSCALARS \x01rho float 1\n";
  return {
      {"header.csv", std::string("x,y,\0z\n0,0,0\n", 13), '\0'},
      {"row.csv", "x,y,z\n0,0,0\n1,\x1b[2J,1\n", '\x1b'},
      {"crlf.txt", "x y z\r\n0 0 0\r\n1 1 \x7f\r\n", '\x7f'},
      {"header_ascii.ply", ply_header("ascii", 1, "comment \x07 bell\n") + "0 0 0\n", '\x07'},
      {"header_binary.ply", ply_header("binary_little_endian", 1, "comment \x08\n") + std::string(12, '\0'), '\x08'},
      {"body_ascii.ply", ply_header("ascii", 2) + "0 0 0\n1 1 " + std::string("\0", 1) + "\n", '\0'},
      {"ascii.vtk", "# vtk DataFile Version 4.1\nx\nASCII\nDATASET POLYDATA\nPOINTS 2 float\n0 0 0\n1 \x02 1\n", '\x02'},
      {"keyword.vtk", vtk_binary, '\x01', false},
      {"tag.vtu", "<VTKFile type=\"UnstructuredGrid\">\n<UnstructuredGrid>\n<Piece NumberOfPoints=\"1\" \x03>\n", '\x03'},
      {"content.vtu",
       "<VTKFile type=\"UnstructuredGrid\">\n<UnstructuredGrid>\n<Piece NumberOfPoints=\"1\">\n<Points>\n"
       "<DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"ascii\">0 0 \x04</DataArray>\n",
       '\x04'},
      {"vertex.obj", "v 0 0 0\nv 1 0 0\nv 0 1 \x05\nf 1 2 3\n", '\x05'},
      {"header.npy", npy_v1("{'descr': '<f4', 'fortran_order': False, 'shape': (\x06, 3), }\n"), '\x06', false},
  };
}

TEST(TextLines, EveryTextReaderRefusesABinaryByteAtTheFirstOne) {
  TempDir dir;
  for (const BinaryCase& c : binary_cases()) {
    const std::string path = dir.file(c.name);
    write_file(path, c.bytes);
    const std::size_t at = c.bytes.find(c.bad);
    ASSERT_NE(at, std::string::npos) << c.name;
    const std::size_t line = 1 + std::size_t(std::count(c.bytes.begin(), c.bytes.begin() + std::ptrdiff_t(at), '\n'));
    const std::string where = c.lines ? fmt::format("line {}, byte {}:", line, at) : fmt::format(": byte {}:", at);
    expect_refused(path, {path, where, fmt::format("control byte 0x{:02x}", static_cast<unsigned char>(c.bad))});
  }
}

TEST(TextLines, OffsetsOfAGzipFileCountTheInflatedBytes) {
  TempDir dir;
  const std::string path = dir.file("rows.csv.gz");
  const std::string text = "x,y,z\n0,0,0\n1,1,\x0e\n";
  gzFile gz = gzopen(path.c_str(), "wb");
  ASSERT_NE(gz, nullptr);
  ASSERT_EQ(gzwrite(gz, text.data(), unsigned(text.size())), int(text.size()));
  ASSERT_EQ(gzclose(gz), Z_OK);
  expect_refused(path, {"line 3, byte 16 (of the decompressed data)", "control byte 0x0e"});
}

// A megabyte of NUL bytes as the first line: refused at byte 0, the message quoting a few of them.
TEST(TextLines, ALineOfNulBytesIsRefusedAtItsFirstByteWithAShortMessage) {
  TempDir dir;
  for (const std::string name : {"nul.csv", "nul.txt", "nul.obj"}) {
    const std::string path = dir.file(name);
    write_file(path, std::string(1 << 20, '\0') + "\nx,y,z\n");
    expect_refused(path, {"line 1, byte 0:", "control byte 0x00", "\\x00\\x00"});
  }
}

TEST(TextLines, ALineLongerThanAnyRecordIsRefusedAtThatLength) {
  TempDir dir;
  const std::string bound = fmt::format("at most {}", human_bytes(double(io::kMaxLineBytes)));
  const std::string line(io::kMaxLineBytes + 1, 'a');
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"long.csv", "x,y,z\n0,0,0\n" + line + "\n1,1,1\n"},
      {"long_header.csv", line + ",x,y,z\n"},
      {"long.ply", ply_header("binary_little_endian", 1, "comment " + line + "\n") + std::string(12, '\0')},
      {"long.vtk", "# vtk DataFile Version 4.1\n" + line + "\nASCII\nDATASET POLYDATA\nPOINTS 1 float\n0 0 0\n"},
      {"long.obj", "v 0 0 0\n# " + line + "\n"},
  };
  for (const auto& [name, bytes] : cases) {
    const std::string path = dir.file(name);
    write_file(path, bytes);
    const std::size_t start = bytes.find(line);
    const std::size_t line_no = 1 + std::size_t(std::count(bytes.begin(), bytes.begin() + std::ptrdiff_t(start), '\n'));
    // The line's own start, or the keyword before it on the same line.
    const std::size_t line_start = bytes.rfind('\n', start) == std::string::npos ? 0 : bytes.rfind('\n', start) + 1;
    expect_refused(path, {fmt::format("line {}, byte {}:", line_no, line_start), bound});
  }
  // A line of exactly the bound is not refused for its length: here it is a row of one field.
  const std::string exact = dir.file("exact.csv");
  write_file(exact, "x,y,z\n" + std::string(io::kMaxLineBytes, '1') + "\n");
  expect_refused(exact, {"line 2", "expected 3 fields", "found 1"});
}

TEST(TextLines, ANpyHeaderIsBoundedLikeALine) {
  TempDir dir;
  const std::string path = dir.file("long.npy");
  // A version 2 header (4-byte length) that says it is longer than the bound.
  std::string bytes = std::string("\x93NUMPY\x02\x00", 8);
  const uint32_t length = uint32_t(io::kMaxLineBytes + 64);
  for (int b = 0; b < 4; ++b) bytes.push_back(char(length >> (8 * b)));
  bytes += "{'descr': '<f4', 'fortran_order': False, 'shape': (1, 3), }" + std::string(io::kMaxLineBytes, ' ') + "\n";
  write_file(path, bytes);
  expect_refused(path, {"byte 8", fmt::format("at most {}", human_bytes(double(io::kMaxLineBytes))),
                        std::to_string(length)});
}

}  // namespace
}  // namespace meniscus
