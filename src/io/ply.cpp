// meniscus io — PLY reader (ascii, binary little/big endian; Turk 1994 "The PLY Polygon File Format") and binary writer.
#include "io/ply.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <optional>
#include <set>
#include <string_view>
#include <unordered_map>

#include <fmt/format.h>

#include "io/atomic_file.hpp"
#include "io/text_lines.hpp"
#include "meniscus/errors.hpp"

namespace meniscus::io {

namespace {

// ---------------------------------------------------------------------------------------------
// Header

enum class Scalar : uint8_t { int8, uint8, int16, uint16, int32, uint32, float32, float64 };

struct ScalarInfo {
  std::string_view name;   // the spelling our messages use
  std::string_view alias;  // the other spelling PLY allows
  std::size_t size;
  bool integer;
  double min, max;
};

constexpr ScalarInfo scalar_infos[] = {
    {"char", "int8", 1, true, -128.0, 127.0},
    {"uchar", "uint8", 1, true, 0.0, 255.0},
    {"short", "int16", 2, true, -32768.0, 32767.0},
    {"ushort", "uint16", 2, true, 0.0, 65535.0},
    {"int", "int32", 4, true, -2147483648.0, 2147483647.0},
    {"uint", "uint32", 4, true, 0.0, 4294967295.0},
    {"float", "float32", 4, false, -double(std::numeric_limits<float>::max()), double(std::numeric_limits<float>::max())},
    {"double", "float64", 8, false, -std::numeric_limits<double>::max(), std::numeric_limits<double>::max()},
};

const ScalarInfo& info(Scalar t) { return scalar_infos[static_cast<int>(t)]; }

std::optional<Scalar> parse_scalar(std::string_view word) {
  for (int i = 0; i < 8; ++i)
    if (word == scalar_infos[i].name || word == scalar_infos[i].alias) return static_cast<Scalar>(i);
  return std::nullopt;
}

// Hashes std::string and std::string_view alike, so a name is looked up without a copy.
struct NameHash {
  using is_transparent = void;
  std::size_t operator()(std::string_view name) const { return std::hash<std::string_view>{}(name); }
};
using NameIndex = std::unordered_map<std::string, std::size_t, NameHash, std::equal_to<>>;

struct Property {
  std::string name;
  Scalar type = Scalar::float32;  // the item type for lists
  bool list = false;
  Scalar count_type = Scalar::uint8;
};

struct Element {
  std::string name;
  uint64_t count = 0;
  std::vector<Property> properties;
  std::size_t line = 0;  // header line that declared it
  NameIndex index;       // property name → its index: lookups in constant time

  void add(Property property) {
    index.emplace(property.name, properties.size());
    properties.push_back(std::move(property));
  }

  bool has_list() const {
    return std::any_of(properties.begin(), properties.end(), [](const Property& p) { return p.list; });
  }
  // Bytes a binary record needs at least (lists may be empty): what a declared count is checked
  // against before anything is allocated for it.
  std::size_t min_binary_size() const {
    std::size_t n = 0;
    for (const Property& p : properties) n += info(p.list ? p.count_type : p.type).size;
    return n;
  }
  const Property* find(std::string_view property) const {
    const std::size_t i = index_of(property);
    return i < properties.size() ? &properties[i] : nullptr;
  }
  std::size_t index_of(std::string_view property) const {
    const auto it = index.find(property);
    return it == index.end() ? properties.size() : it->second;
  }
};

enum class Encoding { ascii, binary_little_endian, binary_big_endian };

struct Header {
  Encoding encoding = Encoding::ascii;
  std::vector<Element> elements;
  NameIndex index;              // element name → its index
  std::size_t body_offset = 0;  // first byte after "end_header\n"
  std::size_t body_line = 0;    // line number of the first body line
  std::size_t end_line = 0;     // line of end_header

  const Element* find(std::string_view name) const {
    const auto it = index.find(name);
    return it == index.end() ? nullptr : &elements[it->second];
  }
};

std::string_view encoding_name(Encoding e) {
  switch (e) {
    case Encoding::ascii: return "ascii";
    case Encoding::binary_little_endian: return "binary little endian";
    case Encoding::binary_big_endian: return "binary big endian";
  }
  return "?";
}

// The first `limit` words of a header line (no line holds more than 5; a sixth tells that there
// are too many, without a view of every word of a hostile line).
std::vector<std::string_view> split_words(std::string_view line, std::size_t limit = 6) {
  std::vector<std::string_view> words;
  std::size_t i = 0;
  while (i < line.size() && words.size() < limit) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
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

Header parse_header(const Source& source) {
  const std::string_view text(reinterpret_cast<const char*>(source.bytes.data()), source.bytes.size());
  const std::string& file = source.path;
  auto fail = [&](std::size_t line, const std::string& message) -> void {
    throw FormatError(file, fmt::format("line {}", line), message);
  };
  if (!sniff_ply(source.bytes))
    throw FormatError(file, "line 1", "expected the PLY magic line 'ply' at the start of the file");

  Header header;
  bool have_format = false;
  std::size_t pos = 0;
  // Elements and properties declared, and what they hold in memory (the names twice, with their
  // lookups): a header of many short lines costs more than its text.
  std::size_t entries = 0;
  double held = 0;
  auto count_entry = [&](std::size_t line_no, std::size_t name_size) {
    if (++entries > kMaxColumns)
      fail(line_no, fmt::format("expected at most {} elements and properties in the header", kMaxColumns));
    held += 2.0 * double(name_size) + 256.0;
    if (entries % 4096 == 0) check_read_memory(source, held, fmt::format("the header's {} properties", entries));
  };
  for (std::size_t line_no = 1;; ++line_no) {
    // Header lines are text of bounded length whatever the body holds.
    const std::size_t newline = line_end(source, pos);
    if (newline == text.size())
      fail(line_no, "expected 'end_header' before the end of the file (the header is incomplete)");
    const std::string_view line = text.substr(pos, newline - pos);
    pos = newline + 1;
    const std::vector<std::string_view> words = split_words(line);
    if (line_no == 1) continue;  // the magic, checked above
    if (words.empty()) continue;
    const std::string_view keyword = words[0];
    if (keyword == "comment" || keyword == "obj_info") continue;
    if (keyword == "end_header") {
      if (!have_format) fail(line_no, "expected a 'format' line before 'end_header'");
      check_read_memory(source, held, fmt::format("the header's {} properties", entries));
      header.body_offset = pos;
      header.body_line = line_no + 1;
      header.end_line = line_no;
      return header;
    }
    if (keyword == "format") {
      if (have_format) fail(line_no, "expected a single 'format' line, found a second one");
      if (!header.elements.empty()) fail(line_no, "expected the 'format' line before the first 'element'");
      if (words.size() != 3 || (words[2] != "1.0" && words[2] != "1"))
        fail(line_no, "expected 'format ascii|binary_little_endian|binary_big_endian 1.0'");
      if (words[1] == "ascii") header.encoding = Encoding::ascii;
      else if (words[1] == "binary_little_endian") header.encoding = Encoding::binary_little_endian;
      else if (words[1] == "binary_big_endian") header.encoding = Encoding::binary_big_endian;
      else
        fail(line_no, fmt::format("expected 'format ascii|binary_little_endian|binary_big_endian 1.0', found "
                                  "format '{}'", excerpt(words[1])));
      have_format = true;
      continue;
    }
    if (keyword == "element") {
      if (!have_format) fail(line_no, "expected a 'format' line before the first 'element'");
      if (words.size() != 3) fail(line_no, "expected 'element <name> <count>'");
      const std::optional<uint64_t> count = parse_count(words[2]);
      if (!count)
        fail(line_no, fmt::format("expected a non-negative integer element count, found '{}'", excerpt(words[2])));
      if (header.find(words[1]))
        fail(line_no, fmt::format("expected each element once, element '{}' is declared twice", excerpt(words[1])));
      count_entry(line_no, words[1].size());
      header.index.emplace(std::string(words[1]), header.elements.size());
      header.elements.push_back(Element{std::string(words[1]), *count, {}, line_no, {}});
      continue;
    }
    if (keyword == "property") {
      if (header.elements.empty()) fail(line_no, "expected an 'element' line before the first 'property'");
      Element& element = header.elements.back();
      Property property;
      if (words.size() >= 2 && words[1] == "list") {
        if (words.size() != 5) fail(line_no, "expected 'property list <count type> <item type> <name>'");
        const std::optional<Scalar> count_type = parse_scalar(words[2]);
        const std::optional<Scalar> item_type = parse_scalar(words[3]);
        if (!count_type || !info(*count_type).integer)
          fail(line_no, fmt::format("expected an integer list count type (uchar, ushort, uint …), found '{}'",
                                    excerpt(words[2])));
        if (!item_type)
          fail(line_no, fmt::format("expected a list item type (char, uchar, short, ushort, int, uint, float, "
                                    "double), found '{}'",
                                    excerpt(words[3])));
        property = Property{std::string(words[4]), *item_type, true, *count_type};
      } else {
        if (words.size() != 3) fail(line_no, "expected 'property <type> <name>'");
        const std::optional<Scalar> type = parse_scalar(words[1]);
        if (!type)
          fail(line_no, fmt::format("expected a property type (char, uchar, short, ushort, int, uint, float, "
                                    "double or their int8 … float64 names), found '{}'",
                                    excerpt(words[1])));
        property = Property{std::string(words[2]), *type, false, Scalar::uint8};
      }
      if (element.find(property.name))
        fail(line_no, fmt::format("expected distinct property names, '{}' appears twice in element '{}'",
                                  excerpt(property.name), excerpt(element.name)));
      count_entry(line_no, property.name.size());
      element.add(std::move(property));
      continue;
    }
    fail(line_no, fmt::format("expected 'format', 'element', 'property', 'comment', 'obj_info' or 'end_header', "
                              "found '{}'",
                              excerpt(keyword)));
  }
}

// ---------------------------------------------------------------------------------------------
// Body: the same element walk over two encodings

// What is being read, turned into words only when the read fails (formatting per value would
// dominate the reading time).
struct Where {
  enum Part { value, count, item };
  const Element* element;
  const Property* property;
  uint64_t record;
  Part part;
};

std::string describe(const Where& w) {
  const Scalar type = w.part == Where::count ? w.property->count_type : w.property->type;
  const char* part = w.part == Where::count ? "list count" : w.part == Where::item ? "list item" : "value";
  // "an int value", "a uint value": the article follows the sound.
  return fmt::format("{} {} {} for property '{}' of {} {}", type == Scalar::int32 ? "an" : "a", info(type).name,
                     part, excerpt(w.property->name), excerpt(w.element->name), w.record);
}

class BinaryBody {
 public:
  BinaryBody(const Source& source, const Header& header)
      : bytes_(source.bytes),
        cursor_(source.bytes, source.path, source.gzip),
        endian_(header.encoding == Encoding::binary_big_endian ? Endian::big : Endian::little) {
    cursor_.seek(header.body_offset, "the body");
  }

  double scalar(Scalar type, const Where& where) {
    const std::size_t size = info(type).size;
    if (cursor_.remaining() < size)
      cursor_.fail(fmt::format("expected {} ({} bytes), but only {} bytes are left (the file is truncated)",
                               describe(where), size, cursor_.remaining()));
    last_ = cursor_.offset();
    const uint8_t* p = cursor_.take(size, {}).data();
    switch (type) {
      case Scalar::int8: return ByteCursor::load<int8_t>(p, endian_);
      case Scalar::uint8: return ByteCursor::load<uint8_t>(p, endian_);
      case Scalar::int16: return ByteCursor::load<int16_t>(p, endian_);
      case Scalar::uint16: return ByteCursor::load<uint16_t>(p, endian_);
      case Scalar::int32: return ByteCursor::load<int32_t>(p, endian_);
      case Scalar::uint32: return ByteCursor::load<uint32_t>(p, endian_);
      case Scalar::float32: return ByteCursor::load<float>(p, endian_);
      case Scalar::float64: return ByteCursor::load<double>(p, endian_);
    }
    return 0;
  }

  void check_count(const Element& element) const {
    cursor_.require_records(element.count, element.min_binary_size(),
                            fmt::format("element '{}' (declared with {} records on header line {})", excerpt(element.name),
                                        element.count, element.line));
  }

  void check_list(uint64_t n, Scalar item, const Where& where) const {
    const std::size_t size = info(item).size;
    if (n > cursor_.remaining() / size)
      cursor_.fail(fmt::format("expected {} list items of {} bytes for property '{}' of {} {}, but only {} bytes "
                               "are left",
                               n, size, excerpt(where.property->name), excerpt(where.element->name), where.record,
                               cursor_.remaining()));
  }

  void skip_items(uint64_t n, Scalar item, const Where& where) {
    check_list(n, item, where);
    cursor_.skip(std::size_t(n) * info(item).size, "list items");
  }

  // Elements without lists have a fixed record size: skip them whole (check_count came first).
  bool skip_fixed(const Element& element) {
    if (element.has_list()) return false;
    cursor_.skip(std::size_t(element.count) * element.min_binary_size(), "the records of element " + element.name);
    return true;
  }

  [[noreturn]] void fail_last(const std::string& message) const { cursor_.fail_at(last_, message); }

  /// After the last element: nothing but whitespace may follow (a count too low leaves records).
  void check_end() const {
    const std::size_t at = cursor_.offset(), size = cursor_.size();
    const ByteView rest = cursor_.remaining() ? ByteView(bytes_.data() + at, size - at) : ByteView();
    const bool blank = std::all_of(rest.begin(), rest.end(), [](uint8_t c) { return c == '\n' || c == '\r' || c == ' '; });
    if (!blank)
      cursor_.fail_at(at, fmt::format("expected the end of the file after the elements its header counts, found {} more "
                                      "bytes (do the counts match the data?)",
                                      rest.size()));
  }

 private:
  ByteView bytes_;
  ByteCursor cursor_;
  Endian endian_;
  std::size_t last_ = 0;
};

class AsciiBody {
 public:
  AsciiBody(const Source& source, const Header& header)
      : text_(reinterpret_cast<const char*>(source.bytes.data()), source.bytes.size()),
        file_(source.path),
        pos_(header.body_offset),
        line_(header.body_line) {
    check_text(source, header.body_offset, source.bytes.size());  // the body is text, to its last byte
  }

  double scalar(Scalar type, const Where& where) {
    const std::string_view token = next_token(where);
    const ScalarInfo& t = info(type);
    const char* begin = token.data();
    const char* end = token.data() + token.size();
    if (begin != end && *begin == '+') ++begin;  // from_chars rejects the '+' that printf may write
    double value = 0;
    bool ok = false;
    if (t.integer) {
      int64_t integer = 0;
      const auto [ptr, ec] = std::from_chars(begin, end, integer);
      if (ec == std::errc() && ptr == end) {
        value = double(integer);
        ok = true;
      } else {
        // Some writers print integers as "3.0"; accept them when they are whole numbers.
        const auto [ptr2, ec2] = std::from_chars(begin, end, value);
        ok = ec2 == std::errc() && ptr2 == end && std::isfinite(value) && value == std::floor(value);
      }
      ok = ok && value >= t.min && value <= t.max;
    } else if (type == Scalar::float32) {
      float f = 0;
      const auto [ptr, ec] = std::from_chars(begin, end, f);
      ok = ec == std::errc() && ptr == end;
      value = f;
    } else {
      const auto [ptr, ec] = std::from_chars(begin, end, value);
      ok = ec == std::errc() && ptr == end;
    }
    if (!ok)
      throw FormatError(file_, fmt::format("line {}", last_line_),
                        fmt::format("expected {}{}, found '{}'", describe(where),
                                    t.integer ? fmt::format(" (an integer in {}..{})", int64_t(t.min), int64_t(t.max))
                                              : "",
                                    excerpt(token)));
    return value;
  }

  void check_count(const Element& element) const {
    // Each value is a token of at least one character plus a separator.
    const std::size_t values = element.properties.size();
    if (values == 0 || element.count == 0) return;
    const std::size_t max_tokens = (text_.size() - std::min(pos_, text_.size()) + 1) / 2;
    if (element.count > max_tokens / values)
      throw FormatError(file_, fmt::format("line {}", line_),
                        fmt::format("expected {} records of {} values for element '{}' (declared on header line "
                                    "{}), but only {} bytes of text are left (the count is larger than the file "
                                    "can hold)",
                                    element.count, values, excerpt(element.name), element.line, text_.size() - pos_));
  }

  void check_list(uint64_t n, Scalar /*item*/, const Where& where) const {
    if (n > (text_.size() - pos_ + 1) / 2)
      throw FormatError(file_, fmt::format("line {}", last_line_),
                        fmt::format("expected {} list items for property '{}' of {} {}, but only {} bytes of text "
                                    "are left",
                                    n, excerpt(where.property->name), excerpt(where.element->name), where.record,
                                    text_.size() - pos_));
  }

  void skip_items(uint64_t n, Scalar item, const Where& where) {
    check_list(n, item, where);
    for (uint64_t i = 0; i < n; ++i) scalar(item, where);
  }

  bool skip_fixed(const Element&) { return false; }

  [[noreturn]] void fail_last(const std::string& message) const {
    throw FormatError(file_, fmt::format("line {}", last_line_), message);
  }

  /// After the last element: nothing but whitespace may follow (a count too low leaves values).
  void check_end() {
    while (pos_ < text_.size() && std::string_view(" \t\r\n\f\v").find(text_[pos_]) != std::string_view::npos) {
      if (text_[pos_] == '\n') ++line_;
      ++pos_;
    }
    if (pos_ == text_.size()) return;
    std::size_t end = pos_;
    while (end < text_.size() && std::string_view(" \t\r\n\f\v").find(text_[end]) == std::string_view::npos) ++end;
    throw FormatError(file_, fmt::format("line {}", line_),
                      fmt::format("expected the end of the file after the elements its header counts, found '{}' "
                                  "(do the counts match the data?)",
                                  excerpt(text_.substr(pos_, end - pos_))));
  }

 private:
  std::string_view next_token(const Where& where) {
    while (pos_ < text_.size()) {
      const char c = text_[pos_];
      if (c == '\n') ++line_;
      else if (c != ' ' && c != '\t' && c != '\r' && c != '\f' && c != '\v') break;
      ++pos_;
    }
    // At the end, point at the last line that had a value rather than the empty line after it.
    if (pos_ == text_.size())
      throw FormatError(file_, fmt::format("line {}", last_line_ ? last_line_ : line_),
                        fmt::format("expected {}, found the end of the file (the file is truncated)",
                                    describe(where)));
    const std::size_t start = pos_;
    while (pos_ < text_.size()) {
      const char c = text_[pos_];
      if (c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v') break;
      ++pos_;
    }
    last_line_ = line_;
    return text_.substr(start, pos_ - start);
  }

  std::string_view text_;
  std::string file_;
  std::size_t pos_;
  std::size_t line_;
  std::size_t last_line_ = 0;
};

// The vertex element's scalar properties as float columns (list properties are read and dropped).
struct VertexColumns {
  const Element* element = nullptr;
  std::vector<std::vector<float>> columns;  // one per property; empty for lists
};

// What read_body collects: the vertex columns and, for meshes, the triangles.
struct BodyTargets {
  const Source* source = nullptr;  // for the memory checks
  VertexColumns* vertices = nullptr;
  std::vector<Triangle>* triangles = nullptr;  // null: the face element is skipped
  uint64_t vertex_count = 0;
};

uint64_t read_list_count(auto& body, const Property& property, const Where& where) {
  const double n = body.scalar(property.count_type, Where{where.element, where.property, where.record, Where::count});
  if (n < 0) body.fail_last(fmt::format("expected a non-negative list count for property '{}' of {} {}, found {}",
                                        excerpt(property.name), excerpt(where.element->name), where.record, int64_t(n)));
  return uint64_t(n);
}

template <class Body>
void read_vertices(Body& body, const Element& element, VertexColumns& out) {
  out.element = &element;
  out.columns.resize(element.properties.size());
  for (std::size_t p = 0; p < element.properties.size(); ++p)
    if (!element.properties[p].list) out.columns[p].resize(element.count);
  for (uint64_t i = 0; i < element.count; ++i)
    for (std::size_t p = 0; p < element.properties.size(); ++p) {
      const Property& property = element.properties[p];
      const Where where{&element, &property, i, Where::value};
      if (property.list) {
        body.skip_items(read_list_count(body, property, where), property.type,
                        Where{&element, &property, i, Where::item});
      } else {
        out.columns[p][i] = static_cast<float>(body.scalar(property.type, where));
      }
    }
}

// The face property holding the corner indices, or properties.size() when there is none.
std::size_t face_index_property(const Element& face) {
  const std::size_t i = face.index_of("vertex_indices");
  return i < face.properties.size() ? i : face.index_of("vertex_index");
}

template <class Body>
void read_faces(Body& body, const Element& element, uint64_t vertex_count, std::vector<Triangle>& triangles) {
  const std::size_t index_property = face_index_property(element);  // validated by decode()
  triangles.reserve(std::size_t(element.count));
  std::vector<uint32_t> polygon;
  for (uint64_t f = 0; f < element.count; ++f)
    for (std::size_t p = 0; p < element.properties.size(); ++p) {
      const Property& property = element.properties[p];
      const Where where{&element, &property, f, Where::value};
      if (!property.list) {
        body.scalar(property.type, where);
        continue;
      }
      const uint64_t n = read_list_count(body, property, where);
      const Where item{&element, &property, f, Where::item};
      if (p != index_property) {
        body.skip_items(n, property.type, item);
        continue;
      }
      body.check_list(n, property.type, item);
      polygon.clear();
      for (uint64_t k = 0; k < n; ++k) {
        const double v = body.scalar(property.type, item);
        if (v < 0 || v >= double(vertex_count))
          body.fail_last(fmt::format("expected a vertex index in 0..{} for face {}, found {}",
                                     vertex_count == 0 ? 0 : vertex_count - 1, f, int64_t(v)));
        polygon.push_back(uint32_t(v));
      }
      // Polygons become triangle fans; faces with fewer than three corners carry no area and are
      // dropped.
      for (std::size_t k = 2; k < polygon.size(); ++k) triangles.push_back({polygon[0], polygon[k - 1], polygon[k]});
    }
}

template <class Body>
void skip_element(Body& body, const Element& element) {
  if (element.properties.empty() || body.skip_fixed(element)) return;
  for (uint64_t i = 0; i < element.count; ++i)
    for (const Property& property : element.properties) {
      const Where where{&element, &property, i, Where::value};
      if (property.list)
        body.skip_items(read_list_count(body, property, where), property.type,
                        Where{&element, &property, i, Where::item});
      else
        body.scalar(property.type, where);
    }
}

template <class Body>
void read_body(Body& body, const Header& header, const BodyTargets& targets) {
  for (const Element& element : header.elements) {
    if (element.properties.empty()) continue;  // nothing stored, however large the count
    body.check_count(element);
    if (element.name == "vertex" && targets.vertices) {
      const std::size_t scalars = std::size_t(std::count_if(element.properties.begin(), element.properties.end(),
                                                            [](const Property& p) { return !p.list; }));
      check_particle_memory(*targets.source, element.count, scalars);
      read_vertices(body, element, *targets.vertices);
    } else if (element.name == "face" && targets.triangles) {
      check_read_memory(*targets.source, double(element.count) * sizeof(Triangle), fmt::format("{} faces", element.count));
      read_faces(body, element, targets.vertex_count, *targets.triangles);
    } else {
      skip_element(body, element);
    }
  }
  body.check_end();
}

// ---------------------------------------------------------------------------------------------
// From columns to positions, normals and attributes

struct Group {
  std::string name;
  std::vector<std::size_t> members;  // property indices, in component order
  bool color = false;
};

// Groups the vertex properties into attributes (see ply.hpp). Properties in `taken` (positions,
// mesh normals) are left out. Groups are formed first, whatever order their members appear in,
// then ordered by their first member so attributes follow the file's property order.
std::vector<Group> group_properties(const Element& element, std::vector<bool> taken) {
  const std::vector<Property>& props = element.properties;
  std::vector<Group> groups;
  std::set<std::string> used;

  auto free_scalar = [&](std::string_view name) -> std::optional<std::size_t> {
    const std::size_t i = element.index_of(name);
    if (i == props.size() || props[i].list || taken[i]) return std::nullopt;
    return i;
  };
  auto try_group = [&](const std::string& name, const std::vector<std::string>& member_names, bool color) {
    std::vector<std::size_t> members;
    for (const std::string& m : member_names) {
      const std::optional<std::size_t> i = free_scalar(m);
      if (!i) return;
      members.push_back(*i);
    }
    // A group may not take the name of a property or of another attribute.
    if (used.count(name) || (element.find(name) && std::find(member_names.begin(), member_names.end(), name) ==
                                                      member_names.end()))
      return;
    for (std::size_t i : members) taken[i] = true;
    used.insert(name);
    groups.push_back(Group{name, std::move(members), color});
  };

  try_group("velocity", {"vx", "vy", "vz"}, false);
  try_group("normal", {"nx", "ny", "nz"}, false);
  try_group("color", {"red", "green", "blue"}, true);
  for (std::size_t i = 0; i < props.size(); ++i) {
    if (taken[i] || props[i].list) continue;
    const std::string& n = props[i].name;
    if (n.size() > 2 && n.ends_with("_x")) {
      const std::string base = n.substr(0, n.size() - 2);
      try_group(base, {base + "_x", base + "_y", base + "_z"}, false);
    } else if (n.size() > 2 && n.ends_with("_0")) {
      const std::string base = n.substr(0, n.size() - 2);
      std::vector<std::string> members;
      while (free_scalar(fmt::format("{}_{}", base, members.size())))
        members.push_back(fmt::format("{}_{}", base, members.size()));
      if (members.size() >= 2) try_group(base, members, false);
    }
  }
  for (std::size_t i = 0; i < props.size(); ++i) {
    if (taken[i] || props[i].list) continue;
    taken[i] = true;
    groups.push_back(Group{props[i].name, {i}, false});
  }
  std::sort(groups.begin(), groups.end(), [](const Group& a, const Group& b) {
    return *std::min_element(a.members.begin(), a.members.end()) <
           *std::min_element(b.members.begin(), b.members.end());
  });
  return groups;
}

std::vector<Attribute> build_attributes(const VertexColumns& v, const std::vector<Group>& groups) {
  const std::size_t n = v.element->count;
  std::vector<Attribute> attributes;
  for (const Group& g : groups) {
    Attribute a;
    a.name = g.name;
    a.components = int(g.members.size());
    a.integer = !g.color && std::all_of(g.members.begin(), g.members.end(), [&](std::size_t m) {
      return info(v.element->properties[m].type).integer;
    });
    a.values.resize(n * g.members.size());
    for (std::size_t c = 0; c < g.members.size(); ++c) {
      const std::vector<float>& column = v.columns[g.members[c]];
      // 8-bit colours are 0..255 by convention; the library's colours are 0..1.
      const float divisor = g.color && v.element->properties[g.members[c]].type == Scalar::uint8 ? 255.0f : 1.0f;
      for (std::size_t i = 0; i < n; ++i) a.values[i * g.members.size() + c] = column[i] / divisor;
    }
    attributes.push_back(std::move(a));
  }
  return attributes;
}

std::vector<Vec3f> gather(const VertexColumns& v, std::size_t ix, std::size_t iy, std::size_t iz) {
  std::vector<Vec3f> out(v.element->count);
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = {v.columns[ix][i], v.columns[iy][i], v.columns[iz][i]};
  return out;
}

}  // namespace

std::optional<PlyRecords> ply_vertex_records(const Source& head) {
  if (!sniff_ply(head.bytes)) return std::nullopt;
  const std::string_view text(reinterpret_cast<const char*>(head.bytes.data()), head.bytes.size());
  if (text.find("end_header") == std::string_view::npos) return std::nullopt;  // the head is too short
  Header h;
  try {
    h = parse_header(head);
  } catch (const FormatError&) {
    return std::nullopt;  // read_particles says what is wrong
  }
  if (h.encoding == Encoding::ascii || h.elements.empty() || h.elements[0].name != "vertex" ||
      h.elements[0].has_list())
    return std::nullopt;
  const Element& v = h.elements[0];
  PlyRecords r;
  r.offset = h.body_offset;
  r.record = v.min_binary_size();
  r.count = v.count;
  r.format = h.encoding == Encoding::binary_little_endian ? "binary_little_endian" : "binary_big_endian";
  for (const Property& p : v.properties) r.properties += fmt::format("property {} {}\n", info(p.type).name, p.name);
  return r;
}

std::string ply_range_header(const PlyRecords& records, std::size_t count) {
  return fmt::format("ply\nformat {} 1.0\nelement vertex {}\n{}end_header\n", records.format, count, records.properties);
}

namespace {

struct Decoded {
  Header header;
  VertexColumns vertices;
  std::vector<Triangle> triangles;
  std::size_t ix = 0, iy = 0, iz = 0;
};

Decoded decode(const Source& source, bool want_faces) {
  Decoded d;
  d.header = parse_header(source);
  const Element* vertex = d.header.find("vertex");
  if (!vertex)
    throw FormatError(source.path, fmt::format("line {}", d.header.end_line),
                      "expected an element 'vertex' in the header");
  d.ix = vertex->index_of("x");
  d.iy = vertex->index_of("y");
  d.iz = vertex->index_of("z");
  const std::size_t np = vertex->properties.size();
  if (d.ix == np || d.iy == np || d.iz == np || vertex->properties[d.ix].list || vertex->properties[d.iy].list ||
      vertex->properties[d.iz].list)
    throw FormatError(source.path, fmt::format("line {}", vertex->line),
                      "expected scalar properties x, y and z in element 'vertex'");
  BodyTargets targets{&source, &d.vertices, want_faces ? &d.triangles : nullptr, vertex->count};
  if (want_faces) {
    if (const Element* face = d.header.find("face"); face && !face->properties.empty()) {
      const std::size_t i = face_index_property(*face);
      if (i == face->properties.size() || !face->properties[i].list || !info(face->properties[i].type).integer)
        throw FormatError(source.path, fmt::format("line {}", face->line),
                          "expected an integer list property 'vertex_indices' (or 'vertex_index') in element "
                          "'face'");
    }
  }
  if (d.header.encoding == Encoding::ascii) {
    AsciiBody body(source, d.header);
    read_body(body, d.header, targets);
  } else {
    BinaryBody body(source, d.header);
    read_body(body, d.header, targets);
  }
  return d;
}

// ---------------------------------------------------------------------------------------------
// Writer

void put_u8(std::vector<uint8_t>& out, uint8_t v) { out.push_back(v); }
void put_u32(std::vector<uint8_t>& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<uint8_t>(v >> (8 * i)));
}
void put_f32(std::vector<uint8_t>& out, float v) { put_u32(out, std::bit_cast<uint32_t>(v)); }

enum class Encode { float32, int32, color_uchar };

struct OutputProperty {
  std::string name;
  const Attribute* attribute;
  int component;
  Encode encode;
};

void check_name(const std::string& name) {
  if (name.empty())
    throw InvalidParameter("cannot write PLY: an attribute has an empty name");
  for (const char c : name)
    if (static_cast<unsigned char>(c) <= ' ' || c == 0x7f)
      throw InvalidParameter(fmt::format("cannot write PLY: attribute name '{}' contains whitespace or control "
                                         "characters, which the PLY header cannot hold",
                                         name));
}

std::vector<OutputProperty> output_properties(const TriangleMesh& mesh) {
  std::vector<OutputProperty> out;
  std::set<std::string> names{"x", "y", "z"};
  if (!mesh.normals.empty()) names.insert({"nx", "ny", "nz"});
  auto add = [&](std::string name, const Attribute& a, int component, Encode encode) {
    if (!names.insert(name).second)
      throw InvalidParameter(fmt::format("cannot write PLY: attribute '{}' would be written as property '{}', "
                                         "which is already used",
                                         a.name, name));
    out.push_back(OutputProperty{std::move(name), &a, component, encode});
  };
  for (const Attribute& a : mesh.attributes) {
    check_name(a.name);
    if (a.components < 1)
      throw InvalidParameter(fmt::format("cannot write PLY: attribute '{}' has {} components", a.name, a.components));
    if (a.values.size() != mesh.vertices.size() * std::size_t(a.components))
      throw InvalidParameter(fmt::format("cannot write PLY: attribute '{}' has {} values, expected {} ({} vertices × "
                                         "{})",
                                         a.name, a.values.size(), mesh.vertices.size() * std::size_t(a.components),
                                         mesh.vertices.size(), a.components));
    const Encode number = a.integer ? Encode::int32 : Encode::float32;
    if (a.components == 1) {
      add(a.name, a, 0, number);
    } else if (a.name == "color" && a.components == 3) {
      add("red", a, 0, Encode::color_uchar);
      add("green", a, 1, Encode::color_uchar);
      add("blue", a, 2, Encode::color_uchar);
    } else if (a.name == "velocity" && a.components == 3) {
      add("vx", a, 0, number);
      add("vy", a, 1, number);
      add("vz", a, 2, number);
    } else if (a.components == 3) {
      add(a.name + "_x", a, 0, number);
      add(a.name + "_y", a, 1, number);
      add(a.name + "_z", a, 2, number);
    } else {
      for (int c = 0; c < a.components; ++c) add(fmt::format("{}_{}", a.name, c), a, c, number);
    }
  }
  return out;
}

}  // namespace

bool sniff_ply(ByteView bytes) {
  return bytes.size() >= 4 && bytes[0] == 'p' && bytes[1] == 'l' && bytes[2] == 'y' &&
         (bytes[3] == '\n' || bytes[3] == '\r');
}

ParticleSet read_ply_particles(const Source& source, const ReadOptions& /*options*/, ReadReport* report) {
  Decoded d = decode(source, false);
  ParticleSet particles;
  particles.positions = gather(d.vertices, d.ix, d.iy, d.iz);
  std::vector<bool> taken(d.vertices.element->properties.size(), false);
  taken[d.ix] = taken[d.iy] = taken[d.iz] = true;
  particles.attributes = build_attributes(d.vertices, group_properties(*d.vertices.element, taken));
  if (report) report->format = fmt::format("ply ({})", encoding_name(d.header.encoding));
  return particles;
}

TriangleMesh read_ply_mesh(const Source& source) {
  Decoded d = decode(source, true);
  const Element& vertex = *d.vertices.element;
  TriangleMesh mesh;
  mesh.vertices = gather(d.vertices, d.ix, d.iy, d.iz);
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Vec3f p = mesh.vertices[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw FormatError(source.path, fmt::format("vertex {}", i),
                        fmt::format("expected finite coordinates, found ({}, {}, {})", p.x, p.y, p.z));
  }
  std::vector<bool> taken(vertex.properties.size(), false);
  taken[d.ix] = taken[d.iy] = taken[d.iz] = true;
  const std::size_t inx = vertex.index_of("nx"), iny = vertex.index_of("ny"), inz = vertex.index_of("nz");
  const std::size_t np = vertex.properties.size();
  if (inx < np && iny < np && inz < np && !vertex.properties[inx].list && !vertex.properties[iny].list &&
      !vertex.properties[inz].list) {
    mesh.normals = gather(d.vertices, inx, iny, inz);
    taken[inx] = taken[iny] = taken[inz] = true;
  }
  mesh.attributes = build_attributes(d.vertices, group_properties(vertex, taken));
  mesh.triangles = std::move(d.triangles);
  return mesh;
}

struct PlyMeshWriter::State {
  std::string path;
  std::size_t vertices = 0, triangles = 0, vertices_written = 0, triangles_written = 0;
  bool normals = false;
  std::vector<std::pair<std::string, int>> layout;  // attribute names and components
  AtomicFile file;
  std::vector<uint8_t> chunk;
  static constexpr std::size_t flush_at = std::size_t(1) << 20;

  State(const std::string& p) : path(p), file(p) { chunk.reserve(flush_at + 4096); }
  void flush_if_full() {
    if (chunk.size() >= flush_at) {
      file.write(chunk);
      chunk.clear();
    }
  }
};

PlyMeshWriter::PlyMeshWriter(const std::string& path, std::size_t vertices, std::size_t triangles,
                             const TriangleMesh& layout) {
  if (vertices > std::numeric_limits<uint32_t>::max())
    throw InvalidParameter(
        fmt::format("cannot write '{}': {} vertices do not fit PLY's uint vertex indices", path, vertices));
  // The property list from the layout's attributes (their names checked; their values not read).
  TriangleMesh named;  // one vertex of the layout
  named.vertices.resize(1);
  named.normals.resize(layout.normals.empty() ? 0 : 1);
  for (const Attribute& a : layout.attributes)
    named.attributes.push_back({a.name, a.components, a.integer, std::vector<float>(std::size_t(std::max(a.components, 0)))});
  const std::vector<OutputProperty> properties = output_properties(named);
  std::string header = fmt::format("ply\nformat binary_little_endian 1.0\ncomment written by meniscus\n"
                                   "element vertex {}\nproperty float x\nproperty float y\nproperty float z\n",
                                   vertices);
  if (!layout.normals.empty()) header += "property float nx\nproperty float ny\nproperty float nz\n";
  for (const OutputProperty& p : properties)
    header += fmt::format("property {} {}\n",
                          p.encode == Encode::color_uchar ? "uchar" : p.encode == Encode::int32 ? "int" : "float",
                          p.name);
  header += fmt::format("element face {}\nproperty list uchar uint vertex_indices\nend_header\n", triangles);
  state_ = std::make_unique<State>(path);
  state_->vertices = vertices, state_->triangles = triangles, state_->normals = !layout.normals.empty();
  for (const Attribute& a : layout.attributes) state_->layout.emplace_back(a.name, a.components);
  state_->file.write(header);
}

PlyMeshWriter::~PlyMeshWriter() = default;

void PlyMeshWriter::add_vertices(const TriangleMesh& part) {
  State& s = *state_;
  const std::size_t nv = part.vertices.size();
  if (s.vertices_written + nv > s.vertices)
    throw InvalidParameter(fmt::format("cannot write '{}': more than the {} vertices of its header", s.path, s.vertices));
  if (s.normals && part.normals.size() != nv)
    throw InvalidParameter(fmt::format("cannot write PLY '{}': {} normals for {} vertices", s.path, part.normals.size(), nv));
  bool same_layout = part.attributes.size() == s.layout.size();
  for (std::size_t a = 0; same_layout && a < s.layout.size(); ++a)
    same_layout = part.attributes[a].name == s.layout[a].first && part.attributes[a].components == s.layout[a].second;
  if (!same_layout)
    throw InvalidParameter(fmt::format("cannot write '{}': a part's attributes are not the header's", s.path));
  const std::vector<OutputProperty> properties = output_properties(part);
  // Integer attributes must survive the int conversion; refuse before the part is written.
  for (const OutputProperty& p : properties) {
    if (p.encode != Encode::int32) continue;
    const std::size_t c = std::size_t(p.attribute->components);
    for (std::size_t i = 0; i < nv; ++i) {
      const float v = p.attribute->values[i * c + std::size_t(p.component)];
      if (!(v >= -2147483648.0f && v < 2147483648.0f))
        throw InvalidParameter(fmt::format("cannot write '{}': integer attribute '{}' has value {} at vertex {}, "
                                           "outside the int range",
                                           s.path, p.attribute->name, v, s.vertices_written + i));
    }
  }
  std::vector<uint8_t>& chunk = s.chunk;
  for (std::size_t i = 0; i < nv; ++i) {
    const Vec3f p = part.vertices[i];
    put_f32(chunk, p.x);
    put_f32(chunk, p.y);
    put_f32(chunk, p.z);
    if (s.normals) {
      put_f32(chunk, part.normals[i].x);
      put_f32(chunk, part.normals[i].y);
      put_f32(chunk, part.normals[i].z);
    }
    for (const OutputProperty& prop : properties) {
      const float v = prop.attribute->values[i * std::size_t(prop.attribute->components) + std::size_t(prop.component)];
      switch (prop.encode) {
        case Encode::float32: put_f32(chunk, v); break;
        case Encode::int32: put_u32(chunk, std::bit_cast<uint32_t>(static_cast<int32_t>(std::lround(v)))); break;
        case Encode::color_uchar: {
          const float clamped = v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f;  // NaN → 0
          put_u8(chunk, static_cast<uint8_t>(std::lround(clamped * 255.0f)));
          break;
        }
      }
    }
    s.flush_if_full();
  }
  s.vertices_written += nv;
}

void PlyMeshWriter::add_triangles(const Triangle* triangles, std::size_t count) {
  State& s = *state_;
  if (s.vertices_written != s.vertices)
    throw InvalidParameter(fmt::format("cannot write '{}': triangles before all {} vertices", s.path, s.vertices));
  if (s.triangles_written + count > s.triangles)
    throw InvalidParameter(fmt::format("cannot write '{}': more than the {} triangles of its header", s.path, s.triangles));
  for (std::size_t i = 0; i < count; ++i) {
    const Triangle& t = triangles[i];
    for (const uint32_t v : t)
      if (v >= s.vertices)
        throw InvalidParameter(fmt::format("cannot write PLY '{}': triangle {} refers to vertex {}, but the mesh has "
                                           "{} vertices",
                                           s.path, s.triangles_written + i, v, s.vertices));
    put_u8(s.chunk, 3);
    put_u32(s.chunk, t[0]);
    put_u32(s.chunk, t[1]);
    put_u32(s.chunk, t[2]);
    s.flush_if_full();
  }
  s.triangles_written += count;
}

void PlyMeshWriter::commit() {
  State& s = *state_;
  if (s.vertices_written != s.vertices || s.triangles_written != s.triangles)
    throw InvalidParameter(fmt::format("cannot write '{}': {} of {} vertices and {} of {} triangles given", s.path,
                                       s.vertices_written, s.vertices, s.triangles_written, s.triangles));
  s.file.write(s.chunk);
  s.chunk.clear();
  s.file.commit();
}

void write_ply_mesh(const std::string& path, const TriangleMesh& mesh) {
  check_mesh_for_writing(path, mesh, "PLY");
  output_properties(mesh);  // names PLY cannot hold are refused before the file is opened
  PlyMeshWriter writer(path, mesh.vertices.size(), mesh.triangles.size(), mesh);
  writer.add_vertices(mesh);
  writer.add_triangles(mesh.triangles.data(), mesh.triangles.size());
  writer.commit();
}

}  // namespace meniscus::io
