// meniscus io — delimited text particle reader (RFC 4180 CSV without embedded separators; whitespace columns as in SPHysics IPART).
#include "io/csv.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <optional>

#include <fmt/format.h>
#include <fmt/ranges.h>

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

void split_fields(std::string_view line, Separator sep, std::vector<std::string_view>& out) {
  out.clear();
  if (sep == Separator::whitespace) {
    std::size_t i = 0;
    while (i < line.size()) {
      while (i < line.size() && is_blank(line[i])) ++i;
      const std::size_t start = i;
      while (i < line.size() && !is_blank(line[i])) ++i;
      if (i > start) out.push_back(trim(line.substr(start, i - start)));
    }
    return;
  }
  const char c = sep == Separator::comma ? ',' : ';';
  std::size_t start = 0;
  for (;;) {
    const std::size_t end = line.find(c, start);
    out.push_back(trim(line.substr(start, end == std::string_view::npos ? std::string_view::npos : end - start)));
    if (end == std::string_view::npos) break;
    start = end + 1;
  }
  // A trailing separator (some exporters end every row with one) adds no column.
  if (out.size() > 1 && out.back().empty()) out.pop_back();
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

std::vector<Group> group_columns(const std::vector<std::string>& names, std::vector<bool>& taken) {
  std::vector<Group> groups;
  auto find = [&](const std::string& n) -> std::optional<std::size_t> {
    for (std::size_t i = 0; i < names.size(); ++i)
      if (!taken[i] && lower(names[i]) == n) return i;
    return std::nullopt;
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
    const std::string n = lower(names[i]);
    // <name>_x/_y/_z and ParaView's <name>:0 … <name>:k
    if (n.size() > 2 && n.ends_with("_x")) {
      const std::string base = names[i].substr(0, n.size() - 2);
      try_group(base, {lower(base) + "_x", lower(base) + "_y", lower(base) + "_z"});
    } else if (n.size() > 2 && n.ends_with(":0")) {
      const std::string base = names[i].substr(0, n.size() - 2);
      std::vector<std::size_t> cols;
      for (std::size_t k = 0;; ++k) {
        const std::optional<std::size_t> c = find(fmt::format("{}:{}", lower(base), k));
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

}  // namespace

ParticleSet read_csv_particles(const Source& source, const ReadOptions& options, ReadReport* report) {
  const std::string_view text(reinterpret_cast<const char*>(source.bytes.data()), source.bytes.size());
  const std::string& file = source.path;
  std::size_t pos = 0, line_no = 0;
  auto next_line = [&](std::string_view& line) {
    if (pos >= text.size()) return false;
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
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
  split_fields(header, sep, fields);
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
    for (const std::string_view f : fields) names.emplace_back(f);
  }

  // Positions: x y z (any case) or ParaView's Points:0..2.
  auto column_of = [&](std::string_view a, std::string_view b) -> std::size_t {
    for (std::size_t i = 0; i < names.size(); ++i)
      if (lower(names[i]) == a || lower(names[i]) == b) return i;
    return names.size();
  };
  const std::size_t ix = column_of("x", "points:0"), iy = column_of("y", "points:1"), iz = column_of("z", "points:2");
  if (ix == names.size() || iy == names.size() || iz == names.size())
    throw FormatError(file, options.columns.empty() ? fmt::format("line {}", first_line) : "",
                      fmt::format("expected columns named x, y and z, found {} ({})",
                                  options.columns.empty() ? "the header" : spelled("columns"),
                                  fmt::join(names, ", ")));
  for (std::size_t i = 0; i < names.size(); ++i)
    for (std::size_t j = i + 1; j < names.size(); ++j)
      if (names[i] == names[j])
        throw FormatError(file, options.columns.empty() ? fmt::format("line {}", first_line) : "",
                          fmt::format("expected distinct column names, '{}' appears twice", names[i]));

  const std::size_t ncol = names.size();
  // At most a row per line left: the columns are sized once, and the memory they and the
  // particles take is checked before they are.
  const std::size_t rows = (first_is_data ? 1 : 0) + std::size_t(std::count(text.begin() + std::ptrdiff_t(std::min(pos, text.size())), text.end(), '\n')) + 1;
  check_particle_memory(source, rows, ncol);
  std::vector<std::vector<float>> columns(ncol);
  for (std::vector<float>& column : columns) column.reserve(rows);
  std::vector<bool> integral(ncol, true);
  auto read_row = [&](std::string_view line) {
    split_fields(line, sep, fields);
    if (fields.size() != ncol)
      throw FormatError(file, fmt::format("line {}", line_no),
                        fmt::format("expected {} fields ({}), found {}", ncol, fmt::join(names, sep == Separator::comma ? "," : " "),
                                    fields.size()));
    for (std::size_t c = 0; c < ncol; ++c) {
      bool whole = false;
      const std::optional<double> v = parse_number(fields[c], &whole);
      if (!v)
        throw FormatError(file, fmt::format("line {}, column {}", line_no, c + 1),
                          fmt::format("expected a number for column '{}', found '{}'", names[c],
                                      fields[c].size() <= 40 ? std::string(fields[c])
                                                             : std::string(fields[c].substr(0, 40)) + "…"));
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
  for (const Group& g : group_columns(names, taken)) {
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
