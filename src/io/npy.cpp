// meniscus io — NumPy .npy reader (numpy.lib.format; NEP 1 "A Simple File Format for NumPy Arrays"), format versions 1.0, 2.0, 3.0.
#include "io/npy.hpp"

#include <algorithm>
#include <charconv>
#include <limits>
#include <optional>

#include <fmt/format.h>

#include "io/text_lines.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/messages.hpp"

namespace meniscus::io {

namespace {

// The header is a Python literal: a dict of strings, booleans, integers, tuples and lists. A tiny
// recursive parser covers what numpy writes (and hand-written variants) without a Python runtime.
struct PyValue {
  enum Kind { string, integer, boolean, sequence, dict, none } kind = none;
  std::string text;
  int64_t number = 0;
  std::vector<PyValue> items;                     // sequence
  // dict: keys[i] ↦ values[i] (two vectors: a vector of pairs would need PyValue complete here)
  std::vector<std::string> keys;
  std::vector<PyValue> values;

  const PyValue* get(std::string_view key) const;
};

const PyValue* PyValue::get(std::string_view key) const {
  for (std::size_t i = 0; i < keys.size(); ++i)
    if (keys[i] == key) return &values[i];
  return nullptr;
}

class LiteralParser {
 public:
  LiteralParser(std::string_view text, const ByteCursor& cursor, std::size_t base, const Source& source)
      : text_(text), cursor_(cursor), base_(base), source_(source) {}

  PyValue parse() {
    PyValue v = value(0);
    skip_space();
    if (pos_ != text_.size()) fail("expected the end of the header dictionary");
    return v;
  }

 private:
  [[noreturn]] void fail(std::string_view what) const {
    cursor_.fail_at(base_ + pos_, fmt::format("{} in the .npy header '{}'", what,
                                              text_.size() <= 120 ? text_ : text_.substr(0, 120)));
  }
  void skip_space() {
    while (pos_ < text_.size() && (text_[pos_] == ' ' || text_[pos_] == '\n' || text_[pos_] == '\t')) ++pos_;
  }
  bool eat(char c) {
    skip_space();
    if (pos_ < text_.size() && text_[pos_] == c) {
      ++pos_;
      return true;
    }
    return false;
  }

  PyValue value(int depth) {
    if (depth > 16) fail("expected a flat header, found nesting deeper than 16");
    skip_space();
    if (pos_ >= text_.size()) fail("expected a value, found the end");
    // Each value costs a PyValue: a header of many small ones ("[0,0,0,…]") holds far more than
    // its text, so what they hold is checked against the read's memory as they are made.
    held_ += double(sizeof(PyValue));
    if (++values_ % 4096 == 0)
      check_read_memory(source_, held_, fmt::format("the {} values of the .npy header", values_));
    const char c = text_[pos_];
    PyValue v;
    if (c == '\'' || c == '"') {
      v.kind = PyValue::string;
      const std::size_t end = text_.find(c, pos_ + 1);
      if (end == std::string_view::npos) fail("expected a closing quote");
      v.text = std::string(text_.substr(pos_ + 1, end - pos_ - 1));
      held_ += double(v.text.size());
      pos_ = end + 1;
    } else if (c == '(' || c == '[') {
      const char close = c == '(' ? ')' : ']';
      ++pos_;
      v.kind = PyValue::sequence;
      while (!eat(close)) {
        v.items.push_back(value(depth + 1));
        if (!eat(',')) {
          if (!eat(close)) fail(fmt::format("expected ',' or '{}'", close));
          break;
        }
      }
    } else if (c == '{') {
      ++pos_;
      v.kind = PyValue::dict;
      while (!eat('}')) {
        PyValue key = value(depth + 1);
        if (key.kind != PyValue::string) fail("expected a string key");
        if (!eat(':')) fail("expected ':'");
        v.keys.push_back(key.text);
        v.values.push_back(value(depth + 1));
        if (!eat(',')) {
          if (!eat('}')) fail("expected ',' or '}'");
          break;
        }
      }
    } else if (text_.substr(pos_).starts_with("True") || text_.substr(pos_).starts_with("False")) {
      v.kind = PyValue::boolean;
      v.number = text_[pos_] == 'T';
      pos_ += v.number ? 4 : 5;
    } else if (text_.substr(pos_).starts_with("None")) {
      pos_ += 4;
    } else {
      v.kind = PyValue::integer;
      std::size_t end = pos_;
      while (end < text_.size() && (std::isdigit(static_cast<unsigned char>(text_[end])) || text_[end] == '-')) ++end;
      if (end < text_.size() && text_[end] == 'L') ++end;  // Python 2 longs
      const auto [ptr, ec] = std::from_chars(text_.data() + pos_, text_.data() + end, v.number);
      if (ec != std::errc() || ptr == text_.data() + pos_) fail("expected a string, tuple, list, dict, boolean or integer");
      pos_ = end;
    }
    return v;
  }

  std::string_view text_;
  const ByteCursor& cursor_;
  std::size_t base_;
  const Source& source_;
  std::size_t pos_ = 0;
  std::size_t values_ = 0;
  double held_ = 0;  // the PyValues made so far, and the text of their strings
};

struct Scalar {
  char kind = 'f';  // 'f' float, 'i' signed, 'u' unsigned, 'b' bool, 'V' padding
  std::size_t size = 4;
  Endian endian = Endian::little;
};

struct Field {
  std::string name;
  Scalar scalar;
  std::size_t components = 1;  // product of the field's sub-array shape
  std::size_t offset = 0;      // within the record
};

double load(const Scalar& s, const uint8_t* p) {
  switch (s.kind) {
    case 'f': return s.size == 4 ? double(ByteCursor::load<float>(p, s.endian)) : ByteCursor::load<double>(p, s.endian);
    case 'i':
      switch (s.size) {
        case 1: return double(ByteCursor::load<int8_t>(p, s.endian));
        case 2: return double(ByteCursor::load<int16_t>(p, s.endian));
        case 4: return double(ByteCursor::load<int32_t>(p, s.endian));
        default: return double(ByteCursor::load<int64_t>(p, s.endian));
      }
    case 'u':
    case 'b':
      switch (s.size) {
        case 1: return double(ByteCursor::load<uint8_t>(p, s.endian));
        case 2: return double(ByteCursor::load<uint16_t>(p, s.endian));
        case 4: return double(ByteCursor::load<uint32_t>(p, s.endian));
        default: return double(ByteCursor::load<uint64_t>(p, s.endian));
      }
    default: return 0;
  }
}

}  // namespace

bool sniff_npy(ByteView bytes) {
  static constexpr uint8_t magic[] = {0x93, 'N', 'U', 'M', 'P', 'Y'};
  return bytes.size() >= 6 && std::equal(std::begin(magic), std::end(magic), bytes.begin());
}

ParticleSet read_npy_particles(const Source& source, const ReadOptions& /*options*/, ReadReport* report) {
  ByteCursor cursor(source.bytes, source.path, source.gzip);
  if (!sniff_npy(source.bytes)) cursor.fail("expected the .npy magic \\x93NUMPY");
  cursor.skip(6, "the magic");
  const uint8_t major = cursor.read<uint8_t>(Endian::little, "the format major version");
  const uint8_t minor = cursor.read<uint8_t>(Endian::little, "the format minor version");
  if (major < 1 || major > 3)
    cursor.fail_at(6, fmt::format("expected .npy format version 1.0, 2.0 or 3.0, found {}.{}", major, minor));
  const std::size_t header_len = major == 1 ? cursor.read<uint16_t>(Endian::little, "the header length")
                                            : cursor.read<uint32_t>(Endian::little, "the header length");
  const std::size_t header_at = cursor.offset();
  // The header is a line of text: bounded like the text formats' lines, and refused at its first
  // binary byte.
  if (header_len > kMaxLineBytes)
    cursor.fail_at(header_at - (major == 1 ? 2 : 4),
                   fmt::format("expected a header of at most {}, the header length says {} bytes",
                               human_bytes(double(kMaxLineBytes)), header_len));
  const ByteView header_bytes = cursor.take(header_len, "the header dictionary");
  check_text(source, header_at, header_at + header_len, false);
  const std::string_view header_text(reinterpret_cast<const char*>(header_bytes.data()), header_bytes.size());
  const PyValue header = LiteralParser(header_text, cursor, header_at, source).parse();
  auto bad_header = [&](const std::string& what) -> void { cursor.fail_at(header_at, what); };
  if (header.kind != PyValue::dict) bad_header("expected the header to be a dictionary");
  const PyValue* descr = header.get("descr");
  const PyValue* fortran = header.get("fortran_order");
  const PyValue* shape = header.get("shape");
  if (!descr || !fortran || !shape || fortran->kind != PyValue::boolean || shape->kind != PyValue::sequence)
    bad_header("expected the keys 'descr', 'fortran_order' (a boolean) and 'shape' (a tuple) in the header");

  auto scalar_of = [&](const std::string& d) {
    // '<f4', '>f8', '|u1', '=i4' …: byte order, kind, size.
    Scalar s;
    if (d.size() < 3 || (d[0] != '<' && d[0] != '>' && d[0] != '|' && d[0] != '='))
      bad_header(fmt::format("expected a dtype like '<f4', found '{}'", excerpt(d)));
    std::size_t size = 0;
    const auto [ptr, ec] = std::from_chars(d.data() + 2, d.data() + d.size(), size);
    s.kind = d[1];
    s.size = size;
    s.endian = d[0] == '>' ? Endian::big : Endian::little;  // '|' and '=' (native) are little on every target we build
    const bool ok = ec == std::errc() && ptr == d.data() + d.size() &&
                    ((s.kind == 'f' && (size == 4 || size == 8)) ||
                     ((s.kind == 'i' || s.kind == 'u') && (size == 1 || size == 2 || size == 4 || size == 8)) ||
                     (s.kind == 'b' && size == 1) || (s.kind == 'V' && size > 0 && size < (1u << 20)));
    if (!ok)
      bad_header(fmt::format("expected a numeric dtype (f4, f8, i1…i8, u1…u8, b1), found '{}'", excerpt(d)));
    return s;
  };

  uint64_t elements = 1;
  for (const PyValue& dim : shape->items) {
    if (dim.kind != PyValue::integer || dim.number < 0) bad_header("expected non-negative integers in 'shape'");
    if (dim.number != 0 && elements > std::numeric_limits<uint64_t>::max() / uint64_t(dim.number))
      bad_header("the shape's element count overflows");
    elements *= uint64_t(dim.number);
  }

  ParticleSet particles;
  const std::size_t data_at = cursor.offset();
  const bool column_major = fortran->number != 0;
  auto check_size = [&](uint64_t records, std::size_t record_size, const std::string& what) {
    cursor.require_records(records, record_size, what);
    if (uint64_t(cursor.remaining()) != records * record_size)
      cursor.fail(fmt::format("expected exactly {} bytes of data for {}, found {} (the shape does not match the "
                              "file)",
                              records * record_size, what, cursor.remaining()));
  };

  if (descr->kind == PyValue::string) {
    const Scalar s = scalar_of(descr->text);
    if (s.kind != 'f') bad_header(fmt::format("expected a float32 or float64 array, found dtype '{}'", excerpt(descr->text)));
    if (shape->items.size() != 2 || shape->items[1].number < 3)
      bad_header("expected a 2-D shape (N, k) with k ≥ 3 columns x, y, z, …");
    const uint64_t n = uint64_t(shape->items[0].number), k = uint64_t(shape->items[1].number);
    check_size(elements, s.size, fmt::format("a ({}, {}) array of {}-byte floats", n, k, s.size));
    check_read_memory(source, double(n) * double(k) * sizeof(float), fmt::format("{} particles of {} values", n, k));
    const uint8_t* base = source.bytes.data() + data_at;
    auto at = [&](uint64_t i, uint64_t c) {
      return load(s, base + (column_major ? c * n + i : i * k + c) * s.size);
    };
    particles.positions.resize(std::size_t(n));
    for (std::size_t i = 0; i < n; ++i)
      particles.positions[i] = {float(at(i, 0)), float(at(i, 1)), float(at(i, 2))};
    if (k > 3) {
      Attribute a{"values", int(k - 3), false, std::vector<float>(std::size_t(n * (k - 3)))};
      for (std::size_t i = 0; i < n; ++i)
        for (std::size_t c = 3; c < k; ++c) a.values[i * (k - 3) + c - 3] = float(at(i, c));
      particles.attributes.push_back(std::move(a));
    }
    if (report) report->format = fmt::format("npy {}.{} ({}, {} columns)", major, minor, descr->text, k);
    return particles;
  }

  if (descr->kind != PyValue::sequence) bad_header("expected 'descr' to be a dtype string or a list of fields");
  if (descr->items.size() > kMaxColumns)
    bad_header(fmt::format("expected at most {} structured fields, found {}", kMaxColumns, descr->items.size()));
  std::vector<Field> fields;
  std::size_t record = 0;
  for (const PyValue& f : descr->items) {
    if (f.kind != PyValue::sequence || f.items.size() < 2 || f.items[0].kind != PyValue::string)
      bad_header("expected each structured field as ('name', 'dtype'[, shape])");
    if (f.items[1].kind != PyValue::string)
      bad_header(fmt::format("expected a scalar dtype for field '{}' (nested structures are not supported)",
                             excerpt(f.items[0].text)));
    Field field{f.items[0].text, scalar_of(f.items[1].text), 1, record};
    if (f.items.size() > 2) {
      const PyValue& sub = f.items[2];
      if (sub.kind == PyValue::integer) field.components = std::size_t(std::max<int64_t>(sub.number, 0));
      else
        for (const PyValue& d : sub.items) {
          if (d.kind != PyValue::integer || d.number < 1 || d.number > 4096)
            bad_header(fmt::format("expected a sub-array shape of 1..4096 per axis for field '{}'", excerpt(field.name)));
          field.components *= std::size_t(d.number);
        }
      if (field.components < 1 || field.components > 4096)
        bad_header(fmt::format("expected 1..4096 values per record for field '{}'", excerpt(field.name)));
    }
    record += field.components * field.scalar.size;
    if (field.scalar.kind != 'V') fields.push_back(std::move(field));  // void fields are alignment padding
  }
  if (record == 0) bad_header("expected at least one field with a size");
  auto find = [&](std::string_view name, std::size_t components) -> const Field* {
    for (const Field& f : fields)
      if (f.name == name && f.components == components) return &f;
    return nullptr;
  };
  const Field *fx = find("x", 1), *fy = find("y", 1), *fz = find("z", 1);
  const Field* fp = nullptr;
  for (const char* name : {"P", "position", "pos", "positions"})
    if (!fp) fp = find(name, 3);
  if (!(fx && fy && fz) && !fp)
    bad_header("expected structured fields x, y, z (scalars) or a field 'P'/'position' of shape (3,)");
  check_size(elements, record, fmt::format("{} records of {} bytes", elements, record));
  std::size_t values = 0;
  for (const Field& f : fields) values += f.components;
  check_read_memory(source, double(elements) * double(values) * sizeof(float),
                    fmt::format("{} particles of {} values", elements, values));
  const uint8_t* base = source.bytes.data() + data_at;
  const std::size_t n = std::size_t(elements);
  particles.positions.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const uint8_t* r = base + i * record;
    if (fx && fy && fz)
      particles.positions[i] = {float(load(fx->scalar, r + fx->offset)), float(load(fy->scalar, r + fy->offset)),
                                float(load(fz->scalar, r + fz->offset))};
    else
      particles.positions[i] = {float(load(fp->scalar, r + fp->offset)),
                                float(load(fp->scalar, r + fp->offset + fp->scalar.size)),
                                float(load(fp->scalar, r + fp->offset + 2 * fp->scalar.size))};
  }
  const bool xyz = fx && fy && fz;
  const Field *vx = find("vx", 1), *vy = find("vy", 1), *vz = find("vz", 1);
  const bool velocity = vx && vy && vz;
  for (const Field& f : fields) {
    if (xyz ? (&f == fx || &f == fy || &f == fz) : &f == fp) continue;
    if (velocity && (&f == vy || &f == vz)) continue;
    std::vector<const Field*> parts{&f};
    std::string name = f.name;
    if (velocity && &f == vx) {
      parts = {vx, vy, vz};
      name = "velocity";
    }
    Attribute a;
    a.name = name;
    a.integer = std::all_of(parts.begin(), parts.end(), [](const Field* p) { return p->scalar.kind != 'f'; });
    std::size_t c = 0;
    for (const Field* p : parts) c += p->components;
    a.components = int(c);
    a.values.resize(n * c);
    for (std::size_t i = 0; i < n; ++i) {
      const uint8_t* r = base + i * record;
      std::size_t k = 0;
      for (const Field* p : parts)
        for (std::size_t j = 0; j < p->components; ++j)
          a.values[i * c + k++] = float(load(p->scalar, r + p->offset + j * p->scalar.size));
    }
    particles.attributes.push_back(std::move(a));
  }
  if (report) report->format = fmt::format("npy {}.{} (structured, {} fields)", major, minor, fields.size());
  return particles;
}

}  // namespace meniscus::io
