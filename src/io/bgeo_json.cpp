// meniscus io — Houdini binary-JSON geometry (SideFX UT_JSONDefines.h token ids, geo.html schema, hgeo.py paging).
#include "io/bgeo_json.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <unordered_map>

#include <fmt/format.h>

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
  explicit BinaryJson(const Source& source) : bytes_(source.bytes), c_(source.bytes, source.path, source.gzip) {
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
        std::string text = read_string_body();
        if (tokens_.size() > c_.size()) c_.fail_at(at, "expected fewer string tokens than bytes");
        tokens_[id] = std::move(text);
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

  std::string read_string(const char* what) {
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
  void read_numbers(std::vector<double>& out, const char* what) {
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
        out.reserve(out.size() + std::size_t(count));
        for (uint64_t i = 0; i < count; ++i) {
          const uint32_t word = ByteCursor::load<uint32_t>(p + 4 * (i / 32), endian_);
          out.push_back(double((word >> (i % 32)) & 1u));
        }
        return;
      }
      const std::size_t size = scalar_size(type);
      if (size == 0) fail_at(at, fmt::format("expected a numeric element type for {}, found 0x{:02X}", what, type));
      c_.require_records(count, size, what);
      const uint8_t* p = c_.take(std::size_t(count) * size, what).data();
      out.reserve(out.size() + std::size_t(count));
      for (uint64_t i = 0; i < count; ++i) out.push_back(load_scalar(type, p + i * size));
      return;
    }
    expect(jid_array_begin, what);
    while (!try_consume(jid_array_end)) out.push_back(read_number(what));
  }

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
      case jid_uniform_array: {
        std::vector<double> ignored;
        read_numbers(ignored, "a uniform array");
        return;
      }
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
  void for_each_entry(const char* what, const std::function<void(const std::string&)>& on_entry) {
    const uint8_t token = peek();
    if (token != jid_array_begin && token != jid_map_begin)
      fail(fmt::format("expected {} (an array of keys and values, or a map), found token 0x{:02X}", what, token));
    const uint8_t end = token == jid_array_begin ? jid_array_end : jid_map_end;
    c_.skip(1, "");
    while (!try_consume(end)) on_entry(read_string("a key"));
  }

 private:
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

  std::string read_string_body() {
    const uint64_t length = read_length("a string length");
    c_.require_records(length, 1, "a string");
    const ByteView text = c_.take(std::size_t(length), "a string");
    return std::string(reinterpret_cast<const char*>(text.data()), text.size());
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

  ByteView bytes_;
  ByteCursor c_;
  Endian endian_ = Endian::little;
  std::unordered_map<uint64_t, std::string> tokens_;
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
  json.for_each_entry("an attribute's values", [&](const std::string& key) {
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
          json.fail_at(at, fmt::format("expected every list of '{}' to hold {} values, found {}", key, first_length,
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
                                   a.name, count, tuple, found));
  };
  switch (p.layout) {
    case Payload::none:
      json.fail_at(p.at, fmt::format("expected 'tuples', 'arrays' or 'rawpagedata' values for point attribute '{}'",
                                     a.name));
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
                                     a.tuple_size, a.name, s));
    packing.push_back(std::size_t(s));
  }
  std::size_t packed = 0;
  for (const std::size_t s : packing) packed += s;
  if (packed != tuple)
    json.fail_at(p.at, fmt::format("expected the packing of point attribute '{}' to add up to its tuple size {}, found {}",
                                   a.name, tuple, packed));
  if (p.page_size < 1 || p.page_size > (int64_t(1) << 20))
    json.fail_at(p.at, fmt::format("expected a page size from 1 to 1048576 for point attribute '{}', found {}", a.name,
                                   p.page_size));
  if (!p.constant_pages.empty() && p.constant_pages.size() != packing.size())
    json.fail_at(p.at, fmt::format("expected constant page flags for each of the {} packed sub-vectors of point "
                                   "attribute '{}', found {} lists",
                                   packing.size(), a.name, p.constant_pages.size()));
  const std::size_t page_size = std::size_t(p.page_size);
  const std::size_t pages = count / page_size + (count % page_size != 0);
  auto constant = [&](std::size_t j, std::size_t page) {
    // An empty flag list means no page of that sub-vector is constant.
    return !p.constant_pages.empty() && !p.constant_pages[j].empty() && p.constant_pages[j][page] != 0.0;
  };
  for (std::size_t j = 0; j < p.constant_pages.size(); ++j)
    if (!p.constant_pages[j].empty() && p.constant_pages[j].size() != pages)
      json.fail_at(p.at, fmt::format("expected {} constant page flags for point attribute '{}', found {}", pages, a.name,
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
                                   expected, a.name, count, page_size, p.raw.size()));
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
  json.for_each_entry("a point attribute definition", [&](const std::string& key) {
    if (key == "name") a.name = json.read_string("the attribute name");
    else if (key == "type") a.type = json.read_string("the attribute type");
    else json.skip_value();
  });
  json.for_each_entry("a point attribute's data", [&](const std::string& key) {
    if (key == "size") a.tuple_size = json.read_integer("the tuple size");
    else if (key == "storage") a.storage = json.read_string("the storage type");
    else if (key == "values" && a.type == "numeric") read_payload(json, a);
    else json.skip_value();  // defaults, string tables and indices of string attributes
  });
  while (!json.try_consume(jid_array_end)) json.skip_value();  // later Houdini versions may add more
  if (a.type != "numeric") return;
  if (a.name.empty()) json.fail_at(a.at, "expected a name for the point attribute");
  if (a.tuple_size < 1 || a.tuple_size > 65535)
    json.fail_at(a.at, fmt::format("expected a tuple size from 1 to 65535 for point attribute '{}', found {}", a.name,
                                   a.tuple_size));
  out.push_back(std::move(a));
}

}  // namespace

bool sniff_bgeo_json(ByteView bytes) {
  if (bytes.size() < 5 || bytes[0] != 0x7F) return false;
  const ByteView tag = bytes.subspan(1, 4);
  return std::equal(tag.begin(), tag.end(), "NSJb") || std::equal(tag.begin(), tag.end(), "bJSN");
}

ParticleSet read_bgeo_json_particles(const Source& source, const ReadOptions& /*options*/, ReadReport* report) {
  BinaryJson json(source);
  std::optional<int64_t> point_count;
  std::size_t count_at = 0;
  std::vector<PointAttribute> attributes;
  json.for_each_entry("the geometry", [&](const std::string& key) {
    if (key == "pointcount") {
      count_at = json.offset();
      point_count = json.read_integer("the point count");
    } else if (key == "attributes") {
      json.for_each_entry("the attributes", [&](const std::string& kind) {
        if (kind != "pointattributes") return json.skip_value();
        json.expect(jid_array_begin, "the point attributes");
        while (!json.try_consume(jid_array_end)) read_attribute(json, attributes);
      });
    } else {
      json.skip_value();
    }
  });
  if (!point_count) json.fail_at(5, "expected a 'pointcount' entry in the geometry");
  // Constant pages let a few bytes stand for many points; bound the expansion like gzip's
  // ~1000:1 so a hostile count cannot make us allocate without limit.
  const uint64_t ceiling = uint64_t(source.bytes.size()) * 1024;
  if (*point_count < 0 || uint64_t(*point_count) > ceiling)
    json.fail_at(count_at, fmt::format("expected a point count from 0 to {} (1024 × the data size), found {}", ceiling,
                                       *point_count));
  const std::size_t count = std::size_t(*point_count);

  ParticleSet particles;
  bool have_position = false;
  for (const PointAttribute& a : attributes) {
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
  if (report) report->format = "bgeo (binary JSON)";
  return particles;
}

}  // namespace meniscus::io
