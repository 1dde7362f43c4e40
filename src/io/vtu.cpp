// meniscus io — VTK XML particle reader (Kitware "VTK XML Formats"; vtkXMLWriter's binary/appended blob layouts).
#include "io/vtu.hpp"

#include <algorithm>
#include <charconv>
#include <cstring>
#include <cmath>
#include <limits>
#include <optional>
#include <string_view>
#include <zlib.h>

#include <fmt/format.h>

#include "io/text_lines.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/messages.hpp"

namespace meniscus::io {

namespace {

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

// ------------------------------------------------------------------------------------ base64
int base64_value(char c) {
  if (c >= 'A' && c <= 'Z') return c - 'A';
  if (c >= 'a' && c <= 'z') return c - 'a' + 26;
  if (c >= '0' && c <= '9') return c - '0' + 52;
  if (c == '+') return 62;
  if (c == '/') return 63;
  return -1;
}

// Decodes base64 text (whitespace skipped, '=' padding ends a 4-character group). Returns the
// offset of the first invalid character, or nullopt on success.
std::optional<std::size_t> base64_decode(std::string_view text, Bytes& out) {
  out.clear();
  out.reserve(text.size() / 4 * 3 + 3);
  uint32_t acc = 0;
  int bits = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (is_space(c)) continue;
    if (c == '=') {  // padding: drop the partial byte and restart (VTK pads each encoded part)
      acc = 0;
      bits = 0;
      continue;
    }
    const int v = base64_value(c);
    if (v < 0) return i;
    acc = (acc << 6) | uint32_t(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<uint8_t>(acc >> bits));
      acc &= (1u << bits) - 1;
    }
  }
  return std::nullopt;
}

std::size_t base64_chars(uint64_t bytes) { return std::size_t((bytes + 2) / 3 * 4); }

// ------------------------------------------------------------------------------------ XML tags
struct Tag {
  std::string name;
  std::vector<std::pair<std::string, std::string>> attributes;
  bool closing = false;
  bool self_closing = false;
  std::size_t at = 0;   // offset of '<'
  std::size_t end = 0;  // offset after '>'

  std::optional<std::string> get(std::string_view key) const {
    for (const auto& [k, v] : attributes)
      if (k == key) return v;
    return std::nullopt;
  }
};

std::string unescape(std::string_view s) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '&') {
      static constexpr std::pair<std::string_view, char> entities[] = {
          {"&lt;", '<'}, {"&gt;", '>'}, {"&amp;", '&'}, {"&quot;", '"'}, {"&apos;", '\''}};
      bool matched = false;
      for (const auto& [e, c] : entities)
        if (s.substr(i).starts_with(e)) {
          out.push_back(c);
          i += e.size() - 1;
          matched = true;
          break;
        }
      if (matched) continue;
    }
    out.push_back(s[i]);
  }
  return out;
}

// A purpose-written scanner for the small XML subset VTK writes: declarations, comments, start
// and end tags with quoted attributes. Text content is left to the caller (it is only read for
// DataArrays), and scanning stops at <AppendedData>, after which the bytes may be raw binary.
// Everything it passes is text (refused at its first binary byte), and a tag holds at most
// kMaxTagBytes.
class TagScanner {
 public:
  TagScanner(const Source& source, std::string_view text, const ByteCursor& errors)
      : source_(source), text_(text), errors_(errors) {}

  std::optional<Tag> next() {
    for (;;) {
      const std::size_t lt = text_.find('<', pos_);
      check_to(lt == std::string_view::npos ? text_.size() : lt);
      if (lt == std::string_view::npos) return std::nullopt;
      const std::string_view rest = text_.substr(lt);
      if (rest.starts_with("<?")) {
        pos_ = skip_to(lt, "?>");
      } else if (rest.starts_with("<!--")) {
        pos_ = skip_to(lt, "-->");
      } else if (rest.starts_with("<!")) {
        pos_ = skip_to(lt, ">");
      } else {
        return tag(lt);
      }
    }
  }
  std::size_t position() const { return pos_; }

 private:
  // Refuses the first binary byte before `end` not checked yet.
  void check_to(std::size_t end) {
    if (end <= checked_) return;
    check_text(source_, checked_, end);
    checked_ = end;
  }

  // A malformed construct: a binary byte before the point of failure is what is reported.
  [[noreturn]] void fail_at(std::size_t at, const std::string& message) {
    check_to(std::min(at + 1, text_.size()));
    errors_.fail_at(at, message);
  }

  std::size_t skip_to(std::size_t from, std::string_view end) {
    const std::size_t e = text_.find(end, from);
    if (e == std::string_view::npos) fail_at(text_.size(), fmt::format("expected '{}' to end the XML construct", end));
    check_to(e + end.size());
    return e + end.size();
  }

  Tag tag(std::size_t lt) {
    // The tag is parsed within kMaxTagBytes of its '<': reaching that bound is its own error.
    const std::string_view text = text_.substr(0, std::min(text_.size(), lt + kMaxTagBytes));
    const auto ended = [&](std::size_t i, const std::string& message) {
      if (text.size() < text_.size())
        fail_at(lt, fmt::format("expected a tag of at most {}, found a longer one", human_bytes(double(kMaxTagBytes))));
      fail_at(i, message);
    };
    Tag t;
    t.at = lt;
    std::size_t i = lt + 1;
    if (i < text.size() && text[i] == '/') {
      t.closing = true;
      ++i;
    }
    const std::size_t name_start = i;
    while (i < text.size() && !is_space(text[i]) && text[i] != '>' && text[i] != '/') ++i;
    t.name = std::string(text.substr(name_start, i - name_start));
    if (t.name.empty()) fail_at(lt, "expected an XML tag name after '<'");
    for (;;) {
      while (i < text.size() && is_space(text[i])) ++i;
      if (i >= text.size()) ended(lt, fmt::format("expected '>' to close the <{}> tag", excerpt(t.name)));
      if (text[i] == '>') {
        ++i;
        break;
      }
      if (text[i] == '/' && i + 1 < text.size() && text[i + 1] == '>') {
        t.self_closing = true;
        i += 2;
        break;
      }
      const std::size_t key_start = i;
      while (i < text.size() && !is_space(text[i]) && text[i] != '=' && text[i] != '>') ++i;
      const std::string key(text.substr(key_start, i - key_start));
      while (i < text.size() && is_space(text[i])) ++i;
      if (i >= text.size() || text[i] != '=' || key.empty())
        ended(i, fmt::format("expected name=\"value\" attributes in the <{}> tag", excerpt(t.name)));
      ++i;
      while (i < text.size() && is_space(text[i])) ++i;
      if (i >= text.size() || (text[i] != '"' && text[i] != '\''))
        ended(i, fmt::format("expected a quoted value for attribute '{}' of <{}>", excerpt(key), excerpt(t.name)));
      const char quote = text[i];
      const std::size_t close = text.find(quote, i + 1);
      if (close == std::string_view::npos)
        ended(i, fmt::format("expected the closing quote of attribute '{}' of <{}>", excerpt(key), excerpt(t.name)));
      t.attributes.emplace_back(key, unescape(text.substr(i + 1, close - i - 1)));
      i = close + 1;
    }
    check_to(i);
    t.end = i;
    pos_ = i;
    return t;
  }

  const Source& source_;
  std::string_view text_;
  const ByteCursor& errors_;
  std::size_t pos_ = 0;
  std::size_t checked_ = 0;  // the bytes before it are text
};

// ------------------------------------------------------------------------------------ arrays
enum class Type : uint8_t { int8, uint8, int16, uint16, int32, uint32, int64, uint64, float32, float64 };

struct TypeInfo {
  std::string_view name;
  Type type;
  std::size_t size;
};
constexpr TypeInfo types[] = {
    {"Int8", Type::int8, 1},    {"UInt8", Type::uint8, 1},     {"Int16", Type::int16, 2},
    {"UInt16", Type::uint16, 2}, {"Int32", Type::int32, 4},    {"UInt32", Type::uint32, 4},
    {"Int64", Type::int64, 8},  {"UInt64", Type::uint64, 8},   {"Float32", Type::float32, 4},
    {"Float64", Type::float64, 8}, {"Char", Type::int8, 1},    {"UChar", Type::uint8, 1},
};

struct ArrayRef {
  std::string name;
  const TypeInfo* type = nullptr;
  int components = 1;
  std::string format;
  uint64_t offset = 0;          // appended
  std::string_view content;     // ascii / binary: the text between the tags
  std::size_t at = 0;           // file offset of the tag, for messages
};

struct Piece {
  uint64_t points = 0, polys = 0;
  std::size_t at = 0;
  std::optional<ArrayRef> positions;
  std::vector<ArrayRef> point_data;
  std::optional<ArrayRef> connectivity, offsets;  // <Polys> of a .vtp
};

struct FileInfo {
  Endian endian = Endian::little;
  std::size_t header_size = 4;  // UInt32 or UInt64 blob headers
  bool compressed = false;
  std::string appended_encoding;
  std::optional<std::size_t> appended_at;  // offset after '_'
};

class VtuReader {
 public:
  explicit VtuReader(const Source& source)
      : source_(source),
        text_(reinterpret_cast<const char*>(source.bytes.data()), source.bytes.size()),
        errors_(source.bytes, source.path, source.gzip) {}

  ParticleSet read(ReadReport* report) {
    scan();
    ParticleSet particles;
    bool first = true;
    for (const Piece& piece : pieces_) {
      if (!piece.positions)
        errors_.fail_at(piece.at, "expected a <Points> DataArray in the <Piece>");
      const std::vector<double> xyz = values(*piece.positions, piece.points, 3);
      kept_ += 12.0 * double(piece.points);
      const std::size_t base = particles.positions.size();
      particles.positions.resize(base + std::size_t(piece.points));
      for (std::size_t i = 0; i < piece.points; ++i)
        particles.positions[base + i] = {float(xyz[3 * i]), float(xyz[3 * i + 1]), float(xyz[3 * i + 2])};
      if (!first && piece.point_data.size() != particles.attributes.size())
        errors_.fail_at(piece.at, fmt::format("expected the same {} point arrays in every <Piece>, found {}",
                                              particles.attributes.size(), piece.point_data.size()));
      for (std::size_t k = 0; k < piece.point_data.size(); ++k) {
        const ArrayRef& a = piece.point_data[k];
        const std::vector<double> v = values(a, piece.points, a.components);
        kept_ += 4.0 * double(v.size());
        if (first) {
          const bool integer = a.type->type != Type::float32 && a.type->type != Type::float64;
          particles.attributes.push_back(Attribute{a.name, a.components, integer, {}});
        } else if (particles.attributes[k].name != a.name || particles.attributes[k].components != a.components) {
          errors_.fail_at(a.at, fmt::format("expected point array '{}' ({} components) as in the first <Piece>, "
                                            "found '{}' ({})",
                                            excerpt(particles.attributes[k].name), particles.attributes[k].components, excerpt(a.name),
                                            a.components));
        }
        std::vector<float>& out = particles.attributes[k].values;
        for (const double d : v) out.push_back(float(d));
      }
      first = false;
    }
    if (pieces_.empty()) errors_.fail_at(0, "expected a <Piece> in the VTK XML file");
    if (report)
      report->format = fmt::format("vtu ({}{}{})", formats_, info_.compressed ? ", zlib" : "",
                                   info_.header_size == 8 ? ", UInt64 headers" : "");
    return particles;
  }

  /// A .vtp of triangles: the points and point data as read(), the <Polys> as triangles (each
  /// must have three corners); "Normals" (3 components) become the normals.
  TriangleMesh read_mesh() {
    TriangleMesh mesh;
    ParticleSet points = read(nullptr);
    mesh.vertices = std::move(points.positions);
    std::size_t base = 0;
    for (const Piece& piece : pieces_) {
      if (piece.polys > 0 && (!piece.connectivity || !piece.offsets))
        errors_.fail_at(piece.at, "expected <Polys> DataArrays 'connectivity' and 'offsets'");
      if (piece.polys > 0) {
        const std::vector<double> offsets = values(*piece.offsets, piece.polys, 1);
        const std::vector<double> corners = values(*piece.connectivity, 3 * piece.polys, 1);
        for (uint64_t t = 0; t < piece.polys; ++t) {
          if (offsets[t] != double(3 * (t + 1)))
            errors_.fail_at(piece.offsets->at, fmt::format("polygon {} is not a triangle (offset {}, expected {})", t,
                                                           offsets[t], 3 * (t + 1)));
          Triangle tri{};
          for (int c = 0; c < 3; ++c) {
            const double v = corners[3 * t + std::size_t(c)];
            if (!(v >= 0 && v < double(piece.points)))
              errors_.fail_at(piece.connectivity->at,
                              fmt::format("triangle {} refers to point {}, but the piece has {}", t, v, piece.points));
            tri[std::size_t(c)] = uint32_t(base + std::size_t(v));
          }
          mesh.triangles.push_back(tri);
        }
      }
      base += std::size_t(piece.points);
    }
    for (Attribute& a : points.attributes)
      if (a.name == "Normals" && a.components == 3 && mesh.normals.empty()) {
        mesh.normals.resize(mesh.vertices.size());
        for (std::size_t v = 0; v < mesh.normals.size(); ++v)
          mesh.normals[v] = {a.values[3 * v], a.values[3 * v + 1], a.values[3 * v + 2]};
      } else {
        mesh.attributes.push_back(std::move(a));
      }
    return mesh;
  }

 private:
  void scan() {
    TagScanner scanner(source_, text_, errors_);
    std::vector<std::string> open;
    bool seen_root = false;
    // What the pieces and array references hold, checked as they are made: a file of many empty
    // <Piece/> tags costs more than its text.
    std::size_t made = 0;
    const auto hold_tag = [&](double bytes) {
      kept_ += bytes;
      if (++made % 1024 == 0)
        check_read_memory(source_, kept_, fmt::format("the {} pieces and arrays of the XML", made));
    };
    while (std::optional<Tag> tag = scanner.next()) {
      if (tag->closing) {
        if (open.empty() || open.back() != tag->name)
          errors_.fail_at(tag->at, fmt::format("expected </{}>, found </{}>", open.empty() ? "" : excerpt(open.back()), excerpt(tag->name)));
        open.pop_back();
        continue;
      }
      if (!seen_root) {
        if (tag->name != "VTKFile") errors_.fail_at(tag->at, fmt::format("expected <VTKFile>, found <{}>", excerpt(tag->name)));
        root(*tag);
        seen_root = true;
      } else if (tag->name == "Piece") {
        Piece piece;
        piece.at = tag->at;
        piece.points = count_attribute(*tag, "NumberOfPoints");
        if (tag->get("NumberOfPolys")) piece.polys = count_attribute(*tag, "NumberOfPolys");
        hold_tag(double(sizeof(Piece)));
        pieces_.push_back(std::move(piece));
      } else if (tag->name == "DataArray" && !open.empty() && !pieces_.empty() && open.back() == "Polys") {
        ArrayRef a = array(*tag);
        if (!tag->self_closing) {
          const std::size_t close = text_.find("</DataArray", tag->end);
          if (close == std::string_view::npos) errors_.fail_at(tag->at, "expected </DataArray>");
          a.content = text_.substr(tag->end, close - tag->end);
        }
        if (a.name == "connectivity") pieces_.back().connectivity = std::move(a);
        else if (a.name == "offsets") pieces_.back().offsets = std::move(a);
      } else if (tag->name == "DataArray" && !open.empty() && !pieces_.empty() &&
                 (open.back() == "Points" || open.back() == "PointData")) {
        ArrayRef a = array(*tag);
        if (!tag->self_closing) {
          const std::size_t close = text_.find("</DataArray", tag->end);
          if (close == std::string_view::npos) errors_.fail_at(tag->at, "expected </DataArray>");
          a.content = text_.substr(tag->end, close - tag->end);
        }
        hold_tag(double(sizeof(ArrayRef) + a.name.size() + a.format.size()));
        if (open.back() == "Points") {
          if (pieces_.back().positions) errors_.fail_at(tag->at, "expected a single DataArray in <Points>");
          pieces_.back().positions = std::move(a);
        } else {
          pieces_.back().point_data.push_back(std::move(a));
        }
      } else if (tag->name == "AppendedData") {
        info_.appended_encoding = tag->get("encoding").value_or("raw");
        std::size_t i = tag->end;
        while (i < text_.size() && is_space(text_[i])) ++i;
        if (i >= text_.size() || text_[i] != '_')
          errors_.fail_at(i, "expected the '_' marker that starts the appended data");
        info_.appended_at = i + 1;
        return;  // what follows may be raw binary: no more tags to scan
      }
      if (!tag->self_closing) {
        // VTK's files nest about 6 deep; the open tags are held until they close.
        if (open.size() == kMaxDepth)
          errors_.fail_at(tag->at, fmt::format("expected XML nested at most {} tags deep", kMaxDepth));
        open.push_back(tag->name);
      }
      // DataArray content (ascii/base64 text) holds no tags; skip it so '<' in it cannot confuse us.
    }
    if (!seen_root) errors_.fail_at(0, "expected a <VTKFile> element");
  }

  void root(const Tag& tag) {
    const std::string order = tag.get("byte_order").value_or("LittleEndian");
    if (order == "BigEndian") info_.endian = Endian::big;
    else if (order != "LittleEndian")
      errors_.fail_at(tag.at, fmt::format("expected byte_order LittleEndian or BigEndian, found '{}'", order));
    const std::string header = tag.get("header_type").value_or("UInt32");
    if (header == "UInt64") info_.header_size = 8;
    else if (header != "UInt32")
      errors_.fail_at(tag.at, fmt::format("expected header_type UInt32 or UInt64, found '{}'", header));
    if (const std::optional<std::string> compressor = tag.get("compressor"); compressor && !compressor->empty()) {
      if (*compressor != "vtkZLibDataCompressor")
        errors_.fail_at(tag.at, fmt::format("expected no compressor or vtkZLibDataCompressor, found '{}' (LZ4/LZMA "
                                            "are not supported; re-save with zlib or no compression)",
                                            *compressor));
      info_.compressed = true;
    }
  }

  uint64_t count_attribute(const Tag& tag, std::string_view key) const {
    const std::optional<std::string> v = tag.get(key);
    uint64_t n = 0;
    const auto parsed = v ? std::from_chars(v->data(), v->data() + v->size(), n) : std::from_chars_result{};
    if (!v || v->empty() || parsed.ec != std::errc() || parsed.ptr != v->data() + v->size())
      errors_.fail_at(tag.at, fmt::format("expected a non-negative integer attribute {} in <{}>", excerpt(key), excerpt(tag.name)));
    return n;
  }

  ArrayRef array(const Tag& tag) const {
    ArrayRef a;
    a.at = tag.at;
    a.name = tag.get("Name").value_or("");
    const std::string type = tag.get("type").value_or("");
    for (const TypeInfo& t : types)
      if (t.name == type) a.type = &t;
    if (!a.type)
      errors_.fail_at(tag.at, fmt::format("expected a numeric DataArray type (Int8 … UInt64, Float32, Float64) for "
                                          "'{}', found '{}'",
                                          excerpt(a.name), excerpt(type)));
    if (tag.get("NumberOfComponents")) {
      const uint64_t c = count_attribute(tag, "NumberOfComponents");
      if (c < 1 || c > 1024)
        errors_.fail_at(tag.at, fmt::format("expected 1..1024 components for '{}', found {}", excerpt(a.name), c));
      a.components = int(c);
    }
    a.format = tag.get("format").value_or("ascii");
    if (a.format == "appended") a.offset = count_attribute(tag, "offset");
    else if (a.format != "ascii" && a.format != "binary")
      errors_.fail_at(tag.at, fmt::format("expected format ascii, binary or appended for '{}', found '{}'", excerpt(a.name),
                                          a.format));
    return a;
  }

  // ---------------------------------------------------------------------------------- decoding
  std::vector<double> values(const ArrayRef& a, uint64_t points, int components) {
    if (a.components != components)
      errors_.fail_at(a.at, fmt::format("expected {} components for '{}', found {}", components, excerpt(a.name), a.components));
    const uint64_t count = points * uint64_t(components);
    if (points > std::numeric_limits<uint64_t>::max() / 1024 / 8)
      errors_.fail_at(a.at, fmt::format("NumberOfPoints {} is too large", points));
    if (formats_.find(a.format) == std::string::npos) formats_ += (formats_.empty() ? "" : ", ") + a.format;
    if (a.format == "ascii") return ascii(a, count);
    const uint64_t bytes = count * a.type->size;
    Bytes raw;
    if (a.format == "binary") {
      raw = base64_blob(a.content, a, bytes);
    } else {
      if (!info_.appended_at) errors_.fail_at(a.at, fmt::format("expected <AppendedData> for appended array '{}'", excerpt(a.name)));
      const std::size_t start = *info_.appended_at;
      if (a.offset > text_.size() - start)
        errors_.fail_at(a.at, fmt::format("array '{}' has offset {}, past the end of the appended data ({} bytes)",
                                          excerpt(a.name), a.offset, text_.size() - start));
      if (info_.appended_encoding == "base64") {
        raw = base64_blob(text_.substr(start + std::size_t(a.offset)), a, bytes);
      } else if (info_.appended_encoding == "raw") {
        raw = binary_blob(source_.bytes.subspan(start + std::size_t(a.offset)), start + std::size_t(a.offset), a, bytes);
      } else {
        errors_.fail_at(a.at, fmt::format("expected AppendedData encoding raw or base64, found '{}'",
                                          info_.appended_encoding));
      }
    }
    hold(a, double(raw.size()) + 8.0 * double(count));
    std::vector<double> out(static_cast<std::size_t>(count));
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = load(a.type->type, raw.data() + i * a.type->size);
    return out;
  }

  /// Checks the memory of an array about to be decoded (`bytes`) beside the particles decoded so
  /// far, whose float values the caller adds to kept_ (after its size was checked against the file).
  void hold(const ArrayRef& a, double bytes) const {
    check_read_memory(source_, kept_ + bytes, fmt::format("array '{}' ({}) and the arrays before it", excerpt(a.name),
                                                         human_bytes(bytes)));
  }

  double load(Type t, const uint8_t* p) const {
    const Endian e = info_.endian;
    switch (t) {
      case Type::int8: return double(ByteCursor::load<int8_t>(p, e));
      case Type::uint8: return double(ByteCursor::load<uint8_t>(p, e));
      case Type::int16: return double(ByteCursor::load<int16_t>(p, e));
      case Type::uint16: return double(ByteCursor::load<uint16_t>(p, e));
      case Type::int32: return double(ByteCursor::load<int32_t>(p, e));
      case Type::uint32: return double(ByteCursor::load<uint32_t>(p, e));
      case Type::int64: return double(ByteCursor::load<int64_t>(p, e));
      case Type::uint64: return double(ByteCursor::load<uint64_t>(p, e));
      case Type::float32: return double(ByteCursor::load<float>(p, e));
      case Type::float64: return ByteCursor::load<double>(p, e);
    }
    return 0;
  }

  std::vector<double> ascii(const ArrayRef& a, uint64_t count) const {
    if (count > (a.content.size() + 1) / 2)
      errors_.fail_at(a.at, fmt::format("expected {} ascii values for '{}', but its text has only {} bytes", count,
                                        excerpt(a.name), a.content.size()));
    hold(a, 8.0 * double(count));
    std::vector<double> out;
    out.reserve(std::size_t(count));
    const std::string_view s = a.content;
    std::size_t i = 0;
    const bool is_float = a.type->type == Type::float32 || a.type->type == Type::float64;
    while (true) {
      while (i < s.size() && is_space(s[i])) ++i;
      if (i >= s.size()) break;
      const std::size_t start = i;
      while (i < s.size() && !is_space(s[i])) ++i;
      const char* b = s.data() + start;
      const char* e = s.data() + i;
      if (*b == '+') ++b;
      double v = 0;
      bool ok = false;
      if (is_float) {
        const auto [ptr, ec] = std::from_chars(b, e, v);
        ok = ec == std::errc() && ptr == e;
      } else {
        int64_t n = 0;
        const auto [ptr, ec] = std::from_chars(b, e, n);
        ok = ec == std::errc() && ptr == e;
        v = double(n);
      }
      const std::size_t where = std::size_t(s.data() - text_.data()) + start;
      if (!ok) errors_.fail_at(where, fmt::format("expected a {} value for '{}', found '{}'", a.type->name, excerpt(a.name),
                                                  s.substr(start, std::min<std::size_t>(i - start, 40))));
      if (out.size() == count)
        errors_.fail_at(where, fmt::format("expected {} values for '{}', found more", count, excerpt(a.name)));
      out.push_back(v);
    }
    if (out.size() != count)
      errors_.fail_at(a.at, fmt::format("expected {} ascii values for '{}', found {}", count, excerpt(a.name), out.size()));
    return out;
  }

  uint64_t header_int(const uint8_t* p) const {
    return info_.header_size == 8 ? ByteCursor::load<uint64_t>(p, info_.endian)
                                  : ByteCursor::load<uint32_t>(p, info_.endian);
  }

  // A raw blob: [byte count][data] or, compressed, [blocks, block size, last size, compressed
  // sizes…][zlib blocks]. `at` is the blob's file offset, for messages.
  Bytes binary_blob(ByteView blob, std::size_t at, const ArrayRef& a, uint64_t expected) const {
    ByteCursor c(blob, source_.path, source_.gzip);
    const std::size_t hs = info_.header_size;
    auto fail = [&](const std::string& message) -> void {
      errors_.fail_at(at, fmt::format("array '{}': {}", excerpt(a.name), message));
    };
    if (blob.size() < hs) fail("expected the blob header, found the end of the data");
    if (!info_.compressed) {
      const uint64_t n = header_int(blob.data());
      if (n != expected) fail(fmt::format("expected {} data bytes ({} values of {} bytes), the header says {}", expected,
                                          expected / a.type->size, a.type->size, n));
      if (n > blob.size() - hs) fail(fmt::format("expected {} data bytes, only {} are left (truncated)", n, blob.size() - hs));
      return Bytes(blob.begin() + std::ptrdiff_t(hs), blob.begin() + std::ptrdiff_t(hs + n));
    }
    if (blob.size() < 3 * hs) fail("expected the compression header, found the end of the data");
    const uint64_t blocks = header_int(blob.data()), block_size = header_int(blob.data() + hs);
    uint64_t last_size = header_int(blob.data() + 2 * hs);
    if (blocks > (blob.size() - 3 * hs) / hs)
      fail(fmt::format("the header announces {} compressed blocks, more than the data can hold", blocks));
    if (last_size == 0) last_size = block_size;  // VTK writes 0 when the last block is full
    const uint64_t total = blocks == 0 ? 0 : (blocks - 1) * block_size + last_size;
    if (blocks > 0 && (block_size == 0 || last_size > block_size || (blocks - 1) > expected / block_size || total != expected))
      fail(fmt::format("expected {} uncompressed bytes, the compression header says {} blocks of {} (last {})",
                       expected, blocks, block_size, last_size));
    std::size_t offset = std::size_t(3 + blocks) * hs;
    // Before allocating the output: the compressed blocks must fit in the data, and deflate
    // expands at most ~1032:1, so a header cannot make us allocate far beyond the file's size.
    uint64_t compressed = 0;
    for (uint64_t b = 0; b < blocks; ++b) {
      compressed += header_int(blob.data() + (3 + b) * hs);
      if (compressed > blob.size() - offset)
        fail(fmt::format("the compressed blocks need {} bytes or more, only {} are left (truncated)", compressed,
                         blob.size() - offset));
    }
    if (expected > compressed * 1032 + blocks * 64)
      fail(fmt::format("{} compressed bytes cannot inflate to the {} bytes the array needs", compressed, expected));
    hold(a, double(expected));
    Bytes out(static_cast<std::size_t>(expected));
    for (uint64_t b = 0; b < blocks; ++b) {
      const uint64_t csize = header_int(blob.data() + (3 + b) * hs);
      const uint64_t usize = b + 1 == blocks ? last_size : block_size;
      if (csize > blob.size() - offset)
        fail(fmt::format("compressed block {} of {} bytes runs past the end of the data ({} bytes left)", b, csize,
                         blob.size() - offset));
      uLongf produced = uLongf(usize);
      const int status = uncompress(out.data() + b * block_size, &produced, blob.data() + offset, uLong(csize));
      if (status != Z_OK || produced != usize)
        fail(fmt::format("expected compressed block {} to inflate to {} bytes ({})", b, usize,
                         status == Z_OK ? fmt::format("got {}", produced) : std::string(zError(status))));
      offset += std::size_t(csize);
    }
    return out;
  }

  // The base64 form: uncompressed blobs are one base64 stream; compressed ones encode the header
  // and the blocks separately (vtkXMLWriter), so the header's length in characters is computed
  // from its block count before the data is decoded.
  Bytes base64_blob(std::string_view text, const ArrayRef& a, uint64_t expected) const {
    const std::size_t at = std::size_t(text.data() - text_.data());
    std::string compact;  // inline content may be wrapped; appended text is not, but both are cheap to compact
    std::size_t i = 0;
    while (i < text.size() && is_space(text[i])) ++i;
    const std::size_t hs = info_.header_size;
    auto decode = [&](std::size_t chars, std::string_view what) {
      while (compact.size() < chars && i < text.size()) {
        if (!is_space(text[i])) compact.push_back(text[i]);
        ++i;
      }
      if (compact.size() < chars)
        errors_.fail_at(at, fmt::format("array '{}': expected {} base64 characters for {}, found {}", excerpt(a.name), chars,
                                        what, compact.size()));
      Bytes out;
      if (const std::optional<std::size_t> bad = base64_decode(std::string_view(compact).substr(0, chars), out))
        errors_.fail_at(at, fmt::format("array '{}': expected base64 text, found '{}' in {}", excerpt(a.name), compact[*bad], what));
      compact.erase(0, chars);
      return out;
    };
    const std::size_t start = i;
    if (!info_.compressed) {
      const Bytes head = decode(base64_chars(hs), "the blob header");
      const uint64_t n = header_int(head.data());
      if (n != expected)
        errors_.fail_at(at, fmt::format("array '{}': expected {} data bytes, the header says {}", excerpt(a.name), expected, n));
      // Header and data form one base64 stream: decode it again from the start, whole.
      i = start;
      compact.clear();
      const Bytes all = decode(base64_chars(hs + n), "the data");
      return Bytes(all.begin() + std::ptrdiff_t(hs), all.begin() + std::ptrdiff_t(hs + n));
    }
    // Compressed: the first header value gives the block count, hence the header's length.
    const Bytes first = decode(base64_chars(hs), "the block count");
    const uint64_t blocks = header_int(first.data());
    if (blocks > text.size() / hs)
      errors_.fail_at(at, fmt::format("array '{}': the header announces {} blocks, more than the text can hold", excerpt(a.name),
                                      blocks));
    i = start;
    compact.clear();
    const Bytes header = decode(base64_chars((3 + blocks) * hs), "the compression header");
    uint64_t compressed = 0;
    for (uint64_t b = 0; b < blocks; ++b) {
      compressed += header_int(header.data() + (3 + b) * hs);
      if (compressed > text.size()) errors_.fail_at(at, fmt::format("array '{}': compressed sizes exceed the text", excerpt(a.name)));
    }
    Bytes blob(header.begin(), header.begin() + std::ptrdiff_t((3 + blocks) * hs));
    const Bytes data = decode(base64_chars(compressed), "the compressed blocks");
    blob.insert(blob.end(), data.begin(), data.end());
    return binary_blob(blob, at, a, expected);
  }

  const Source& source_;
  std::string_view text_;
  ByteCursor errors_;
  static constexpr std::size_t kMaxDepth = 64;
  double kept_ = 0;  // bytes held beside the file: the pieces and arrays scanned, the particles decoded
  FileInfo info_;
  std::vector<Piece> pieces_;
  std::string formats_;
};

}  // namespace

bool sniff_vtu(ByteView bytes) {
  const std::string_view head(reinterpret_cast<const char*>(bytes.data()), std::min<std::size_t>(bytes.size(), 1024));
  return head.find("<VTKFile") != std::string_view::npos;
}

ParticleSet read_vtu_particles(const Source& source, const ReadOptions& /*options*/, ReadReport* report) {
  return VtuReader(source).read(report);
}

TriangleMesh read_vtp_mesh(const Source& source) { return VtuReader(source).read_mesh(); }

}  // namespace meniscus::io
