// meniscus io — a --config file: a JSON object of parameters (or a whole --stats file), read with a
// bound on its size and with each error placed at its line (params/config.cpp applies the keys).
#include <algorithm>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "io/file_bytes.hpp"
#include "meniscus/config.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/messages.hpp"
#include "meniscus/parameters.hpp"

namespace meniscus {

namespace {

using nlohmann::json;

/// Line (1-based) of the byte at `index` (0-based) of `text`.
std::size_t line_of(const std::string& text, std::size_t index) {
  index = std::min(index, text.size());
  return 1 + std::size_t(std::count(text.begin(), text.begin() + std::ptrdiff_t(index), '\n'));
}

}  // namespace

Params read_config(const std::string& path, const Params& base) {
  // A configuration is a few hundred bytes; more than this is not one (a wrong path, /dev/zero).
  constexpr std::size_t kMaxConfigBytes = 16'000'000;
  const io::ByteBuffer bytes = io::read_file_bytes(
      path, {kMaxConfigBytes, fmt::format("the {} a configuration file may hold", human_bytes(kMaxConfigBytes))});
  const std::string text(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  // One JSON object, with each key once: nlohmann keeps the last of two equal keys silently, so
  // the parser's callback keeps the keys of every open object.
  std::vector<std::vector<std::string>> open_objects;
  std::string duplicate;
  const json::parser_callback_t check_keys = [&](int, json::parse_event_t event, json& parsed) {
    if (event == json::parse_event_t::object_start) open_objects.emplace_back();
    if (event == json::parse_event_t::object_end && !open_objects.empty()) open_objects.pop_back();
    if (event == json::parse_event_t::key && !open_objects.empty() && duplicate.empty()) {
      std::vector<std::string>& keys = open_objects.back();
      const std::string key = parsed.get<std::string>();
      if (std::find(keys.begin(), keys.end(), key) != keys.end()) duplicate = key;
      keys.push_back(key);
    }
    return true;
  };
  json document;
  try {
    document = json::parse(text, check_keys);
  } catch (const json::parse_error& e) {
    // e.byte is 1-based (the byte that could not be read; one past the end for a truncated file).
    std::string message = e.what();
    const std::size_t colon = message.find(": ", message.find("parse error"));
    if (colon != std::string::npos) message = message.substr(colon + 2);
    throw FormatError(path, fmt::format("line {}", line_of(text, e.byte == 0 ? 0 : e.byte - 1)),
                      "malformed JSON: " + message);
  } catch (const json::out_of_range& e) {
    // A number beyond double's range (1e400); nlohmann names it but not where it is.
    const std::string message = e.what();
    const std::size_t quote = message.find('\'');
    const std::string number =
        quote == std::string::npos ? "" : message.substr(quote + 1, message.find('\'', quote + 1) - quote - 1);
    const std::size_t at = number.empty() ? std::string::npos : text.find(number);
    throw FormatError(path, at == std::string::npos ? "" : fmt::format("line {}", line_of(text, at)),
                      fmt::format("the number {} is beyond the range of a double (about ±1.8e308)", number));
  }
  if (!duplicate.empty()) {
    const std::string quoted = "\"" + duplicate + "\"";
    const std::size_t first = text.find(quoted),
                      second = first == std::string::npos ? first : text.find(quoted, first + 1);
    throw FormatError(path, second == std::string::npos ? "" : fmt::format("line {}", line_of(text, second)),
                      fmt::format("the key \"{}\" is given twice; give each parameter once", duplicate));
  }
  if (!document.is_object())
    throw FormatError(path, "", fmt::format("expected a JSON object of parameters, got {}", document.type_name()));
  // A --stats file replays its "parameters" (the counts and times beside them are ignored), less
  // the machine's resources it recorded (the "execution" group: threads, backend, memory bound):
  // those come from the machine that replays, unless its options give them. A hand-written
  // configuration is taken as written.
  const bool stats_file = document.contains("parameters") && document["parameters"].is_object();
  json object = stats_file ? document["parameters"] : document;
  if (stats_file)
    for (const ParamSpec& spec : parameter_table())
      if (spec.group == "execution") object.erase(std::string(spec.key));
  try {
    return params_from_json(object, base);
  } catch (const InvalidParameter& e) {
    // The key as the file writes it, whichever front end reads the file.
    if (!e.key().empty())
      throw InvalidParameter(fmt::format("{}: {} = {}: {}", path, e.key(), printable(e.value()), e.expectation()));
    throw InvalidParameter(fmt::format("{}: {}", path, e.what()));
  }
}

}  // namespace meniscus
