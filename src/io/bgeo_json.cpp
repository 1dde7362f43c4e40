// meniscus io — Houdini binary-JSON geometry (SideFX UT_JSONDefines.h token ids, geo.html schema, hgeo.py paging):
// reader of points and polygon meshes, writer of triangle meshes (the stream inside a .bgeo.sc).
#include "io/bgeo_json.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <set>
#include <string_view>
#include <type_traits>
#include <unordered_map>

#include <fmt/format.h>

#include "io/text_lines.hpp"
#include "meniscus/errors.hpp"

namespace meniscus::io {

namespace {

// Token bytes (UT_JID_*).
enum : uint8_t {
  jid_null = 0x00,
  jid_bool = 0x10,
  jid_int8 = 0x11,
  jid_int16 = 0x12,
  jid_int32 = 0x13,
  jid_int64 = 0x14,
  jid_real16 = 0x18,
  jid_real32 = 0x19,
  jid_real64 = 0x1A,
  jid_uint8 = 0x21,
  jid_uint16 = 0x22,
  jid_token_ref = 0x26,
  jid_string = 0x27,
  jid_token_def = 0x2B,
  jid_token_undef = 0x2D,
  jid_false = 0x30,
  jid_true = 0x31,
  jid_uniform_array = 0x40,
  jid_array_begin = 0x5B,
  jid_array_end = 0x5D,
  jid_map_begin = 0x7B,
  jid_map_end = 0x7D,
};

// Nesting deeper than this is hostile (Houdini's geometry nests about 8 levels): refuse it
// rather than recurse until the stack runs out.
constexpr int max_depth = 64;

std::size_t scalar_size(uint8_t token) {
  switch (token) {
    case jid_int8:
    case jid_uint8: return 1;
    case jid_int16:
    case jid_uint16:
    case jid_real16: return 2;
    case jid_int32:
    case jid_real32: return 4;
    case jid_int64:
    case jid_real64: return 8;
    default: return 0;
  }
}

float half_to_float(uint16_t h) {
  const int exponent = (h >> 10) & 0x1F;
  const int mantissa = h & 0x3FF;
  const float sign = (h & 0x8000) ? -1.0f : 1.0f;
  if (exponent == 0) return sign * std::ldexp(float(mantissa), -24);
  if (exponent == 31) return mantissa ? std::numeric_limits<float>::quiet_NaN() : sign * std::numeric_limits<float>::infinity();
  return sign * std::ldexp(float(mantissa + 1024), exponent - 25);
}

// A pull tokenizer over the binary JSON stream: token definitions are absorbed as they come,
// values are read by type or skipped whole.
class BinaryJson {
 public:
  explicit BinaryJson(const Source& source)
      : source_(source), bytes_(source.bytes), c_(source.bytes, source.path, source.gzip) {
    const ByteView magic = c_.take(5, "the binary JSON magic");
    if (magic[0] != 0x7F) c_.fail_at(0, "expected the binary JSON magic byte 0x7F");
    if (std::equal(magic.begin() + 1, magic.end(), "NSJb")) endian_ = Endian::little;
    else if (std::equal(magic.begin() + 1, magic.end(), "bJSN")) endian_ = Endian::big;
    else c_.fail_at(1, "expected 'NSJb' (little-endian) or 'bJSN' (big-endian) after the 0x7F magic byte");
  }

  ByteCursor& cursor() { return c_; }

  // The next value token, after any token definitions (which are not values).
  uint8_t peek() {
    for (;;) {
      c_.require(1, "a binary JSON token");
      const uint8_t token = bytes_[c_.offset()];
      if (token == jid_token_def) {
        c_.skip(1, "");
        const std::size_t at = c_.offset();
        const uint64_t id = read_length("a token id");
        const std::string_view text = read_string_body();
        if (tokens_.size() > c_.size()) c_.fail_at(at, "expected fewer string tokens than bytes");
        // A token of a few bytes costs a map entry: what they hold is checked as they come.
        if (tokens_.insert_or_assign(id, text).second && tokens_.size() % 4096 == 0)
          check_read_memory(source_, double(tokens_.size()) * kTokenBytes,
                            fmt::format("{} string tokens", tokens_.size()));
        continue;
      }
      if (token == jid_token_undef) {
        c_.skip(1, "");
        tokens_.erase(read_length("a token id"));
        continue;
      }
      return token;
    }
  }

  std::size_t offset() const { return c_.offset(); }
  [[noreturn]] void fail(std::string_view message) const { c_.fail(message); }
  [[noreturn]] void fail_at(std::size_t at, std::string_view message) const { c_.fail_at(at, message); }

  void expect(uint8_t token, const char* what) {
    if (peek() != token) fail(fmt::format("expected {}, found token 0x{:02X}", what, peek()));
    c_.skip(1, "");
  }
  bool try_consume(uint8_t token) {
    if (peek() != token) return false;
    c_.skip(1, "");
    return true;
  }

  // A string of the file: a view of its bytes (those of a token's definition for a reference),
  // valid as long as the file's bytes, so a string referred to many times is never copied.
  std::string_view read_string(const char* what) {
    const uint8_t token = peek();
    const std::size_t at = offset();
    if (token == jid_string) {
      c_.skip(1, "");
      return read_string_body();
    }
    if (token == jid_token_ref) {
      c_.skip(1, "");
      const uint64_t id = read_length("a token id");
      const auto it = tokens_.find(id);
      if (it == tokens_.end()) fail_at(at, fmt::format("expected {}, found a reference to undefined token {}", what, id));
      return it->second;
    }
    fail(fmt::format("expected {} (a string), found token 0x{:02X}", what, token));
  }

  bool is_number(uint8_t token) const { return scalar_size(token) != 0; }

  double read_number(const char* what) {
    const uint8_t token = peek();
    if (token == jid_false || token == jid_true) {
      c_.skip(1, "");
      return token == jid_true ? 1.0 : 0.0;
    }
    if (token == jid_bool) {
      c_.skip(1, "");
      return c_.read<uint8_t>(endian_, "a bool") ? 1.0 : 0.0;
    }
    if (!is_number(token)) fail(fmt::format("expected {} (a number), found token 0x{:02X}", what, token));
    c_.skip(1, "");
    c_.require(scalar_size(token), what);
    const double v = load_scalar(token, c_.take(scalar_size(token), what).data());
    return v;
  }

  int64_t read_integer(const char* what) {
    const std::size_t at = offset();
    const double v = read_number(what);
    if (!(v >= -9.0e15 && v <= 9.0e15) || v != std::floor(v))
      fail_at(at, fmt::format("expected {} (an integer), found {}", what, v));
    return static_cast<int64_t>(v);
  }

  // A list of numbers: a uniform array (any numeric or bool element type) or an array of numbers.
  void read_numbers(std::vector<double>& out, const char* what) { numbers(&out, what); }

  void skip_value(int depth = 0) {
    if (depth > max_depth) fail(fmt::format("expected values nested at most {} levels deep", max_depth));
    const uint8_t token = peek();
    switch (token) {
      case jid_null:
      case jid_false:
      case jid_true: c_.skip(1, ""); return;
      case jid_bool: c_.skip(2, "a bool"); return;
      case jid_string:
      case jid_token_ref: read_string("a string"); return;
      case jid_uniform_array: numbers(nullptr, "a uniform array"); return;
      case jid_array_begin:
        c_.skip(1, "");
        while (!try_consume(jid_array_end)) skip_value(depth + 1);
        return;
      case jid_map_begin:
        c_.skip(1, "");
        while (!try_consume(jid_map_end)) {
          read_string("a map key");
          skip_value(depth + 1);
        }
        return;
      default:
        if (is_number(token)) {
          read_number("a number");
          return;
        }
        fail(fmt::format("expected a binary JSON value, found unknown token 0x{:02X}", token));
    }
  }

  // Houdini writes most objects as arrays of alternating keys and values, some as maps: both are
  // walked here; `on_entry` must consume the value of each key.
  void for_each_entry(const char* what, const std::function<void(std::string_view)>& on_entry) {
    const uint8_t token = peek();
    if (token != jid_array_begin && token != jid_map_begin)
      fail(fmt::format("expected {} (an array of keys and values, or a map), found token 0x{:02X}", what, token));
    const uint8_t end = token == jid_array_begin ? jid_array_end : jid_map_end;
    c_.skip(1, "");
    while (!try_consume(end)) on_entry(read_string("a key"));
  }

 private:
  // Reads a list of numbers into *out, or skips it (out null) without decoding it.
  void numbers(std::vector<double>* out, const char* what) {
    const uint8_t token = peek();
    if (token == jid_uniform_array) {
      c_.skip(1, "");
      const std::size_t at = offset();
      const uint8_t type = c_.read<uint8_t>(endian_, "a uniform array element type");
      const uint64_t count = read_length("a uniform array length");
      if (type == jid_bool) {
        // Bools are packed LSB-first into 32-bit words.
        const uint64_t word_count = count / 32 + (count % 32 != 0);
        c_.require_records(word_count, 4, what);
        const uint8_t* p = c_.take(std::size_t(word_count) * 4, what).data();
        if (!out) return;
        hold(double(count), what);
        out->reserve(out->size() + std::size_t(count));
        for (uint64_t i = 0; i < count; ++i) {
          const uint32_t word = ByteCursor::load<uint32_t>(p + 4 * (i / 32), endian_);
          out->push_back(double((word >> (i % 32)) & 1u));
        }
        return;
      }
      const std::size_t size = scalar_size(type);
      if (size == 0) fail_at(at, fmt::format("expected a numeric element type for {}, found 0x{:02X}", what, type));
      c_.require_records(count, size, what);
      const uint8_t* p = c_.take(std::size_t(count) * size, what).data();
      if (!out) return;
      hold(double(count), what);
      out->reserve(out->size() + std::size_t(count));
      for (uint64_t i = 0; i < count; ++i) out->push_back(load_scalar(type, p + i * size));
      return;
    }
    expect(jid_array_begin, what);
    while (!try_consume(jid_array_end)) {
      const double v = read_number(what);
      if (!out) continue;
      hold(1, what);
      out->push_back(v);
    }
  }

  // Counts `values` more decoded doubles against the read's memory: a byte of the file may stand
  // for a double (an int8 array) or eight (a packed bool array).
  void hold(double values, const char* what) {
    decoded_ += values;
    const double bytes = decoded_ * sizeof(double);
    if (source_.limit.bytes && double(source_.bytes.size()) + bytes > double(source_.limit.bytes))
      check_read_memory(source_, bytes, fmt::format("{:.0f} numbers decoded up to {}", decoded_, what));
  }

  // Lengths and ids: a byte below 0xF1 is the value; F2, F4, F8 announce a uint16, uint32, int64.
  uint64_t read_length(const char* what) {
    const std::size_t at = offset();
    const uint8_t first = c_.read<uint8_t>(endian_, what);
    if (first < 0xF1) return first;
    if (first == 0xF2) return c_.read<uint16_t>(endian_, what);
    if (first == 0xF4) return c_.read<uint32_t>(endian_, what);
    if (first == 0xF8) {
      const int64_t v = c_.read<int64_t>(endian_, what);
      if (v < 0) fail_at(at, fmt::format("expected a non-negative {}, found {}", what, v));
      return uint64_t(v);
    }
    fail_at(at, fmt::format("expected {} (a byte below 0xF1, or 0xF2/0xF4/0xF8 and a wider value), found 0x{:02X}",
                            what, first));
  }

  std::string_view read_string_body() {
    const uint64_t length = read_length("a string length");
    c_.require_records(length, 1, "a string");
    const ByteView text = c_.take(std::size_t(length), "a string");
    return std::string_view(reinterpret_cast<const char*>(text.data()), text.size());
  }

  double load_scalar(uint8_t type, const uint8_t* p) const {
    switch (type) {
      case jid_int8: return ByteCursor::load<int8_t>(p, endian_);
      case jid_uint8: return ByteCursor::load<uint8_t>(p, endian_);
      case jid_int16: return ByteCursor::load<int16_t>(p, endian_);
      case jid_uint16: return ByteCursor::load<uint16_t>(p, endian_);
      case jid_int32: return ByteCursor::load<int32_t>(p, endian_);
      case jid_int64: return double(ByteCursor::load<int64_t>(p, endian_));
      case jid_real16: return half_to_float(ByteCursor::load<uint16_t>(p, endian_));
      case jid_real32: return ByteCursor::load<float>(p, endian_);
      case jid_real64: return ByteCursor::load<double>(p, endian_);
      default: return 0.0;
    }
  }

  static constexpr double kTokenBytes = 64;  // a token's map entry, its text being the file's

  const Source& source_;
  ByteView bytes_;
  ByteCursor c_;
  Endian endian_ = Endian::little;
  std::unordered_map<uint64_t, std::string_view> tokens_;  // views of the definitions' bytes
  double decoded_ = 0;  // values read_numbers has decoded
};

// The numeric payload of one attribute, in whichever layout the file used.
struct Payload {
  std::size_t at = 0;  // where the values array started, for messages
  std::vector<double> raw;
  enum Layout { none, tuples, arrays, paged } layout = none;
  std::vector<int64_t> packing;
  int64_t page_size = 1024;
  std::vector<std::vector<double>> constant_pages;  // per packed sub-vector, per page 0/1
  std::size_t lists = 0, list_length = 0;  // the shape of `tuples`/`arrays`
};

struct PointAttribute {
  std::string name;
  std::string type;
  std::string storage;
  int64_t tuple_size = 1;
  Payload payload;
  std::size_t at = 0;
};

void read_payload(BinaryJson& json, PointAttribute& attribute) {
  Payload& p = attribute.payload;
  p.at = json.offset();
  json.for_each_entry("an attribute's values", [&](std::string_view key) {
    if (key == "size") {
      attribute.tuple_size = json.read_integer("the tuple size");
    } else if (key == "storage") {
      attribute.storage = json.read_string("the storage type");
    } else if (key == "packing") {
      std::vector<double> packing;
      json.read_numbers(packing, "the packing");
      p.packing.assign(packing.begin(), packing.end());
    } else if (key == "pagesize") {
      p.page_size = json.read_integer("the page size");
    } else if (key == "constantpageflags") {
      json.expect(jid_array_begin, "the constant page flags (one list per packed sub-vector)");
      while (!json.try_consume(jid_array_end)) {
        p.constant_pages.emplace_back();
        json.read_numbers(p.constant_pages.back(), "the constant page flags");
      }
    } else if (key == "rawpagedata") {
      p.layout = Payload::paged;
      json.read_numbers(p.raw, "the raw page data");
    } else if (key == "tuples" || key == "arrays") {
      p.layout = key == "tuples" ? Payload::tuples : Payload::arrays;
      // Both are lists of lists: `tuples` one list per element, `arrays` one list per component.
      json.expect(jid_array_begin, key == "tuples" ? "the tuples" : "the arrays");
      std::size_t lists = 0;
      std::size_t first_length = 0;
      while (!json.try_consume(jid_array_end)) {
        const std::size_t at = json.offset();
        const std::size_t before = p.raw.size();
        json.read_numbers(p.raw, "the attribute values");
        const std::size_t length = p.raw.size() - before;
        if (lists == 0) first_length = length;
        else if (length != first_length)
          json.fail_at(at, fmt::format("expected every list of '{}' to hold {} values, found {}", excerpt(key), first_length,
                                       length));
        ++lists;
      }
      // The shape, for the size check: tuples are points × tuple, arrays tuple × points.
      p.lists = lists;
      p.list_length = first_length;
    } else {
      json.skip_value();
    }
  });
}

// Unpacks a payload into element-major floats, checking its size against `count` elements.
std::vector<float> unpack(const BinaryJson& json, const PointAttribute& a, std::size_t count) {
  const Payload& p = a.payload;
  const std::size_t tuple = std::size_t(a.tuple_size);
  std::vector<float> out;
  auto mismatch = [&](std::size_t expected, std::size_t found) {
    json.fail_at(p.at, fmt::format("expected {} values for point attribute '{}' ({} points × {}), found {}", expected,
                                   excerpt(a.name), count, tuple, found));
  };
  switch (p.layout) {
    case Payload::none:
      json.fail_at(p.at, fmt::format("expected 'tuples', 'arrays' or 'rawpagedata' values for point attribute '{}'",
                                     excerpt(a.name)));
    case Payload::tuples: {
      if (p.raw.size() != count * tuple || (count > 0 && p.lists != count)) mismatch(count * tuple, p.raw.size());
      out.resize(count * tuple);
      for (std::size_t i = 0; i < out.size(); ++i) out[i] = float(p.raw[i]);  // already element-major
      return out;
    }
    case Payload::arrays: {
      if (p.raw.size() != count * tuple || (count > 0 && p.lists != tuple)) mismatch(count * tuple, p.raw.size());
      out.resize(count * tuple);
      for (std::size_t k = 0; k < tuple; ++k)
        for (std::size_t i = 0; i < count; ++i) out[i * tuple + k] = float(p.raw[k * count + i]);
      return out;
    }
    case Payload::paged: break;
  }

  // rawpagedata: page-major; inside a page one run per packed sub-vector, each run page-length ×
  // sub-vector size values (element-major), or one tuple of the sub-vector when its page is constant.
  std::vector<std::size_t> packing;
  if (p.packing.empty()) packing.push_back(tuple);
  for (const int64_t s : p.packing) {
    if (s < 1 || s > a.tuple_size)
      json.fail_at(p.at, fmt::format("expected packing sizes from 1 to {} for point attribute '{}', found {}",
                                     a.tuple_size, excerpt(a.name), s));
    packing.push_back(std::size_t(s));
  }
  std::size_t packed = 0;
  for (const std::size_t s : packing) packed += s;
  if (packed != tuple)
    json.fail_at(p.at, fmt::format("expected the packing of point attribute '{}' to add up to its tuple size {}, found {}",
                                   excerpt(a.name), tuple, packed));
  if (p.page_size < 1 || p.page_size > (int64_t(1) << 20))
    json.fail_at(p.at, fmt::format("expected a page size from 1 to 1048576 for point attribute '{}', found {}", excerpt(a.name),
                                   p.page_size));
  if (!p.constant_pages.empty() && p.constant_pages.size() != packing.size())
    json.fail_at(p.at, fmt::format("expected constant page flags for each of the {} packed sub-vectors of point "
                                   "attribute '{}', found {} lists",
                                   packing.size(), excerpt(a.name), p.constant_pages.size()));
  const std::size_t page_size = std::size_t(p.page_size);
  const std::size_t pages = count / page_size + (count % page_size != 0);
  auto constant = [&](std::size_t j, std::size_t page) {
    // An empty flag list means no page of that sub-vector is constant.
    return !p.constant_pages.empty() && !p.constant_pages[j].empty() && p.constant_pages[j][page] != 0.0;
  };
  for (std::size_t j = 0; j < p.constant_pages.size(); ++j)
    if (!p.constant_pages[j].empty() && p.constant_pages[j].size() != pages)
      json.fail_at(p.at, fmt::format("expected {} constant page flags for point attribute '{}', found {}", pages, excerpt(a.name),
                                     p.constant_pages[j].size()));
  // Size check before writing anything: the exact number of raw values this layout needs.
  std::size_t expected = 0;
  for (std::size_t page = 0; page < pages; ++page) {
    const std::size_t length = std::min(page_size, count - page * page_size);
    for (std::size_t j = 0; j < packing.size(); ++j) expected += constant(j, page) ? packing[j] : length * packing[j];
  }
  if (p.raw.size() != expected)
    json.fail_at(p.at, fmt::format("expected {} raw page values for point attribute '{}' ({} points, page size {}), "
                                   "found {}",
                                   expected, excerpt(a.name), count, page_size, p.raw.size()));
  out.resize(count * tuple);
  std::size_t r = 0;
  for (std::size_t page = 0; page < pages; ++page) {
    const std::size_t first = page * page_size;
    const std::size_t length = std::min(page_size, count - first);
    std::size_t offset = 0;  // first component of this sub-vector within the tuple
    for (std::size_t j = 0; j < packing.size(); ++j) {
      const std::size_t s = packing[j];
      const bool is_constant = constant(j, page);
      for (std::size_t i = 0; i < length; ++i)
        for (std::size_t k = 0; k < s; ++k)
          out[(first + i) * tuple + offset + k] = float(p.raw[r + (is_constant ? k : i * s + k)]);
      r += is_constant ? s : length * s;
      offset += s;
    }
  }
  return out;
}

void read_attribute(BinaryJson& json, std::vector<PointAttribute>& out) {
  PointAttribute a;
  a.at = json.offset();
  json.expect(jid_array_begin, "a point attribute ([definition, values])");
  json.for_each_entry("a point attribute definition", [&](std::string_view key) {
    if (key == "name") a.name = json.read_string("the attribute name");
    else if (key == "type") a.type = json.read_string("the attribute type");
    else json.skip_value();
  });
  json.for_each_entry("a point attribute's data", [&](std::string_view key) {
    if (key == "size") a.tuple_size = json.read_integer("the tuple size");
    else if (key == "storage") a.storage = json.read_string("the storage type");
    else if (key == "values" && a.type == "numeric") read_payload(json, a);
    else json.skip_value();  // defaults, string tables and indices of string attributes
  });
  while (!json.try_consume(jid_array_end)) json.skip_value();  // later Houdini versions may add more
  if (a.type != "numeric") return;
  if (a.name.empty()) json.fail_at(a.at, "expected a name for the point attribute");
  if (a.tuple_size < 1 || a.tuple_size > 65535)
    json.fail_at(a.at, fmt::format("expected a tuple size from 1 to 65535 for point attribute '{}', found {}", excerpt(a.name),
                                   a.tuple_size));
  out.push_back(std::move(a));
}

// Closed polygons in primitive order: a run of consecutive vertices from `start` whose sizes are
// listed ("n_v") or run-length encoded as (size, repeat) pairs ("r_v"), or one polygon listed by
// its vertex numbers ("Poly", or one primitive of a Houdini 12 "run").
struct Polygons {
  std::size_t at = 0;  // where the primitive entry starts, for messages
  bool run = false;
  int64_t start = 0, primitives = 0;
  std::vector<double> sizes, rle;
  std::vector<double> vertices;
};

// What the reader collects; topology and primitives only when a mesh is asked for.
struct Geometry {
  std::optional<int64_t> point_count, vertex_count;
  std::size_t point_count_at = 0, vertex_count_at = 0;
  std::vector<PointAttribute> attributes;
  std::optional<std::vector<double>> pointref;  // the point of each vertex
  std::size_t pointref_at = 0;
  std::vector<Polygons> polygons;
};

void read_topology(BinaryJson& json, Geometry& g) {
  json.for_each_entry("the topology", [&](std::string_view key) {
    if (key != "pointref") return json.skip_value();
    json.for_each_entry("the point references", [&](std::string_view inner) {
      if (inner != "indices") return json.skip_value();
      g.pointref_at = json.offset();
      g.pointref.emplace();
      json.read_numbers(*g.pointref, "the point of each vertex");
    });
  });
}

void read_polygon_run(BinaryJson& json, Polygons& run) {
  run.run = true;
  json.for_each_entry("a polygon run", [&](std::string_view key) {
    if (key == "s_v" || key == "startvertex") run.start = json.read_integer("the run's first vertex");
    else if (key == "n_p" || key == "nprimitives") run.primitives = json.read_integer("the run's primitive count");
    else if (key == "r_v" || key == "nvertices_rle") json.read_numbers(run.rle, "the run-length encoded vertex counts");
    else if (key == "n_v" || key == "nvertices") json.read_numbers(run.sizes, "the vertex counts of the run");
    else json.skip_value();
  });
}

// The definition ([type, …]) and data of every primitive; closed polygons are kept.
void read_primitives(BinaryJson& json, Geometry& g) {
  json.expect(jid_array_begin, "the primitives (a list of [definition, data] pairs)");
  while (!json.try_consume(jid_array_end)) {
    Polygons p;
    p.at = json.offset();
    json.expect(jid_array_begin, "a primitive ([definition, data])");
    std::string type, run_type;
    std::vector<std::string> varying;
    bool uniform_closed = true;
    json.for_each_entry("a primitive definition", [&](std::string_view key) {
      if (key == "type") {
        type = json.read_string("the primitive type");
      } else if (key == "runtype") {
        run_type = json.read_string("the primitive type of a run");
      } else if (key == "varyingfields") {
        json.expect(jid_array_begin, "the varying fields of a run");
        while (!json.try_consume(jid_array_end)) varying.emplace_back(json.read_string("a varying field"));
      } else if (key == "uniformfields") {
        json.for_each_entry("the uniform fields of a run", [&](std::string_view field) {
          if (field == "closed") uniform_closed = json.read_number("the closed flag") != 0.0;
          else json.skip_value();
        });
      } else {
        json.skip_value();
      }
    });
    if (type == "p_r" || type == "Polygon_run") {
      read_polygon_run(json, p);
      g.polygons.push_back(std::move(p));
    } else if (type == "Poly" || type == "Polygon") {
      bool closed = true;
      json.for_each_entry("a polygon", [&](std::string_view key) {
        if (key == "vertex") json.read_numbers(p.vertices, "the polygon's vertices");
        else if (key == "closed") closed = json.read_number("the closed flag") != 0.0;
        else json.skip_value();
      });
      if (closed) g.polygons.push_back(std::move(p));
    } else if (type == "run" && run_type == "Poly") {
      // Houdini 12: one array per polygon holding a value for each varying field.
      json.expect(jid_array_begin, "the polygons of a run");
      while (!json.try_consume(jid_array_end)) {
        Polygons poly;
        poly.at = json.offset();
        bool closed = uniform_closed;
        json.expect(jid_array_begin, "a polygon of a run (one value per varying field)");
        for (const std::string& field : varying) {
          if (field == "vertex") json.read_numbers(poly.vertices, "the polygon's vertices");
          else if (field == "closed") closed = json.read_number("the closed flag") != 0.0;
          else json.skip_value();
        }
        while (!json.try_consume(jid_array_end)) json.skip_value();
        if (closed) g.polygons.push_back(std::move(poly));
      }
    } else {
      json.skip_value();  // open curves ("c_r"), particles, volumes, packed primitives …
    }
    while (!json.try_consume(jid_array_end)) json.skip_value();
  }
}

Geometry read_geometry(BinaryJson& json, bool want_mesh) {
  Geometry g;
  json.for_each_entry("the geometry", [&](std::string_view key) {
    if (key == "pointcount") {
      g.point_count_at = json.offset();
      g.point_count = json.read_integer("the point count");
    } else if (key == "vertexcount" && want_mesh) {
      g.vertex_count_at = json.offset();
      g.vertex_count = json.read_integer("the vertex count");
    } else if (key == "attributes") {
      json.for_each_entry("the attributes", [&](std::string_view kind) {
        if (kind != "pointattributes") return json.skip_value();
        json.expect(jid_array_begin, "the point attributes");
        while (!json.try_consume(jid_array_end)) read_attribute(json, g.attributes);
      });
    } else if (key == "topology" && want_mesh) {
      read_topology(json, g);
    } else if (key == "primitives" && want_mesh) {
      read_primitives(json, g);
    } else {
      json.skip_value();
    }
  });
  return g;
}

std::size_t checked_point_count(const BinaryJson& json, const Geometry& g, std::size_t data_size) {
  if (!g.point_count) json.fail_at(5, "expected a 'pointcount' entry in the geometry");
  // Constant pages let a few bytes stand for many points; bound the expansion like gzip's
  // ~1000:1 so a hostile count cannot make us allocate without limit.
  const uint64_t ceiling = uint64_t(data_size) * 1024;
  if (*g.point_count < 0 || uint64_t(*g.point_count) > ceiling)
    json.fail_at(g.point_count_at, fmt::format("expected a point count from 0 to {} (1024 × the data size), found {}",
                                               ceiling, *g.point_count));
  return std::size_t(*g.point_count);
}

// P → positions, every other numeric point attribute → an Attribute under its file name.
ParticleSet points_of(const Source& source, const BinaryJson& json, const Geometry& g, std::size_t count) {
  std::size_t per_point = 0;
  for (const PointAttribute& a : g.attributes) per_point += std::size_t(std::max<int64_t>(a.tuple_size, 0));
  check_particle_memory(source, count, per_point);
  ParticleSet particles;
  bool have_position = false;
  for (const PointAttribute& a : g.attributes) {
    std::vector<float> values = unpack(json, a, count);
    if (a.name == "P") {
      if (a.tuple_size < 3)
        json.fail_at(a.at, fmt::format("expected P with at least 3 components, found {}", a.tuple_size));
      const std::size_t t = std::size_t(a.tuple_size);
      particles.positions.resize(count);
      for (std::size_t i = 0; i < count; ++i)
        particles.positions[i] = {values[i * t], values[i * t + 1], values[i * t + 2]};
      have_position = true;
      continue;
    }
    Attribute out;
    out.name = a.name;
    out.components = int(a.tuple_size);
    out.integer = a.storage.starts_with("int") || a.storage.starts_with("uint");
    out.values = std::move(values);
    particles.attributes.push_back(std::move(out));
  }
  if (!have_position && count > 0) json.fail_at(5, "expected a numeric point attribute 'P' (the positions)");
  return particles;
}

// The closed polygons as triangles, every vertex number and point reference checked.
std::vector<Triangle> triangles_of(const BinaryJson& json, const Geometry& g, std::size_t point_count) {
  std::vector<Triangle> out;
  if (g.polygons.empty()) return out;
  if (!g.pointref)
    json.fail_at(g.polygons.front().at, "expected a 'topology' entry (pointref indices) for the polygons");
  const std::vector<double>& ref = *g.pointref;
  if (g.vertex_count && uint64_t(*g.vertex_count) != ref.size())
    json.fail_at(g.vertex_count_at, fmt::format("expected the vertex count to match the {} topology indices, found {}",
                                                ref.size(), *g.vertex_count));
  std::vector<uint32_t> point(ref.size());
  for (std::size_t v = 0; v < ref.size(); ++v) {
    if (!(ref[v] >= 0 && ref[v] < double(point_count)) || ref[v] != std::floor(ref[v]))
      json.fail_at(g.pointref_at, fmt::format("expected the point of vertex {} to be a point number below {}, found {}",
                                              v, point_count, ref[v]));
    point[v] = uint32_t(ref[v]);
  }
  const uint64_t vertices = ref.size();
  // A fan per polygon, wound back from Houdini's clockwise into our counter-clockwise.
  auto fan = [&](std::size_t size, const auto& vertex) {
    const uint32_t p0 = point[vertex(0)];
    for (std::size_t k = 1; k + 1 < size; ++k) out.push_back({p0, point[vertex(k + 1)], point[vertex(k)]});
  };
  for (const Polygons& p : g.polygons) {
    if (!p.run) {
      if (p.vertices.size() < 3)
        json.fail_at(p.at, fmt::format("expected a closed polygon with at least 3 vertices, found {}", p.vertices.size()));
      for (const double v : p.vertices)
        if (!(v >= 0 && v < double(vertices)) || v != std::floor(v))
          json.fail_at(p.at, fmt::format("expected polygon vertices below the vertex count {}, found {}", vertices, v));
      fan(p.vertices.size(), [&](std::size_t k) { return std::size_t(p.vertices[k]); });
      continue;
    }
    if (p.start < 0 || uint64_t(p.start) > vertices)
      json.fail_at(p.at, fmt::format("expected a polygon run starting at a vertex from 0 to {}, found {}", vertices,
                                     p.start));
    if (p.primitives < 0)
      json.fail_at(p.at, fmt::format("expected a non-negative primitive count for a polygon run, found {}", p.primitives));
    if (p.rle.size() % 2 != 0)
      json.fail_at(p.at, fmt::format("expected (vertex count, repeat) pairs in 'r_v', found {} values", p.rle.size()));
    uint64_t next = uint64_t(p.start);
    uint64_t left = uint64_t(p.primitives);
    // `repeat` polygons of `size` vertices each, checked against the vertices and primitives left.
    auto polygons = [&](double size, double repeat) {
      if (!(size >= 3 && size <= double(vertices)) || size != std::floor(size))
        json.fail_at(p.at, fmt::format("expected polygon vertex counts from 3 to {} in a polygon run, found {}", vertices,
                                       size));
      if (!(repeat >= 0 && repeat <= double(left)) || repeat != std::floor(repeat))
        json.fail_at(p.at, fmt::format("expected at most the {} primitives left in the run, found a repeat of {}", left,
                                       repeat));
      const uint64_t n = uint64_t(size), r = uint64_t(repeat);
      if (r > (vertices - next) / n)
        json.fail_at(p.at, fmt::format("expected the polygon run to fit the {} vertices, it needs {} from vertex {}",
                                       vertices, n * r, next));
      for (uint64_t i = 0; i < r; ++i, next += n) fan(std::size_t(n), [&](std::size_t k) { return std::size_t(next + k); });
      left -= r;
    };
    for (std::size_t i = 0; i + 1 < p.rle.size(); i += 2) polygons(p.rle[i], p.rle[i + 1]);
    for (const double size : p.sizes) polygons(size, 1);
    if (left != 0)
      json.fail_at(p.at, fmt::format("expected vertex counts for all {} primitives of the polygon run, {} have none",
                                     p.primitives, left));
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Writer
//
// The stream, as Houdini 18.5 writes a polygon mesh (compare the decompressed
// tests/data/houdini_pop_splatter_13883_points.bgeo.sc): little-endian, every string a token
// defined at its first use and referenced after, integers in the smallest signed type.
//   [ "fileversion", "18.5.506", "hasindex", false, "pointcount", n, "vertexcount", 3t,
//     "primitivecount", t, "info", {"software": "meniscus <version>", "bounds": real32[6]},
//     "topology", ["pointref", ["indices", int32[3t]]],
//     "attributes", ["pointattributes", [P, N, the mesh attributes …]],
//     "primitives", [[["type", "p_r"], ["s_v", 0, "n_p", t, "r_v", int16|int32[3, t]]]] ]
// where "p_r", "s_v", "n_p", "r_v" are what Houdini's binary writer calls a Polygon_run and its
// startvertex, nprimitives, nvertices_rle (the ASCII .geo spells them out), and an attribute is
//   [["scope", "public", "type", "numeric", "name", N, "options", {"type": {"type": "string",
//     "value": "point"|"normal"|"color"|"vector"}} or {}],
//    ["size", k, "storage", "fpreal32"|"int32", "defaults", ["size", 1, "storage", "fpreal64",
//     "values", real64[1]], "values", ["size", k, "storage", …, "pagesize", 1024,
//     "rawpagedata", real32|int32[k n]]]]
// rawpagedata without "packing" or "constantpageflags" is one sub-vector of the whole tuple on
// every page, i.e. the element-major array itself (hgeo.py: packing defaults to [size]).

constexpr const char* houdini_file_version = "18.5.506";
constexpr int64_t page_size = 1024;
constexpr std::size_t flush_at = std::size_t(1) << 20;

class BinaryJsonWriter {
 public:
  explicit BinaryJsonWriter(const std::function<void(ByteView)>& sink) : sink_(sink) {
    out_.reserve(flush_at + 4096);
    for (const char c : std::string_view("\x7FNSJb")) out_.push_back(uint8_t(c));
  }

  void begin_array() { out_.push_back(jid_array_begin); }
  void end_array() { out_.push_back(jid_array_end); }
  void begin_map() { out_.push_back(jid_map_begin); }
  void end_map() { out_.push_back(jid_map_end); }
  void boolean(bool value) { out_.push_back(value ? jid_true : jid_false); }

  void string(std::string_view text) {
    auto it = tokens_.find(std::string(text));
    if (it == tokens_.end()) {
      it = tokens_.emplace(std::string(text), uint64_t(tokens_.size())).first;
      out_.push_back(jid_token_def);
      length(it->second);
      length(text.size());
      out_.insert(out_.end(), text.begin(), text.end());
    }
    out_.push_back(jid_token_ref);
    length(it->second);
  }

  void integer(int64_t v) {
    if (v >= std::numeric_limits<int8_t>::min() && v <= std::numeric_limits<int8_t>::max()) {
      out_.push_back(jid_int8);
      put(int8_t(v));
    } else if (v >= std::numeric_limits<int16_t>::min() && v <= std::numeric_limits<int16_t>::max()) {
      out_.push_back(jid_int16);
      put(int16_t(v));
    } else if (v >= std::numeric_limits<int32_t>::min() && v <= std::numeric_limits<int32_t>::max()) {
      out_.push_back(jid_int32);
      put(int32_t(v));
    } else {
      out_.push_back(jid_int64);
      put(v);
    }
  }

  // A uniform array of `count` values of `T` (element type `type`), value(i) for the i-th,
  // handed to the sink as it grows.
  template <class T, class Value>
  void uniform_array(uint8_t type, std::size_t count, const Value& value) {
    out_.push_back(jid_uniform_array);
    out_.push_back(type);
    length(count);
    for (std::size_t i = 0; i < count; ++i) {
      put(T(value(i)));
      if ((i & 0xFFFF) == 0xFFFF) flush(false);
    }
  }

  // Hands the bytes so far to the sink once there is about a chunk of them (or when `force`).
  void flush(bool force) {
    if (out_.empty() || (!force && out_.size() < flush_at)) return;
    sink_(out_);
    out_.clear();
  }

 private:
  // Lengths and token ids: one byte below 0xF1, else 0xF2/0xF4/0xF8 and a uint16/uint32/int64.
  void length(uint64_t n) {
    if (n < 0xF1) {
      out_.push_back(uint8_t(n));
    } else if (n <= 0xFFFF) {
      out_.push_back(0xF2);
      put(uint16_t(n));
    } else if (n <= 0xFFFFFFFFu) {
      out_.push_back(0xF4);
      put(uint32_t(n));
    } else {
      out_.push_back(0xF8);
      put(int64_t(n));
    }
  }

  template <class T>
  void put(T value) {
    using U = std::conditional_t<sizeof(T) == 1, uint8_t,
              std::conditional_t<sizeof(T) == 2, uint16_t,
              std::conditional_t<sizeof(T) == 4, uint32_t, uint64_t>>>;
    const U u = std::bit_cast<U>(value);
    for (std::size_t i = 0; i < sizeof(T); ++i) out_.push_back(uint8_t(u >> (8 * i)));
  }

  const std::function<void(ByteView)>& sink_;
  Bytes out_;
  std::unordered_map<std::string, uint64_t> tokens_;
};

struct OutputAttribute {
  std::string name;
  const char* type_info;  // Houdini's typeinfo option, or nullptr
  int components;
  double default_value;
  const float* values;  // element-major, `components` per point
  bool integer;
};

// P, N and the mesh attributes under the names Houdini knows (as write_bgeo_mesh names them).
std::vector<OutputAttribute> output_attributes(const std::string& path, const TriangleMesh& mesh) {
  std::vector<OutputAttribute> out;
  std::set<std::string> names;
  auto add = [&](OutputAttribute a, const std::string& from) {
    if (a.name.empty())
      throw InvalidParameter(fmt::format("cannot write '{}': an attribute has an empty name", path));
    if (!names.insert(a.name).second)
      throw InvalidParameter(fmt::format("cannot write '{}': attribute '{}' would be written as '{}', which is already "
                                         "used",
                                         path, from, a.name));
    out.push_back(std::move(a));
  };
  const float* positions = mesh.vertices.empty() ? nullptr : &mesh.vertices[0].x;
  add({"P", "point", 3, 0.0, positions, false}, "positions");
  if (!mesh.normals.empty()) add({"N", "normal", 3, 0.0, &mesh.normals[0].x, false}, "normals");
  for (const Attribute& a : mesh.attributes) {
    // Cd and v (renamed from meniscus's names, or carried over from a Houdini cache under
    // Houdini's) get their type info, so Houdini shows Cd as colour and transforms v.
    const bool vector3 = a.components == 3 && !a.integer;
    const std::string name = !vector3 ? a.name : a.name == "color" ? "Cd" : a.name == "velocity" ? "v" : a.name;
    if (vector3 && name == "Cd") add({name, "color", 3, 1.0, a.values.data(), false}, a.name);
    else if (vector3 && name == "v") add({name, "vector", 3, 0.0, a.values.data(), false}, a.name);
    else add({name, nullptr, a.components, 0.0, a.values.data(), a.integer}, a.name);
  }
  // Integer attributes must survive the int32 conversion; refuse before anything is written.
  const std::size_t nv = mesh.vertices.size();
  for (const OutputAttribute& a : out) {
    if (!a.integer) continue;
    for (std::size_t i = 0; i < nv * std::size_t(a.components); ++i)
      if (!(a.values[i] >= -2147483648.0f && a.values[i] < 2147483648.0f))
        throw InvalidParameter(fmt::format("cannot write '{}': integer attribute '{}' has value {} at vertex {}, "
                                           "outside the int32 range",
                                           path, a.name, a.values[i], i / std::size_t(a.components)));
  }
  return out;
}

void write_attribute(BinaryJsonWriter& w, const OutputAttribute& a, std::size_t count) {
  const char* storage = a.integer ? "int32" : "fpreal32";
  w.begin_array();
  w.begin_array();
  w.string("scope");
  w.string("public");
  w.string("type");
  w.string("numeric");
  w.string("name");
  w.string(a.name);
  w.string("options");
  w.begin_map();
  if (a.type_info) {
    w.string("type");
    w.begin_map();
    w.string("type");
    w.string("string");
    w.string("value");
    w.string(a.type_info);
    w.end_map();
  }
  w.end_map();
  w.end_array();

  w.begin_array();
  w.string("size");
  w.integer(a.components);
  w.string("storage");
  w.string(storage);
  w.string("defaults");
  w.begin_array();
  w.string("size");
  w.integer(1);
  w.string("storage");
  w.string("fpreal64");
  w.string("values");
  w.uniform_array<double>(jid_real64, 1, [&](std::size_t) { return a.default_value; });
  w.end_array();
  w.string("values");
  w.begin_array();
  w.string("size");
  w.integer(a.components);
  w.string("storage");
  w.string(storage);
  w.string("pagesize");
  w.integer(page_size);
  w.string("rawpagedata");
  const std::size_t n = count * std::size_t(a.components);
  if (a.integer)
    w.uniform_array<int32_t>(jid_int32, n, [&](std::size_t i) { return int32_t(std::lround(a.values[i])); });
  else
    w.uniform_array<float>(jid_real32, n, [&](std::size_t i) { return a.values[i]; });
  w.end_array();
  w.end_array();
  w.end_array();
}

}  // namespace

bool sniff_bgeo_json(ByteView bytes) {
  if (bytes.size() < 5 || bytes[0] != 0x7F) return false;
  const ByteView tag = bytes.subspan(1, 4);
  return std::equal(tag.begin(), tag.end(), "NSJb") || std::equal(tag.begin(), tag.end(), "bJSN");
}

ParticleSet read_bgeo_json_particles(const Source& source, const ReadOptions& /*options*/, ReadReport* report) {
  BinaryJson json(source);
  const Geometry g = read_geometry(json, false);
  ParticleSet particles = points_of(source, json, g, checked_point_count(json, g, source.bytes.size()));
  if (report) report->format = "bgeo (binary JSON)";
  return particles;
}

TriangleMesh read_bgeo_json_mesh(const Source& source) {
  BinaryJson json(source);
  const Geometry g = read_geometry(json, true);
  const std::size_t count = checked_point_count(json, g, source.bytes.size());
  ParticleSet points = points_of(source, json, g, count);
  TriangleMesh mesh;
  mesh.triangles = triangles_of(json, g, count);
  mesh.vertices = std::move(points.positions);
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Vec3f p = mesh.vertices[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw FormatError(source.path, fmt::format("point {}", i),
                        fmt::format("expected finite coordinates, found ({}, {}, {})", p.x, p.y, p.z));
  }
  for (Attribute& a : points.attributes) {
    const bool vector3 = a.components == 3 && !a.integer;
    if (a.name == "N" && vector3) {
      mesh.normals.resize(mesh.vertices.size());
      for (std::size_t i = 0; i < mesh.normals.size(); ++i)
        mesh.normals[i] = {a.values[3 * i], a.values[3 * i + 1], a.values[3 * i + 2]};
      continue;
    }
    if (a.name == "Cd" && vector3) a.name = "color";
    else if (a.name == "v" && vector3) a.name = "velocity";
    mesh.attributes.push_back(std::move(a));
  }
  return mesh;
}

void encode_bgeo_json_mesh(const std::string& path, const TriangleMesh& mesh,
                           const std::function<void(ByteView)>& sink) {
  const std::size_t nv = mesh.vertices.size(), nt = mesh.triangles.size();
  // Point numbers are written as int32 (as Houdini writes pointref indices).
  if (nv > std::size_t(std::numeric_limits<int32_t>::max()))
    throw InvalidParameter(fmt::format("cannot write '{}': {} vertices do not fit bgeo's int32 point numbers", path, nv));
  check_mesh_for_writing(path, mesh, "bgeo.sc");
  static_assert(sizeof(Vec3f) == 3 * sizeof(float), "positions and normals are read as packed float triples");
  const std::vector<OutputAttribute> attributes = output_attributes(path, mesh);

  BinaryJsonWriter w(sink);
  w.begin_array();
  w.string("fileversion");
  w.string(houdini_file_version);
  w.string("hasindex");
  w.boolean(false);
  w.string("pointcount");
  w.integer(int64_t(nv));
  w.string("vertexcount");
  w.integer(int64_t(3 * nt));
  w.string("primitivecount");
  w.integer(int64_t(nt));

  w.string("info");
  w.begin_map();
  w.string("software");
  w.string(std::string("meniscus ") + MENISCUS_VERSION);
  if (nv > 0) {
    Vec3f lo = mesh.vertices[0], hi = mesh.vertices[0];
    for (const Vec3f& p : mesh.vertices) {
      lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
      hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
    }
    const float bounds[6] = {lo.x, hi.x, lo.y, hi.y, lo.z, hi.z};  // Houdini's order: x range, y, z
    w.string("bounds");
    w.uniform_array<float>(jid_real32, 6, [&](std::size_t i) { return bounds[i]; });
  }
  w.end_map();

  // Each triangle's corners in Houdini's clockwise order (as write_bgeo_mesh: 0, 2, 1).
  w.string("topology");
  w.begin_array();
  w.string("pointref");
  w.begin_array();
  w.string("indices");
  w.uniform_array<int32_t>(jid_int32, 3 * nt, [&](std::size_t i) {
    constexpr std::size_t clockwise[3] = {0, 2, 1};
    return int32_t(mesh.triangles[i / 3][clockwise[i % 3]]);
  });
  w.end_array();
  w.end_array();

  w.string("attributes");
  w.begin_array();
  w.string("pointattributes");
  w.begin_array();
  for (const OutputAttribute& a : attributes) write_attribute(w, a, nv);
  w.end_array();
  w.end_array();

  w.string("primitives");
  w.begin_array();
  if (nt > 0) {
    w.begin_array();
    w.begin_array();
    w.string("type");
    w.string("p_r");
    w.end_array();
    w.begin_array();
    w.string("s_v");
    w.integer(0);
    w.string("n_p");
    w.integer(int64_t(nt));
    w.string("r_v");
    // The smallest integer type that holds the run, as Houdini picks it.
    const std::size_t rle[2] = {3, nt};
    if (nt <= std::size_t(std::numeric_limits<int16_t>::max()))
      w.uniform_array<int16_t>(jid_int16, 2, [&](std::size_t i) { return int16_t(rle[i]); });
    else if (nt <= std::size_t(std::numeric_limits<int32_t>::max()))
      w.uniform_array<int32_t>(jid_int32, 2, [&](std::size_t i) { return int32_t(rle[i]); });
    else
      w.uniform_array<int64_t>(jid_int64, 2, [&](std::size_t i) { return int64_t(rle[i]); });
    w.end_array();
    w.end_array();
  }
  w.end_array();
  w.end_array();
  w.flush(true);
}

}  // namespace meniscus::io
