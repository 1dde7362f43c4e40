// meniscus io — legacy VTK reader and writer (docs.vtk.org "Simple Legacy Formats"; VTK 9 v5.1 cell layout).
#include "io/vtk_legacy.hpp"

#include <algorithm>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <limits>
#include <optional>
#include <set>
#include <string_view>

#include <fmt/format.h>

#include "io/atomic_file.hpp"
#include "io/obj.hpp"
#include "io/text_lines.hpp"
#include "meniscus/errors.hpp"

namespace meniscus::io {

namespace {

enum class Type : uint8_t { int8, uint8, int16, uint16, int32, uint32, int64, uint64, float32, float64 };

struct TypeName {
  std::string_view name;
  Type type;
};

// Legacy type names (compared case-insensitively, as vtkDataReader does). `long` and vtkIdType are
// 64-bit: that is what VTK on LP64 systems writes for them.
constexpr TypeName type_names[] = {
    {"char", Type::int8},           {"signed_char", Type::int8},     {"unsigned_char", Type::uint8},
    {"short", Type::int16},         {"unsigned_short", Type::uint16}, {"int", Type::int32},
    {"unsigned_int", Type::uint32}, {"long", Type::int64},           {"unsigned_long", Type::uint64},
    {"vtkidtype", Type::int64},     {"float", Type::float32},        {"double", Type::float64},
    {"vtktypeint8", Type::int8},    {"vtktypeuint8", Type::uint8},   {"vtktypeint16", Type::int16},
    {"vtktypeuint16", Type::uint16}, {"vtktypeint32", Type::int32},  {"vtktypeuint32", Type::uint32},
    {"vtktypeint64", Type::int64},  {"vtktypeuint64", Type::uint64}, {"vtktypefloat32", Type::float32},
    {"vtktypefloat64", Type::float64},
};

std::size_t type_size(Type t) {
  switch (t) {
    case Type::int8: case Type::uint8: return 1;
    case Type::int16: case Type::uint16: return 2;
    case Type::int32: case Type::uint32: case Type::float32: return 4;
    case Type::int64: case Type::uint64: case Type::float64: return 8;
  }
  return 1;
}

bool is_integer(Type t) { return t != Type::float32 && t != Type::float64; }

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = char(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

std::optional<Type> parse_type(std::string_view word) {
  const std::string w = lower(word);
  for (const TypeName& t : type_names)
    if (w == t.name) return t.type;
  return std::nullopt;
}

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; }

// The first `limit` words of a keyword line (none needs more than 4): a hostile line of many
// words costs no view of each.
std::vector<std::string_view> split_words(std::string_view line, std::size_t limit = 8) {
  std::vector<std::string_view> words;
  std::size_t i = 0;
  while (i < line.size() && words.size() < limit) {
    while (i < line.size() && is_space(line[i])) ++i;
    const std::size_t start = i;
    while (i < line.size() && !is_space(line[i])) ++i;
    if (i > start) words.push_back(line.substr(start, i - start));
  }
  return words;
}

std::optional<uint64_t> parse_count(std::string_view word) {
  uint64_t value = 0;
  const auto [end, ec] = std::from_chars(word.data(), word.data() + word.size(), value);
  if (ec != std::errc() || end != word.data() + word.size()) return std::nullopt;
  return value;
}

// One array of point data as it was found in the file.
struct PointArray {
  std::string name;
  int components = 1;
  bool integer = false;
  bool normals = false;  // a NORMALS section: the mesh reader's normals
  std::vector<float> values;
};

// Cells as offsets into a connectivity list (the v5.1 layout; v4 counts are converted).
struct Cells {
  std::vector<uint64_t> offsets{0};
  std::vector<uint64_t> connectivity;
  std::vector<int32_t> types;  // CELL_TYPES, for UNSTRUCTURED_GRID
};

struct Parsed {
  bool binary = false;
  std::string version;
  std::string dataset;
  std::vector<Vec3f> points;
  bool have_points = false;
  std::vector<PointArray> arrays;
  Cells polygons;  // POLYGONS (POLYDATA)
  Cells cells;     // CELLS + CELL_TYPES (UNSTRUCTURED_GRID)
};

class LegacyParser {
 public:
  LegacyParser(const Source& source, bool want_cells)
      : source_(source),
        text_(reinterpret_cast<const char*>(source.bytes.data()), source.bytes.size()),
        want_cells_(want_cells) {}

  Parsed parse() {
    parse_preamble();
    // An ASCII file is text to its last byte: values are read token by token, not as lines.
    if (!out_.binary) check_text(source_, pos_, text_.size());
    enum class Section { geometry, point_data, cell_data } section = Section::geometry;
    uint64_t section_count = 0;
    std::size_t at = 0;
    for (std::string_view line; next_keyword_line(line, at);) {
      const std::vector<std::string_view> words = split_words(line);
      const std::string keyword = lower(words[0]);
      auto need = [&](std::size_t n, std::string_view form) {
        if (words.size() < n) fail_at(at, fmt::format("expected '{}', found '{}'", form, shorten(line)));
      };
      auto count_of = [&](std::size_t i, std::string_view form) {
        const std::optional<uint64_t> n = parse_count(words[i]);
        if (!n) fail_at(at, fmt::format("expected a non-negative count in '{}', found '{}'", form, shorten(words[i])));
        return *n;
      };
      if (keyword == "points") {
        need(3, "POINTS <n> <type>");
        if (out_.have_points) fail_at(at, "expected a single POINTS section, found a second one");
        const uint64_t n = count_of(1, "POINTS <n> <type>");
        const Type t = type_of(words[2], at);
        std::vector<float> xyz;
        read_values(t, checked_mul(n, 3, at), &xyz, fmt::format("the coordinates of POINTS {}", n));
        out_.points.resize(std::size_t(n));
        for (std::size_t i = 0; i < out_.points.size(); ++i)
          out_.points[i] = {xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]};
        out_.have_points = true;
      } else if (keyword == "vertices" || keyword == "lines" || keyword == "polygons" ||
                 keyword == "triangle_strips" || keyword == "cells") {
        need(3, fmt::format("{} <n> <size>", words[0]));
        const uint64_t n = count_of(1, "<n>");
        const uint64_t size = count_of(2, "<size>");
        Cells* target = !want_cells_ ? nullptr : keyword == "polygons" ? &out_.polygons
                                                 : keyword == "cells"  ? &out_.cells
                                                                       : nullptr;
        read_cells(n, size, target, at, words[0]);
      } else if (keyword == "cell_types") {
        need(2, "CELL_TYPES <n>");
        const uint64_t n = count_of(1, "CELL_TYPES <n>");
        std::vector<int32_t> types;
        read_values(Type::int32, n, want_cells_ ? &types : nullptr, "the CELL_TYPES");
        if (want_cells_) out_.cells.types = std::move(types);
      } else if (keyword == "dimensions" || keyword == "origin" || keyword == "spacing" ||
                 keyword == "aspect_ratio") {
        continue;  // STRUCTURED_GRID/POINTS metadata: the points (when any) follow as POINTS
      } else if (keyword == "point_data") {
        need(2, "POINT_DATA <n>");
        section_count = count_of(1, "POINT_DATA <n>");
        if (!out_.have_points) fail_at(at, "expected POINTS before POINT_DATA");
        if (section_count != out_.points.size())
          fail_at(at, fmt::format("expected POINT_DATA {} (the number of POINTS), found {}", out_.points.size(),
                                  section_count));
        section = Section::point_data;
      } else if (keyword == "cell_data") {
        need(2, "CELL_DATA <n>");
        section_count = count_of(1, "CELL_DATA <n>");
        section = Section::cell_data;
      } else if (keyword == "metadata") {
        skip_metadata();
      } else if (keyword == "field") {
        need(3, "FIELD <name> <number of arrays>");
        read_field(count_of(2, "FIELD <name> <n>"), section == Section::point_data);
      } else if (keyword == "scalars" || keyword == "vectors" || keyword == "normals" || keyword == "tensors" ||
                 keyword == "tensors6" || keyword == "texture_coordinates" || keyword == "color_scalars" ||
                 keyword == "global_ids" || keyword == "pedigree_ids" || keyword == "lookup_table") {
        if (section == Section::geometry)
          fail_at(at, fmt::format("expected POINT_DATA or CELL_DATA before {}", words[0]));
        read_attribute(keyword, words, line, at, section_count, section == Section::point_data);
      } else {
        fail_at(at, fmt::format("expected a legacy VTK section keyword (POINTS, CELLS, POLYGONS, POINT_DATA, "
                                "SCALARS, FIELD …), found '{}'",
                                shorten(words[0])));
      }
    }
    if (!out_.have_points) fail_at(text_.size(), "expected a POINTS section, found the end of the file");
    return std::move(out_);
  }

 private:
  // ------------------------------------------------------------------ lines and locations
  std::string location(std::size_t at) const {
    if (out_.binary) return ByteCursor(source_.bytes, source_.path, source_.gzip).location(at);
    // Lines are only counted when an error needs one: no bookkeeping on the hot path.
    const std::size_t end = std::min(at, text_.size());
    return fmt::format("line {}", 1 + std::count(text_.begin(), text_.begin() + std::ptrdiff_t(end), '\n'));
  }

  [[noreturn]] void fail_at(std::size_t at, const std::string& message) const {
    throw FormatError(source_.path, location(at), message);
  }

  static std::string shorten(std::string_view s) {
    return s.size() <= 60 ? std::string(s) : std::string(s.substr(0, 60)) + "…";
  }

  // The line at pos_ (without its end), consumed. At the end of the data returns an empty view.
  // Keyword lines are text of bounded length even between binary blocks (line_end refuses others).
  std::string_view take_line() {
    const std::size_t start = pos_;
    const std::size_t end = line_end(source_, pos_, !out_.binary);
    pos_ = std::min(end + 1, text_.size());
    std::string_view line = text_.substr(start, end - start);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    return line;
  }

  // Skips blank lines (VTK writers put a newline after binary blocks, some add more) and returns
  // the next non-blank line and its offset; false at the end of the data.
  bool next_keyword_line(std::string_view& line, std::size_t& at) {
    while (pos_ < text_.size() && is_space(text_[pos_])) ++pos_;
    if (pos_ >= text_.size()) return false;
    at = pos_;
    line = take_line();
    return true;
  }

  void parse_preamble() {
    constexpr std::string_view magic = "# vtk DataFile Version";
    std::string_view line = take_line();
    if (!line.starts_with(magic))
      fail_at(0, fmt::format("expected the legacy VTK magic line '{} x.y', found '{}'", magic, shorten(line)));
    const std::vector<std::string_view> version = split_words(line.substr(magic.size()));
    out_.version = version.empty() ? std::string("?") : std::string(version[0]);
    v5_ = !out_.version.empty() && out_.version[0] >= '5' && out_.version[0] <= '9';
    if (pos_ >= text_.size()) fail_at(pos_, "expected a title line after the version line");
    take_line();  // the title: free text, may be empty
    std::size_t at = 0;
    if (!next_keyword_line(line, at)) fail_at(text_.size(), "expected ASCII or BINARY, found the end of the file");
    const std::vector<std::string_view> words = split_words(line);
    const std::string format = lower(words[0]);
    if (format == "binary") out_.binary = true;
    else if (format != "ascii") fail_at(at, fmt::format("expected ASCII or BINARY, found '{}'", shorten(line)));
    if (!next_keyword_line(line, at)) fail_at(text_.size(), "expected 'DATASET <type>', found the end of the file");
    const std::vector<std::string_view> dataset = split_words(line);
    if (lower(dataset[0]) != "dataset" || dataset.size() < 2)
      fail_at(at, fmt::format("expected 'DATASET <type>', found '{}'", shorten(line)));
    out_.dataset = lower(dataset[1]);
    if (out_.dataset != "polydata" && out_.dataset != "unstructured_grid" && out_.dataset != "structured_grid")
      fail_at(at, fmt::format("expected DATASET POLYDATA, UNSTRUCTURED_GRID or STRUCTURED_GRID (datasets with "
                              "explicit points), found '{}'",
                              shorten(dataset[1])));
  }

  void skip_metadata() {
    // VTK ≥ 8 writes METADATA blocks (INFORMATION, COMPONENT_NAMES …) ended by a blank line.
    while (pos_ < text_.size()) {
      const std::string_view line = take_line();
      if (split_words(line).empty()) return;
    }
  }

  Type type_of(std::string_view word, std::size_t at) const {
    const std::optional<Type> t = parse_type(word);
    if (!t)
      fail_at(at, fmt::format("expected a data type (unsigned_char, char, unsigned_short, short, unsigned_int, "
                              "int, unsigned_long, long, float, double, vtktypeint64 …), found '{}'",
                              shorten(word)));
    return *t;
  }

  uint64_t checked_mul(uint64_t a, uint64_t b, std::size_t at) const {
    if (b != 0 && a > std::numeric_limits<uint64_t>::max() / b)
      fail_at(at, fmt::format("the count {} × {} overflows", a, b));
    return a * b;
  }

  // ------------------------------------------------------------------ values
  // Reads `count` values of type t (big-endian binary or whitespace-separated text) into *out
  // (resized to count), or skips them when out is null. The count is checked against the bytes
  // left before anything is allocated.
  template <class T>
  void read_values(Type t, uint64_t count, std::vector<T>* out, std::string_view what) {
    const std::size_t size = type_size(t);
    // Every array read is kept (it becomes the particles): their sum is what the read holds.
    const auto hold = [&] {
      decoded_bytes_ += double(count) * sizeof(T);
      check_read_memory(source_, decoded_bytes_, fmt::format("the arrays decoded up to {} ({} values)", what, count));
    };
    if (out_.binary) {
      ByteCursor cursor(source_.bytes, source_.path, source_.gzip);
      cursor.seek(pos_, what);
      cursor.require_records(count, size, what);
      if (out) {
        hold();
        out->resize(std::size_t(count));
        const uint8_t* p = source_.bytes.data() + pos_;
        for (std::size_t i = 0; i < out->size(); ++i, p += size) (*out)[i] = static_cast<T>(load(t, p));
      }
      pos_ += std::size_t(count) * size;
      return;
    }
    const std::size_t left = text_.size() - pos_;
    if (count > (left + 1) / 2)
      fail_at(pos_, fmt::format("expected {} values for {}, but only {} bytes of text are left (the count is larger "
                                "than the file can hold)",
                                count, what, left));
    if (out) {
      hold();
      out->resize(std::size_t(count));
    }
    for (std::size_t i = 0; i < count; ++i) {
      while (pos_ < text_.size() && is_space(text_[pos_])) ++pos_;
      const std::size_t start = pos_;
      while (pos_ < text_.size() && !is_space(text_[pos_])) ++pos_;
      if (start == pos_)
        fail_at(start, fmt::format("expected value {} of {} for {}, found the end of the file", i, count, what));
      const double v = parse_value(t, text_.substr(start, pos_ - start), start, what);
      if (out) (*out)[i] = static_cast<T>(v);
    }
  }

  // As double: exact for every integer a cell index can be and for both float types.
  static double load(Type t, const uint8_t* p) {
    constexpr Endian be = Endian::big;  // legacy binary is big-endian whatever the machine
    switch (t) {
      case Type::int8: return double(ByteCursor::load<int8_t>(p, be));
      case Type::uint8: return double(ByteCursor::load<uint8_t>(p, be));
      case Type::int16: return double(ByteCursor::load<int16_t>(p, be));
      case Type::uint16: return double(ByteCursor::load<uint16_t>(p, be));
      case Type::int32: return double(ByteCursor::load<int32_t>(p, be));
      case Type::uint32: return double(ByteCursor::load<uint32_t>(p, be));
      case Type::int64: return double(ByteCursor::load<int64_t>(p, be));
      case Type::uint64: return double(ByteCursor::load<uint64_t>(p, be));
      case Type::float32: return double(ByteCursor::load<float>(p, be));
      case Type::float64: return double(ByteCursor::load<double>(p, be));
    }
    return 0;
  }

  double parse_value(Type t, std::string_view token, std::size_t at, std::string_view what) const {
    const char* begin = token.data();
    const char* end = begin + token.size();
    if (begin != end && *begin == '+') ++begin;  // from_chars rejects the '+' printf may write
    bool ok = false;
    double value = 0;
    if (t == Type::float32) {  // parsed as float so the nearest float is exact, not double-rounded
      float f = 0;
      const auto [ptr, ec] = std::from_chars(begin, end, f);
      ok = ec == std::errc() && ptr == end;
      value = double(f);
    } else if (t == Type::float64) {
      const auto [ptr, ec] = std::from_chars(begin, end, value);
      ok = ec == std::errc() && ptr == end;
    } else if (t == Type::uint64) {
      uint64_t u = 0;
      const auto [ptr, ec] = std::from_chars(begin, end, u);
      ok = ec == std::errc() && ptr == end;
      value = double(u);
    } else {
      int64_t i = 0;
      const auto [ptr, ec] = std::from_chars(begin, end, i);
      ok = ec == std::errc() && ptr == end;
      value = double(i);
    }
    if (!ok)
      fail_at(at, fmt::format("expected {} number for {}, found '{}'", is_integer(t) ? "an integer" : "a",
                              what, shorten(token)));
    return value;
  }

  // ------------------------------------------------------------------ cells
  // v4: `<KEY> n size` then `size` int32 values (k, i_0 … i_k-1) per cell. v5.1: `<KEY> n size`
  // (n = cells + 1 offsets) then `OFFSETS <type>` and `CONNECTIVITY <type>` blocks.
  void read_cells(uint64_t n, uint64_t size, Cells* target, std::size_t at, std::string_view key) {
    if (v5_) {
      std::vector<double> offsets, connectivity;
      expect_block("offsets", at, key);
      read_values(block_type_, n, target ? &offsets : nullptr, "the cell OFFSETS");
      expect_block("connectivity", at, key);
      read_values(block_type_, size, target ? &connectivity : nullptr, "the cell CONNECTIVITY");
      if (!target) return;
      for (std::size_t i = 0; i < offsets.size(); ++i) {
        const double o = offsets[i];
        if (!(o >= 0 && o <= float(connectivity.size())) || (i > 0 && o < offsets[i - 1]))
          fail_at(at, fmt::format("expected non-decreasing cell offsets within 0..{}, offset {} is {}",
                                  connectivity.size(), i, o));
      }
      target->offsets.clear();
      for (const double o : offsets) target->offsets.push_back(uint64_t(o));
      if (target->offsets.empty()) target->offsets.push_back(0);
      for (const double c : connectivity) target->connectivity.push_back(index_of(c, at));
      return;
    }
    std::vector<double> data;
    read_values(Type::int32, size, target ? &data : nullptr, fmt::format("the {} data", key));
    if (!target) return;
    std::size_t i = 0;
    for (uint64_t cell = 0; cell < n; ++cell) {
      if (i >= data.size())
        fail_at(at, fmt::format("expected {} cells in {} values, cell {} starts past the end", n, size, cell));
      const double k = data[i++];
      if (!(k >= 0) || double(k) > double(data.size() - i))
        fail_at(at, fmt::format("expected a vertex count for cell {} within the {} values, found {}", cell, size, k));
      for (std::size_t j = 0; j < std::size_t(k); ++j) target->connectivity.push_back(index_of(data[i++], at));
      target->offsets.push_back(target->connectivity.size());
    }
  }

  uint64_t index_of(double v, std::size_t at) const {
    if (!(v >= 0 && v <= double(std::numeric_limits<uint32_t>::max())))
      fail_at(at, fmt::format("expected a point index in 0..4294967295, found {}", v));
    return uint64_t(v);
  }

  void expect_block(std::string_view name, std::size_t at, std::string_view key) {
    std::string_view line;
    std::size_t line_at = at;
    if (!next_keyword_line(line, line_at))
      fail_at(text_.size(), fmt::format("expected '{} <type>' after {} (version 5 cell layout)", name, key));
    const std::vector<std::string_view> words = split_words(line);
    if (lower(words[0]) != name || words.size() < 2)
      fail_at(line_at, fmt::format("expected '{} <type>' after {} (version 5 cell layout), found '{}'",
                                   name, key, shorten(line)));
    block_type_ = type_of(words[1], line_at);
  }

  // ------------------------------------------------------------------ attributes
  void keep(std::string name, int components, Type t, std::vector<float>&& values, bool normals = false) {
    out_.arrays.push_back(PointArray{std::move(name), components, is_integer(t), normals, std::move(values)});
  }

  void read_attribute(const std::string& keyword, const std::vector<std::string_view>& words, std::string_view line,
                      std::size_t at, uint64_t count, bool point_data) {
    auto need = [&](std::size_t n, std::string_view form) {
      if (words.size() < n) fail_at(at, fmt::format("expected '{}', found '{}'", form, shorten(line)));
    };
    auto components_of = [&](std::string_view word) {
      const std::optional<uint64_t> c = parse_count(word);
      if (!c || *c < 1 || *c > 1024)
        fail_at(at, fmt::format("expected a component count in 1..1024, found '{}'", shorten(word)));
      return int(*c);
    };
    std::vector<float> values;
    std::vector<float>* sink = point_data ? &values : nullptr;
    const std::string name = words.size() > 1 ? std::string(words[1]) : std::string();
    if (keyword == "scalars") {
      need(3, "SCALARS <name> <type> [components]");
      const Type t = type_of(words[2], at);
      const int c = words.size() > 3 ? components_of(words[3]) : 1;
      // LOOKUP_TABLE is required by the spec, but some writers leave it out: take it when present.
      const std::size_t save = pos_;
      std::string_view next;
      std::size_t next_at = 0;
      if (!(next_keyword_line(next, next_at) && lower(split_words(next)[0]) == "lookup_table")) pos_ = save;
      read_values(t, checked_mul(count, uint64_t(c), at), sink, fmt::format("SCALARS '{}'", shorten(name)));
      if (point_data) keep(name, c, t, std::move(values));
    } else if (keyword == "vectors" || keyword == "normals") {
      need(3, fmt::format("{} <name> <type>", words[0]));
      const Type t = type_of(words[2], at);
      read_values(t, checked_mul(count, 3, at), sink, fmt::format("{} '{}'", words[0], shorten(name)));
      if (point_data) keep(name, 3, t, std::move(values), keyword == "normals");
    } else if (keyword == "texture_coordinates") {
      need(4, "TEXTURE_COORDINATES <name> <dim> <type>");
      const int c = components_of(words[2]);
      const Type t = type_of(words[3], at);
      read_values(t, checked_mul(count, uint64_t(c), at), sink, fmt::format("TEXTURE_COORDINATES '{}'", shorten(name)));
      if (point_data) keep(name, c, t, std::move(values));
    } else if (keyword == "tensors" || keyword == "tensors6") {
      need(3, fmt::format("{} <name> <type>", words[0]));
      const Type t = type_of(words[2], at);
      const int c = keyword == "tensors" ? 9 : 6;
      read_values(t, checked_mul(count, uint64_t(c), at), sink, fmt::format("{} '{}'", words[0], shorten(name)));
      if (point_data) keep(name, c, t, std::move(values));
    } else if (keyword == "color_scalars") {
      need(3, "COLOR_SCALARS <name> <components>");
      const int c = components_of(words[2]);
      // Binary colour scalars are bytes 0..255, ASCII ones floats 0..1.
      const Type t = out_.binary ? Type::uint8 : Type::float32;
      read_values(t, checked_mul(count, uint64_t(c), at), sink, fmt::format("COLOR_SCALARS '{}'", shorten(name)));
      if (out_.binary)
        for (float& v : values) v /= 255.0f;
      if (point_data) out_.arrays.push_back(PointArray{name, c, false, false, std::move(values)});
    } else if (keyword == "global_ids" || keyword == "pedigree_ids") {
      need(3, fmt::format("{} <name> <type>", words[0]));
      const Type t = type_of(words[2], at);
      read_values(t, count, sink, fmt::format("{} '{}'", words[0], shorten(name)));
      if (point_data) keep(name, 1, t, std::move(values));
    } else {  // a lookup table of its own: size RGBA entries, never per point
      need(3, "LOOKUP_TABLE <name> <size>");
      const std::optional<uint64_t> n = parse_count(words[2]);
      if (!n) fail_at(at, fmt::format("expected a lookup table size, found '{}'", shorten(words[2])));
      read_values<float>(out_.binary ? Type::uint8 : Type::float32, checked_mul(*n, 4, at), nullptr, "the LOOKUP_TABLE");
    }
  }

  // `FIELD <name> k`, then k arrays `<name> <components> <tuples> <type>` + data. Only arrays with
  // one tuple per point in POINT_DATA are attributes; the rest (time stamps …) are skipped.
  void read_field(uint64_t arrays, bool point_data) {
    for (uint64_t a = 0; a < arrays; ++a) {
      std::string_view line;
      std::size_t at = 0;
      if (!next_keyword_line(line, at))
        fail_at(text_.size(), fmt::format("expected FIELD array {} of {}, found the end of the file", a, arrays));
      std::vector<std::string_view> words = split_words(line);
      if (lower(words[0]) == "metadata") {
        skip_metadata();
        --a;
        continue;
      }
      if (words[0] == "NULL_ARRAY") continue;
      if (words.size() < 4)
        fail_at(at, fmt::format("expected FIELD array '<name> <components> <tuples> <type>', found '{}'",
                                shorten(line)));
      const std::optional<uint64_t> components = parse_count(words[1]);
      const std::optional<uint64_t> tuples = parse_count(words[2]);
      if (!components || *components < 1 || *components > 1024 || !tuples)
        fail_at(at, fmt::format("expected FIELD array '<name> <components 1..1024> <tuples> <type>', found '{}'",
                                shorten(line)));
      const Type t = type_of(words[3], at);
      const bool per_point = point_data && *tuples == out_.points.size();
      std::vector<float> values;
      read_values(t, checked_mul(*components, *tuples, at), per_point ? &values : nullptr,
                  fmt::format("FIELD array '{}'", shorten(words[0])));
      if (per_point) keep(std::string(words[0]), int(*components), t, std::move(values));
    }
  }

  const Source& source_;
  std::string_view text_;
  bool want_cells_;
  bool v5_ = false;
  Type block_type_ = Type::int64;
  std::size_t pos_ = 0;
  double decoded_bytes_ = 0;  // what read_values has allocated so far
  Parsed out_;
};

// ---------------------------------------------------------------------------------------------
// Writer

void put_be(std::string& out, uint32_t v) {
  for (int i = 3; i >= 0; --i) out.push_back(static_cast<char>(v >> (8 * i)));
}
void put_be(std::string& out, float v) { put_be(out, std::bit_cast<uint32_t>(v)); }

void check_vtk_name(const std::string& name) {
  if (name.empty() || std::any_of(name.begin(), name.end(),
                                  [](char c) { return static_cast<unsigned char>(c) <= ' ' || c == 0x7f; }))
    throw InvalidParameter(fmt::format("cannot write legacy VTK: attribute name '{}' is empty or contains "
                                       "whitespace, which the legacy header cannot hold",
                                       name));
}

}  // namespace

bool sniff_vtk_legacy(ByteView bytes) {
  constexpr std::string_view magic = "# vtk DataFile Version";
  return bytes.size() >= magic.size() && std::equal(magic.begin(), magic.end(), bytes.begin());
}

ParticleSet read_vtk_legacy_particles(const Source& source, const ReadOptions& /*options*/, ReadReport* report) {
  Parsed parsed = LegacyParser(source, false).parse();
  ParticleSet particles;
  particles.positions = std::move(parsed.points);
  for (PointArray& a : parsed.arrays)
    particles.attributes.push_back(Attribute{std::move(a.name), a.components, a.integer, std::move(a.values)});
  if (report)
    report->format = fmt::format("vtk legacy {} ({}, {})", parsed.version, parsed.binary ? "binary" : "ascii",
                                 parsed.dataset);
  return particles;
}

TriangleMesh read_vtk_legacy_mesh(const Source& source) {
  Parsed parsed = LegacyParser(source, true).parse();
  TriangleMesh mesh;
  mesh.vertices = std::move(parsed.points);
  const std::size_t nv = mesh.vertices.size();
  for (std::size_t i = 0; i < nv; ++i) {
    const Vec3f p = mesh.vertices[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw FormatError(source.path, fmt::format("point {}", i),
                        fmt::format("expected finite coordinates, found ({}, {}, {})", p.x, p.y, p.z));
  }
  // Polygons are fan-triangulated; among unstructured cells only surface cells count
  // (VTK_TRIANGLE 5, VTK_POLYGON 7, VTK_QUAD 9).
  auto add_cells = [&](const Cells& cells, bool filter) {
    if (filter && cells.types.size() + 1 != cells.offsets.size() && cells.offsets.size() > 1)
      throw FormatError(source.path, "", fmt::format("expected one CELL_TYPES entry per cell ({}), found {}",
                                                     cells.offsets.size() - 1, cells.types.size()));
    for (std::size_t c = 0; c + 1 < cells.offsets.size(); ++c) {
      if (filter && cells.types[c] != 5 && cells.types[c] != 7 && cells.types[c] != 9) continue;
      const uint64_t begin = cells.offsets[c], end = cells.offsets[c + 1];
      for (uint64_t k = begin; k < end; ++k)
        if (cells.connectivity[k] >= nv)
          throw FormatError(source.path, fmt::format("cell {}", c),
                            fmt::format("expected point indices below {}, found {}", nv, cells.connectivity[k]));
      for (uint64_t k = begin + 1; k + 1 < end; ++k)
        mesh.triangles.push_back({uint32_t(cells.connectivity[begin]), uint32_t(cells.connectivity[k]),
                                  uint32_t(cells.connectivity[k + 1])});
    }
  };
  add_cells(parsed.polygons, false);
  add_cells(parsed.cells, true);
  for (PointArray& a : parsed.arrays) {
    if (a.normals && mesh.normals.empty()) {
      mesh.normals.resize(nv);
      for (std::size_t i = 0; i < nv; ++i) mesh.normals[i] = {a.values[3 * i], a.values[3 * i + 1], a.values[3 * i + 2]};
      continue;
    }
    mesh.attributes.push_back(Attribute{std::move(a.name), a.components, a.integer, std::move(a.values)});
  }
  return mesh;
}

void write_vtk_legacy_mesh(const std::string& path, const TriangleMesh& mesh) {
  check_mesh_for_writing(path, mesh, "legacy VTK");
  const std::size_t nv = mesh.vertices.size();
  if (nv > uint64_t(std::numeric_limits<int32_t>::max()) ||
      mesh.triangles.size() > uint64_t(std::numeric_limits<int32_t>::max()) / 4)
    throw InvalidParameter(fmt::format("cannot write '{}': {} vertices / {} triangles exceed legacy VTK's int32 "
                                       "cell data",
                                       path, nv, mesh.triangles.size()));
  std::set<std::string> names;
  for (const Attribute& a : mesh.attributes) {
    check_vtk_name(a.name);
    if (!names.insert(a.name).second)
      throw InvalidParameter(fmt::format("cannot write '{}': two attributes are named '{}'", path, a.name));
  }

  AtomicFile file(path);
  std::string out;
  constexpr std::size_t flush_at = std::size_t(1) << 20;
  auto flush = [&](bool force) {
    if (force || out.size() >= flush_at) {
      file.write(out);
      out.clear();
    }
  };
  out += fmt::format("# vtk DataFile Version 4.2\nmeniscus surface\nBINARY\nDATASET POLYDATA\nPOINTS {} float\n", nv);
  for (const Vec3f& p : mesh.vertices) {
    put_be(out, p.x);
    put_be(out, p.y);
    put_be(out, p.z);
    flush(false);
  }
  out += fmt::format("\nPOLYGONS {} {}\n", mesh.triangles.size(), 4 * mesh.triangles.size());
  for (const Triangle& t : mesh.triangles) {
    put_be(out, uint32_t(3));
    for (const uint32_t v : t) put_be(out, v);
    flush(false);
  }
  out += "\n";
  if (!mesh.normals.empty() || !mesh.attributes.empty()) out += fmt::format("POINT_DATA {}\n", nv);
  if (!mesh.normals.empty()) {
    out += "NORMALS normals float\n";
    for (const Vec3f& n : mesh.normals) {
      put_be(out, n.x);
      put_be(out, n.y);
      put_be(out, n.z);
      flush(false);
    }
    out += "\n";
  }
  auto put_values = [&](const Attribute& a) {
    for (const float v : a.values) {
      // Integer attributes hold whole numbers; out-of-range values saturate rather than wrap.
      if (a.integer) put_be(out, std::bit_cast<uint32_t>(int32_t(std::clamp(std::round(double(v)), -2147483648.0,
                                                                               2147483647.0))));
      else put_be(out, v);
      flush(false);
    }
    out += "\n";
  };
  std::vector<const Attribute*> fields;
  for (const Attribute& a : mesh.attributes) {
    const char* type = a.integer ? "int" : "float";
    if (a.components == 1) {
      out += fmt::format("SCALARS {} {} 1\nLOOKUP_TABLE default\n", a.name, type);
      put_values(a);
    } else if (a.components == 3) {
      out += fmt::format("VECTORS {} {}\n", a.name, type);
      put_values(a);
    } else {
      fields.push_back(&a);
    }
  }
  if (!fields.empty()) {
    out += fmt::format("FIELD FieldData {}\n", fields.size());
    for (const Attribute* a : fields) {
      out += fmt::format("{} {} {} {}\n", a->name, a->components, nv, a->integer ? "int" : "float");
      put_values(*a);
    }
  }
  flush(true);
  file.commit();
}

}  // namespace meniscus::io
