// meniscus — frame-sequence file patterns and frame ranges.
#include "meniscus/sequence.hpp"

#include <algorithm>
#include <charconv>
#include <filesystem>
#include <fmt/format.h>
#include <set>

#include "meniscus/errors.hpp"

namespace meniscus {

std::string FramePattern::format(int frame) const {
  const std::string digits = frame < 0 ? fmt::format("-{:0{}}", -static_cast<long long>(frame), width)
                                       : fmt::format("{:0{}}", frame, width);
  return prefix + digits + suffix;
}

std::optional<int> FramePattern::match(const std::string& name) const {
  if (name.size() <= prefix.size() + suffix.size()) return std::nullopt;
  if (name.compare(0, prefix.size(), prefix) != 0) return std::nullopt;
  if (name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0) return std::nullopt;
  const std::string middle = name.substr(prefix.size(), name.size() - prefix.size() - suffix.size());
  int value = 0;
  const char* first = middle.data();
  const char* last = middle.data() + middle.size();
  const auto [ptr, ec] = std::from_chars(first, last, value);
  if (ec != std::errc{} || ptr != last) return std::nullopt;
  // Padded patterns only match names written with that padding (or wider numbers).
  const std::size_t digits = middle.size() - (middle[0] == '-' ? 1 : 0);
  if (width > 0 && digits < std::size_t(width)) return std::nullopt;
  if (format(value) != name) return std::nullopt;
  return value;
}

std::optional<FramePattern> parse_frame_pattern(const std::string& path) {
  // Search the file name only: directories may legitimately contain '#' or '%'.
  const std::size_t name_start = path.find_last_of('/') == std::string::npos ? 0 : path.find_last_of('/') + 1;
  FramePattern p;
  const std::size_t hash = path.rfind('#');
  if (hash != std::string::npos && hash >= name_start) {
    std::size_t begin = hash;
    while (begin > name_start && path[begin - 1] == '#') --begin;
    p.prefix = path.substr(0, begin);
    p.suffix = path.substr(hash + 1);
    p.width = int(hash + 1 - begin);
    return p;
  }
  const std::size_t braces = path.rfind("{}");
  if (braces != std::string::npos && braces >= name_start) {
    p.prefix = path.substr(0, braces);
    p.suffix = path.substr(braces + 2);
    return p;
  }
  const std::size_t percent = path.rfind('%');
  if (percent != std::string::npos && percent >= name_start) {
    std::size_t i = percent + 1;
    int width = 0;
    const bool zero = i < path.size() && path[i] == '0';
    while (i < path.size() && path[i] >= '0' && path[i] <= '9') width = width * 10 + (path[i++] - '0');
    if (i < path.size() && path[i] == 'd' && width <= 32) {
      p.prefix = path.substr(0, percent);
      p.suffix = path.substr(i + 1);
      p.width = zero ? width : 0;
      return p;
    }
  }
  return std::nullopt;
}

std::vector<int> parse_frame_ranges(const std::string& spec) {
  auto fail = [&](const std::string& why) {
    throw InvalidParameter(fmt::format("frames '{}': {} (expected e.g. 1-240, 1-240:2 or 1,5,10-20)", spec, why));
  };
  auto number = [&](std::string_view text) {
    int v = 0;
    const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
    if (text.empty() || ec != std::errc{} || ptr != text.data() + text.size())
      fail(fmt::format("'{}' is not a frame number", text));
    return v;
  };
  std::vector<int> frames;
  std::set<int> seen;
  std::string_view rest = spec;
  if (rest.empty()) fail("empty");
  while (!rest.empty()) {
    const std::size_t comma = rest.find(',');
    std::string_view item = rest.substr(0, comma);
    rest = comma == std::string_view::npos ? std::string_view{} : rest.substr(comma + 1);
    int step = 1;
    if (const std::size_t colon = item.find(':'); colon != std::string_view::npos) {
      step = number(item.substr(colon + 1));
      if (step < 1) fail("the step must be ≥ 1");
      item = item.substr(0, colon);
    }
    // A '-' after the first character separates the range (the first may be a minus sign).
    const std::size_t dash = item.find('-', 1);
    const int first = number(item.substr(0, dash));
    const int last = dash == std::string_view::npos ? first : number(item.substr(dash + 1));
    if (last < first) fail(fmt::format("range {}-{} runs backwards", first, last));
    if ((long long)(last - first) / step + frames.size() > 10'000'000) fail("more than 10 million frames");
    for (long long f = first; f <= last; f += step)
      if (seen.insert(int(f)).second) frames.push_back(int(f));
  }
  return frames;
}

std::string format_frame_ranges(const std::vector<int>& frames) {
  std::string text;
  for (std::size_t i = 0; i < frames.size();) {
    std::size_t j = i;
    while (j + 1 < frames.size() && frames[j + 1] == frames[j] + 1) ++j;
    if (!text.empty()) text += ',';
    text += j == i ? std::to_string(frames[i]) : std::to_string(frames[i]) + "-" + std::to_string(frames[j]);
    i = j + 1;
  }
  return text;
}

std::vector<int> discover_frames(const FramePattern& pattern) {
  namespace fs = std::filesystem;
  const fs::path prefix(pattern.prefix);
  const fs::path dir = pattern.prefix.empty() || pattern.prefix.back() == '/' ? fs::path(pattern.prefix)
                                                                               : prefix.parent_path();
  std::vector<int> frames;
  std::error_code ec;
  const fs::path scan = dir.empty() ? fs::path(".") : dir;
  for (fs::directory_iterator it(scan, ec), end; !ec && it != end; it.increment(ec)) {
    std::string name = it->path().string();
    if (dir.empty() && name.rfind("./", 0) == 0) name = name.substr(2);
    if (const auto f = pattern.match(name)) frames.push_back(*f);
  }
  std::sort(frames.begin(), frames.end());
  return frames;
}

}  // namespace meniscus
