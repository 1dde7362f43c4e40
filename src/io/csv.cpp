// meniscus io — delimited text particle reader (RFC 4180 CSV without embedded separators; whitespace columns as in SPHysics IPART).
#include "io/csv.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <optional>
#include <unordered_map>

#include <fmt/format.h>

#include "io/text_lines.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/messages.hpp"

namespace meniscus::io {

namespace {

enum class Separator { comma, semicolon, whitespace };

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_blank(s.back())) s.remove_suffix(1);
  if (s.size() >= 2 && s.front() == '"' && s.back() == '"') s = s.substr(1, s.size() - 2);
  return s;
}

// Splits a line into its fields, keeping at most `limit` of them in `out`; returns how many the
// line holds (a row with far too many fields is refused without a view of each).
std::size_t split_fields(std::string_view line, Separator sep, std::vector<std::string_view>& out, std::size_t limit) {
  out.clear();
  std::size_t count = 0;
  const auto add = [&](std::string_view field) {
    if (count++ < limit) out.push_back(trim(field));
  };
  if (sep == Separator::whitespace) {
    std::size_t i = 0;
    while (i < line.size()) {
      while (i < line.size() && is_blank(line[i])) ++i;
      const std::size_t start = i;
      while (i < line.size() && !is_blank(line[i])) ++i;
      if (i > start) add(line.substr(start, i - start));
    }
    return count;
  }
  const char c = sep == Separator::comma ? ',' : ';';
  std::size_t start = 0;
  for (;;) {
    const std::size_t end = line.find(c, start);
    if (end == std::string_view::npos) {
      // A trailing separator (some exporters end every row with one) adds no column.
      const std::string_view last = line.substr(start);
      if (count == 0 || !trim(last).empty()) add(last);
      return count;
    }
    add(line.substr(start, end - start));
    start = end + 1;
  }
}

std::optional<double> parse_number(std::string_view token, bool* integral) {
  const char* begin = token.data();
  const char* end = begin + token.size();
  if (begin != end && *begin == '+') ++begin;
  double value = 0;
  const auto [ptr, ec] = std::from_chars(begin, end, value);
  if (ec != std::errc() || ptr != end || begin == end) return std::nullopt;
  *integral = std::all_of(begin, end, [](char ch) { return std::isdigit(static_cast<unsigned char>(ch)) || ch == '-'; });
  return value;
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& ch : out) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  return out;
}

// Groups of columns that form one attribute, like the PLY reader's grouping.
struct Group {
  std::string name;
  std::vector<std::size_t> columns;
};

// `names` and their lower-case forms `lowered`; columns in `taken` are left out.
std::vector<Group> group_columns(const std::vector<std::string>& names, const std::vector<std::string>& lowered,
                                 std::vector<bool>& taken) {
  // The columns of each lower-case name, in column order. A lookup wants the first one not taken;
  // columns only ever become taken, so `next` moves past them once and every lookup costs
  // constant time on average, even in a header of many case variants of one name.
  struct SameName {
    std::vector<std::size_t> columns;
    std::size_t next = 0;
  };
  std::unordered_map<std::string_view, SameName> by_name;
  by_name.reserve(names.size());
  for (std::size_t i = 0; i < names.size(); ++i) by_name[lowered[i]].columns.push_back(i);
  std::vector<Group> groups;
  auto find = [&](std::string_view n) -> std::optional<std::size_t> {
    const auto it = by_name.find(n);
    if (it == by_name.end()) return std::nullopt;
    SameName& same = it->second;
    while (same.next < same.columns.size() && taken[same.columns[same.next]]) ++same.next;
    if (same.next == same.columns.size()) return std::nullopt;
    return same.columns[same.next];
  };
  auto try_group = [&](const std::string& name, std::initializer_list<std::string> members) {
    std::vector<std::size_t> cols;
    for (const std::string& m : members) {
      const std::optional<std::size_t> i = find(m);
      if (!i) return;
      cols.push_back(*i);
    }
    for (const std::size_t i : cols) taken[i] = true;
    groups.push_back(Group{name, std::move(cols)});
  };
  try_group("velocity", {"vx", "vy", "vz"});
  try_group("velocity", {"u", "v", "w"});
  try_group("normal", {"nx", "ny", "nz"});
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (taken[i]) continue;
    const std::string& n = lowered[i];
    // <name>_x/_y/_z and ParaView's <name>:0 … <name>:k
    if (n.size() > 2 && n.ends_with("_x")) {
      const std::string base = names[i].substr(0, n.size() - 2);
      const std::string lower_base = n.substr(0, n.size() - 2);
      try_group(base, {lower_base + "_x", lower_base + "_y", lower_base + "_z"});
    } else if (n.size() > 2 && n.ends_with(":0")) {
      const std::string base = names[i].substr(0, n.size() - 2);
      const std::string lower_base = n.substr(0, n.size() - 2);
      std::vector<std::size_t> cols;
      for (std::size_t k = 0;; ++k) {
        const std::optional<std::size_t> c = find(fmt::format("{}:{}", lower_base, k));
        if (!c) break;
        cols.push_back(*c);
      }
      if (cols.size() >= 2) {
        for (const std::size_t c : cols) taken[c] = true;
        groups.push_back(Group{base, std::move(cols)});
      }
    }
  }
  for (std::size_t i = 0; i < names.size(); ++i)
    if (!taken[i]) {
      taken[i] = true;
      groups.push_back(Group{names[i], {i}});
    }
  std::sort(groups.begin(), groups.end(), [](const Group& a, const Group& b) {
    return *std::min_element(a.columns.begin(), a.columns.end()) < *std::min_element(b.columns.begin(), b.columns.end());
  });
  return groups;
}

// Column names for a message: all of a short list, else the first few and how many there are.
std::string name_list(const std::vector<std::string>& names, std::string_view separator) {
  constexpr std::size_t kShown = 8;
  std::string out;
  for (std::size_t i = 0; i < names.size() && i < kShown; ++i)
    out += (i ? std::string(separator) : std::string()) + excerpt(names[i], 24);
  if (names.size() > kShown) out += fmt::format("{}… ({} columns)", separator, names.size());
  return out;
}

}  // namespace

ParticleSet read_csv_particles(const Source& source, const ReadOptions& options, ReadReport* report) {
  const std::string_view text(reinterpret_cast<const char*>(source.bytes.data()), source.bytes.size());
  const std::string& file = source.path;
  std::size_t pos = 0, line_no = 0;
  // Lines are bounded (kMaxLineBytes) and refused at their first binary byte: a file that is not
  // text stops here, before a field or a name is made of it.
  auto next_line = [&](std::string_view& line) {
    if (pos >= text.size()) return false;
    const std::size_t end = line_end(source, pos);
    line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    if (line_no == 1 && line.starts_with("\xEF\xBB\xBF")) line.remove_prefix(3);  // UTF-8 byte order mark
    return true;
  };

  // The first non-blank line decides the separator and whether there is a header.
  std::string_view first;
  std::size_t first_line = 0;
  for (;;) {
    if (!next_line(first)) throw FormatError(file, "", "the file holds no text lines (expected a header or data rows)");
    if (!trim(first).empty()) break;
  }
  first_line = line_no;
  const Separator sep = first.find(',') != std::string_view::npos   ? Separator::comma
                        : first.find(';') != std::string_view::npos ? Separator::semicolon
                                                                    : Separator::whitespace;
  std::string_view header = first;
  const bool hashed = trim(first).starts_with('#');
  if (hashed) header = trim(first).substr(1);
  std::vector<std::string_view> fields;
  const std::size_t header_fields = split_fields(header, sep, fields, kMaxColumns);
  bool numeric = true;
  for (const std::string_view f : fields) {
    bool integral = false;
    numeric = numeric && parse_number(f, &integral).has_value();
  }

  std::vector<std::string> names;
  bool first_is_data = false;
  if (!options.columns.empty()) {
    names = options.columns;
    first_is_data = numeric && !hashed;
  } else {
    if (numeric && !hashed)
      throw FormatError(file, fmt::format("line {}", first_line),
                        fmt::format("expected a header line naming the columns (e.g. 'x,y,z,vx,vy,vz'), found numbers; "
                                    "give {} to name the columns of a headerless file",
                                    spelled_setting("columns", "x,y,z,...")));
    if (header_fields > kMaxColumns)
      throw FormatError(file, fmt::format("line {}", first_line),
                        fmt::format("expected a header of at most {} columns, found {}", kMaxColumns, header_fields));
    // What the names, their lower-case forms, their lookup and the empty columns take, before
    // any is made (a long header of short names costs more than its text).
    double held = 0;
    for (const std::string_view f : fields) held += 2.0 * double(f.size()) + 256.0;
    check_read_memory(source, held, fmt::format("the {} column names of the header", fields.size()));
    names.reserve(fields.size());
    for (const std::string_view f : fields) names.emplace_back(f);
  }
  std::vector<std::string> lowered;
  lowered.reserve(names.size());
  for (const std::string& name : names) lowered.push_back(lower(name));

  // Positions: x y z (any case) or ParaView's Points:0..2.
  auto column_of = [&](std::string_view a, std::string_view b) -> std::size_t {
    for (std::size_t i = 0; i < names.size(); ++i)
      if (lowered[i] == a || lowered[i] == b) return i;
    return names.size();
  };
  const std::size_t ix = column_of("x", "points:0"), iy = column_of("y", "points:1"), iz = column_of("z", "points:2");
  if (ix == names.size() || iy == names.size() || iz == names.size())
    throw FormatError(file, options.columns.empty() ? fmt::format("line {}", first_line) : "",
                      fmt::format("expected columns named x, y and z, found {} ({})",
                                  options.columns.empty() ? "the header" : spelled("columns"), name_list(names, ", ")));
  // The first name that comes again (the smallest index with a later twin), as a pairwise
  // comparison would find it, in one pass.
  std::unordered_map<std::string_view, std::size_t> first_index;
  first_index.reserve(names.size());
  std::size_t twice = names.size();
  for (std::size_t j = 0; j < names.size(); ++j)
    if (const auto [it, fresh] = first_index.try_emplace(names[j], j); !fresh) twice = std::min(twice, it->second);
  if (twice < names.size())
    throw FormatError(file, options.columns.empty() ? fmt::format("line {}", first_line) : "",
                      fmt::format("expected distinct column names, '{}' appears twice", excerpt(names[twice])));

  const std::size_t ncol = names.size();
  // At most a row per line left: the columns are sized once, and the memory they and the
  // particles take is checked before they are.
  const std::size_t rows = (first_is_data ? 1 : 0) + std::size_t(std::count(text.begin() + std::ptrdiff_t(std::min(pos, text.size())), text.end(), '\n')) + 1;
  check_particle_memory(source, rows, ncol);
  std::vector<std::vector<float>> columns(ncol);
  for (std::vector<float>& column : columns) column.reserve(rows);
  std::vector<bool> integral(ncol, true);
  auto read_row = [&](std::string_view line) {
    const std::size_t found = split_fields(line, sep, fields, ncol + 1);
    if (found != ncol)
      throw FormatError(file, fmt::format("line {}", line_no),
                        fmt::format("expected {} fields ({}), found {}", ncol,
                                    name_list(names, sep == Separator::comma ? "," : " "), found));
    for (std::size_t c = 0; c < ncol; ++c) {
      bool whole = false;
      const std::optional<double> v = parse_number(fields[c], &whole);
      if (!v)
        throw FormatError(file, fmt::format("line {}, column {}", line_no, c + 1),
                          fmt::format("expected a number for column '{}', found '{}'", excerpt(names[c]),
                                      excerpt(fields[c])));
      columns[c].push_back(static_cast<float>(*v));
      integral[c] = integral[c] && whole;
    }
  };
  if (first_is_data) read_row(first);
  for (std::string_view line; next_line(line);) {
    const std::string_view t = trim(line);
    if (t.empty() || t.starts_with('#')) continue;
    read_row(line);
  }

  ParticleSet particles;
  const std::size_t n = columns[ix].size();
  particles.positions.resize(n);
  for (std::size_t i = 0; i < n; ++i) particles.positions[i] = {columns[ix][i], columns[iy][i], columns[iz][i]};
  std::vector<bool> taken(ncol, false);
  taken[ix] = taken[iy] = taken[iz] = true;
  for (const Group& g : group_columns(names, lowered, taken)) {
    Attribute a;
    a.name = g.name;
    a.components = int(g.columns.size());
    a.integer = std::all_of(g.columns.begin(), g.columns.end(), [&](std::size_t c) { return bool(integral[c]); });
    a.values.resize(n * g.columns.size());
    for (std::size_t k = 0; k < g.columns.size(); ++k)
      for (std::size_t i = 0; i < n; ++i) a.values[i * g.columns.size() + k] = columns[g.columns[k]][i];
    particles.attributes.push_back(std::move(a));
  }
  if (report)
    report->format = fmt::format("text ({}-separated, {})",
                                 sep == Separator::comma ? "comma" : sep == Separator::semicolon ? "semicolon" : "whitespace",
                                 options.columns.empty() ? "header" : "columns given");
  return particles;
}

}  // namespace meniscus::io
