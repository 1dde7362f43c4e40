// meniscus — message helpers (messages.hpp) and the structured InvalidParameter (errors.hpp).
#include "meniscus/messages.hpp"

#include <atomic>
#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "meniscus/errors.hpp"
#include "meniscus/parameters.hpp"

namespace meniscus {

namespace {

std::atomic<Spelling> g_spelling{Spelling::cpp};

/// The length of the valid UTF-8 sequence at `s` (2 to 4 bytes), or 0.
std::size_t utf8_sequence(std::string_view s) {
  const auto byte = [&](std::size_t i) { return static_cast<unsigned char>(s[i]); };
  const unsigned char lead = byte(0);
  std::size_t length = 0;
  uint32_t code = 0;
  if (lead >= 0xC2 && lead <= 0xDF) length = 2, code = lead & 0x1F;
  else if (lead >= 0xE0 && lead <= 0xEF) length = 3, code = lead & 0x0F;
  else if (lead >= 0xF0 && lead <= 0xF4) length = 4, code = lead & 0x07;
  else return 0;
  if (s.size() < length) return 0;
  for (std::size_t i = 1; i < length; ++i) {
    if ((byte(i) & 0xC0) != 0x80) return 0;
    code = (code << 6) | (byte(i) & 0x3F);
  }
  const bool overlong = (length == 3 && code < 0x800) || (length == 4 && code < 0x10000);
  const bool surrogate = code >= 0xD800 && code <= 0xDFFF;
  if (overlong || surrogate || code > 0x10FFFF) return 0;
  if (code >= 0x80 && code <= 0x9F) return 0;  // C1 controls (CSI is U+009B)
  return length;
}

}  // namespace

std::string printable(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size();) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c >= 0x20 && c < 0x7F) {
      out += char(c), ++i;
    } else if (c == '\n' || c == '\t') {
      out += char(c), ++i;
    } else if (const std::size_t n = c >= 0x80 ? utf8_sequence(text.substr(i)) : 0; n > 0) {
      out.append(text.substr(i, n)), i += n;
    } else {
      out += fmt::format("\\x{:02x}", c), ++i;
    }
  }
  return out;
}

InvalidParameter::InvalidParameter(std::string key, std::string value, std::string expectation)
    : std::invalid_argument(spelled_setting(key, printable(value)) + ": " + expectation),
      key_(std::move(key)), value_(std::move(value)), expectation_(std::move(expectation)) {}

void set_message_spelling(Spelling spelling) { g_spelling = spelling; }

Spelling message_spelling() { return g_spelling; }

std::string spelled(std::string_view key) {
  switch (message_spelling()) {
    case Spelling::cli: {
      if (const ParamSpec* spec = find_parameter(key); spec && !spec->option.empty()) return std::string(spec->option);
      std::string option = "--" + std::string(key);
      for (char& c : option) c = c == '_' ? '-' : c;
      return option;
    }
    case Spelling::python:
    case Spelling::cpp: return std::string(key);
  }
  return std::string(key);
}

std::string spelled_setting(std::string_view key, std::string_view value) {
  switch (message_spelling()) {
    case Spelling::cli:
      if (value == "true") return spelled(key);  // a flag
      return fmt::format("{} {}", spelled(key), value);
    case Spelling::python:
      if (value == "true" || value == "false") return fmt::format("{}={}", key, value == "true" ? "True" : "False");
      return fmt::format("{}={}", key, value);
    case Spelling::cpp: return fmt::format("{} = {}", key, value);
  }
  return std::string(key);
}

std::string human_bytes(double bytes) {
  if (!std::isfinite(bytes)) return "an unbounded amount";
  if (bytes < 1000) return fmt::format("{:.0f} {}", bytes, std::lround(bytes) == 1 ? "byte" : "bytes");
  static constexpr const char* kUnits[] = {"KB", "MB", "GB", "TB", "PB", "EB"};
  int unit = 0;
  double value = bytes / 1000;
  while (value >= 999.5 && unit + 1 < int(std::size(kUnits))) value /= 1000, ++unit;
  return value >= 99.95 ? fmt::format("{:.0f} {}", value, kUnits[unit])
         : value >= 9.995 ? fmt::format("{:.1f} {}", value, kUnits[unit])
                          : fmt::format("{:.2f} {}", value, kUnits[unit]);
}

std::string closest_name(std::string_view name, const std::vector<std::string>& candidates) {
  const auto distance = [](std::string_view a, std::string_view b) {
    std::vector<std::size_t> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
      std::size_t diagonal = row[0];
      row[0] = i;
      for (std::size_t j = 1; j <= b.size(); ++j) {
        const std::size_t substitute = diagonal + (a[i - 1] == b[j - 1] ? 0 : 1);
        diagonal = row[j];
        row[j] = std::min({row[j] + 1, row[j - 1] + 1, substitute});
      }
    }
    return row[b.size()];
  };
  std::string best;
  std::size_t best_distance = std::numeric_limits<std::size_t>::max();
  for (const std::string& candidate : candidates)
    if (const std::size_t d = distance(name, candidate); d < best_distance) best_distance = d, best = candidate;
  return best_distance <= std::max<std::size_t>(2, name.size() / 3) ? best : std::string();
}

}  // namespace meniscus
