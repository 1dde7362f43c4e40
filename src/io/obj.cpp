// meniscus io — Wavefront OBJ mesh writer and reader (Wavefront "Advanced Visualizer" manual, Appendix B1 "Object Files").
#include "io/obj.hpp"

#include <charconv>
#include <cmath>
#include <limits>
#include <optional>

#include <fmt/format.h>

#include "io/atomic_file.hpp"
#include "io/text_lines.hpp"
#include "meniscus/errors.hpp"

namespace meniscus::io {

void write_obj_mesh(const std::string& path, const TriangleMesh& mesh) {
  check_mesh_for_writing(path, mesh, "OBJ");
  AtomicFile file(path);
  fmt::memory_buffer out;
  constexpr std::size_t flush_at = std::size_t(1) << 20;
  auto flush = [&](bool force) {
    if (force || out.size() >= flush_at) {
      file.write(out.data(), out.size());
      out.clear();
    }
  };
  fmt::format_to(std::back_inserter(out), "# written by meniscus: {} vertices, {} triangles{}\n",
                 mesh.vertices.size(), mesh.triangles.size(), mesh.normals.empty() ? "" : ", vertex normals");
  // fmt's "{}" for float is the shortest text that reads back to the same float: exact round trips.
  for (const Vec3f& p : mesh.vertices) {
    fmt::format_to(std::back_inserter(out), "v {} {} {}\n", p.x, p.y, p.z);
    flush(false);
  }
  for (const Vec3f& n : mesh.normals) {
    fmt::format_to(std::back_inserter(out), "vn {} {} {}\n", n.x, n.y, n.z);
    flush(false);
  }
  const bool normals = !mesh.normals.empty();
  for (const Triangle& t : mesh.triangles) {
    const uint64_t a = uint64_t(t[0]) + 1, b = uint64_t(t[1]) + 1, c = uint64_t(t[2]) + 1;
    if (normals) fmt::format_to(std::back_inserter(out), "f {0}//{0} {1}//{1} {2}//{2}\n", a, b, c);
    else fmt::format_to(std::back_inserter(out), "f {} {} {}\n", a, b, c);
    flush(false);
  }
  flush(true);
  file.commit();
}

namespace {

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

class ObjLines {
 public:
  explicit ObjLines(const Source& source)
      : source_(source), text_(reinterpret_cast<const char*>(source.bytes.data()), source.bytes.size()),
        file_(source.path) {}

  // Lines are text of bounded length (line_end refuses a binary byte or a line past kMaxLineBytes).
  bool next(std::string_view& line) {
    if (pos_ >= text_.size()) return false;
    const std::size_t end = line_end(source_, pos_);
    line = text_.substr(pos_, end - pos_);
    pos_ = end + 1;
    ++line_;
    if (const std::size_t hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
    return true;
  }

  std::vector<std::string_view> words(std::string_view line) const {
    std::vector<std::string_view> out;
    std::size_t i = 0;
    while (i < line.size()) {
      while (i < line.size() && is_blank(line[i])) ++i;
      const std::size_t start = i;
      while (i < line.size() && !is_blank(line[i])) ++i;
      if (i > start) out.push_back(line.substr(start, i - start));
    }
    return out;
  }

  [[noreturn]] void fail(const std::string& message) const {
    throw FormatError(file_, fmt::format("line {}", line_), message);
  }

  float number(std::string_view word, std::string_view what) const {
    const char* begin = word.data();
    const char* end = begin + word.size();
    if (begin != end && *begin == '+') ++begin;
    float v = 0;
    const auto [ptr, ec] = std::from_chars(begin, end, v);
    if (ec != std::errc() || ptr != end) fail(fmt::format("expected a number for {}, found '{}'", what, excerpt(word)));
    return v;
  }

  // A 1-based (or negative, relative) OBJ index into a list of `count` items, as a 0-based index.
  uint32_t index(std::string_view word, std::size_t count, std::string_view what) const {
    int64_t i = 0;
    const auto [ptr, ec] = std::from_chars(word.data(), word.data() + word.size(), i);
    if (ec != std::errc() || ptr != word.data() + word.size() || i == 0)
      fail(fmt::format("expected a non-zero integer {} index, found '{}'", what, excerpt(word)));
    const int64_t zero_based = i > 0 ? i - 1 : int64_t(count) + i;
    if (zero_based < 0 || uint64_t(zero_based) >= count)
      fail(fmt::format("{} index {} is out of range: {} {}s are defined so far", what, i, count, what));
    if (uint64_t(zero_based) > std::numeric_limits<uint32_t>::max())
      fail(fmt::format("{} index {} exceeds the 32-bit index range", what, i));
    return uint32_t(zero_based);
  }

 private:
  const Source& source_;
  std::string_view text_;
  std::string file_;
  std::size_t pos_ = 0;
  std::size_t line_ = 0;
};

}  // namespace

TriangleMesh read_obj_mesh(const Source& source) {
  ObjLines lines(source);
  TriangleMesh mesh;
  std::vector<Vec3f> normals_in;
  std::vector<float> colors;
  bool all_colored = true;
  std::vector<Vec3f> normals;       // per vertex, through face corners
  std::vector<uint8_t> has_normal;  // per vertex
  bool any_normal_corner = false;
  std::string_view line;
  while (lines.next(line)) {
    const std::vector<std::string_view> w = lines.words(line);
    if (w.empty()) continue;
    if (w[0] == "v") {
      if (w.size() != 4 && w.size() != 5 && w.size() != 7)
        lines.fail(fmt::format("expected 'v x y z [w]' or 'v x y z r g b', found {} numbers", w.size() - 1));
      const Vec3f p{lines.number(w[1], "x"), lines.number(w[2], "y"), lines.number(w[3], "z")};
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        lines.fail(fmt::format("expected finite vertex coordinates, found ({}, {}, {})", p.x, p.y, p.z));
      mesh.vertices.push_back(p);
      if (w.size() == 7) {
        for (int c = 0; c < 3; ++c) colors.push_back(lines.number(w[std::size_t(4 + c)], "a vertex colour"));
      } else {
        all_colored = false;
      }
    } else if (w[0] == "vn") {
      if (w.size() != 4) lines.fail(fmt::format("expected 'vn x y z', found {} numbers", w.size() - 1));
      normals_in.push_back({lines.number(w[1], "nx"), lines.number(w[2], "ny"), lines.number(w[3], "nz")});
    } else if (w[0] == "f") {
      if (w.size() < 4) lines.fail(fmt::format("expected a face of at least 3 corners, found {}", w.size() - 1));
      std::vector<uint32_t> corners;
      for (std::size_t k = 1; k < w.size(); ++k) {
        const std::string_view corner = w[k];
        const std::size_t s1 = corner.find('/');
        corners.push_back(lines.index(corner.substr(0, s1), mesh.vertices.size(), "vertex"));
        if (s1 == std::string_view::npos) continue;
        const std::size_t s2 = corner.find('/', s1 + 1);
        if (s2 == std::string_view::npos || s2 + 1 == corner.size()) continue;  // i/t or i/t/
        const uint32_t n = lines.index(corner.substr(s2 + 1), normals_in.size(), "normal");
        if (normals.size() < mesh.vertices.size()) {
          normals.resize(mesh.vertices.size());
          has_normal.resize(mesh.vertices.size(), 0);
        }
        normals[corners.back()] = normals_in[n];
        has_normal[corners.back()] = 1;
        any_normal_corner = true;
      }
      for (std::size_t k = 1; k + 1 < corners.size(); ++k)
        mesh.triangles.push_back({corners[0], corners[k], corners[k + 1]});
    }
    // Everything else (vt, o, g, s, usemtl, mtllib, l, p, curves) carries nothing a TriangleMesh holds.
  }
  if (any_normal_corner) {
    normals.resize(mesh.vertices.size());
    has_normal.resize(mesh.vertices.size(), 0);
    bool complete = true;
    for (const uint8_t h : has_normal) complete = complete && h;
    if (complete) mesh.normals = std::move(normals);
  }
  if (all_colored && !mesh.vertices.empty()) mesh.attributes.push_back(Attribute{"color", 3, false, std::move(colors)});
  return mesh;
}

}  // namespace meniscus::io
