// meniscus — parameters by name: presets, the artist controls (smoothness, detail) and JSON
// configuration files (docs/cli.md "Artist controls"). One table of keys serves the CLI's --config,
// the Python keywords and the Blender panel.
#include "meniscus/config.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "io/file_bytes.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/messages.hpp"
#include "meniscus/parameters.hpp"

namespace meniscus {

namespace {

using nlohmann::json;

/// Keys that a --stats file's "parameters" carry besides the table's: accepted and ignored, so a
/// stats file replays as a configuration.
constexpr std::string_view kStatsOnlyKeys[] = {"spacing_estimated", "estimated_on"};

std::string canonical(std::string_view key) {
  std::string k(key);
  std::replace(k.begin(), k.end(), '-', '_');
  return k;
}

[[noreturn]] void unknown_key(std::string_view key) {
  std::vector<std::string> known;
  for (const ParamSpec& spec : parameter_table()) known.emplace_back(spec.key);
  const std::string close = closest_name(canonical(key), known);
  throw InvalidParameter(fmt::format("unknown parameter '{}'{} (known: {})", printable(key),
                                     close.empty() ? "" : fmt::format(" — did you mean '{}'?", close),
                                     fmt::join(known, ", ")));
}

/// Line (1-based) of the byte at `index` (0-based) of `text`.
std::size_t line_of(const std::string& text, std::size_t index) {
  index = std::min(index, text.size());
  return 1 + std::size_t(std::count(text.begin(), text.begin() + std::ptrdiff_t(index), '\n'));
}

// ---------------------------------------------------------------------------------------------
// Smoothness and presets.

// Smoothness s scales the whole schedule linearly from nothing (s = 0: the mesh as extracted)
// to twice the default (s = 1), so s = 0.5 is exactly the default 20 A + 10 B + 3 free sweeps.
constexpr double kStepsAAtFull = 40, kStepsBAtFull = 20, kStepsFreeAtFull = 6;

// Every preset sets the same settings (so switching presets never leaves one behind); the
// radii go back to "derive" (0) so that r_outer_factor decides. Measured on the jittered block,
// lone particles, stretched sheets and the real frames of tests/data (docs/cli.md "Artist controls").
struct Preset {
  const char* name;
  double detail, r_outer_factor;
  int steps_a, steps_b, steps_free;
};

constexpr Preset kPresets[] = {
    // Coarser than 0.6 and lone droplets collapse (detail 0.5: 9 % of their volume left).
    {"preview", 0.6, 1.0, 10, 5, 0},
    {"production", 1.0, 1.0, 20, 10, 3},
    // r_outer 1.25 d bridges particles up to 2.5 d apart and makes a lone droplet one
    // particle's volume (r_inner 0.625 d); no free sweeps, so every vertex stays in its shell.
    {"droplets", 1.0, 1.25, 10, 20, 0},
};

}  // namespace

std::vector<std::string> preset_names() {
  std::vector<std::string> names;
  for (const Preset& p : kPresets) names.emplace_back(p.name);
  return names;
}

void apply_preset(Params& params, std::string_view name) {
  for (const Preset& p : kPresets)
    if (name == p.name) {
      params.detail = p.detail;
      params.voxel_size = 0;  // the detail decides
      params.r_outer_factor = p.r_outer_factor;
      params.r_outer = 0;
      params.r_inner = 0;
      params.steps_a = p.steps_a;
      params.steps_b = p.steps_b;
      params.steps_free = p.steps_free;
      return;
    }
  throw InvalidParameter("preset", std::string(name), fmt::format("expected {}", fmt::join(preset_names(), ", ")));
}

void apply_smoothness(Params& params, double smoothness) {
  if (!(smoothness >= 0 && smoothness <= 1))
    throw InvalidParameter("smoothness", fmt::format("{:g}", smoothness),
                           "must be " + accepted_values(*find_parameter("smoothness")) + " (0.5 = the defaults)");
  params.steps_a = int(std::lround(kStepsAAtFull * smoothness));
  params.steps_b = int(std::lround(kStepsBAtFull * smoothness));
  params.steps_free = int(std::lround(kStepsFreeAtFull * smoothness));
}

void apply_detail(Params& params, double detail) {
  if (!(detail > 0 && detail <= 8))
    throw InvalidParameter("detail", fmt::format("{:g}", detail),
                           "must be " + accepted_values(*find_parameter("detail")) +
                               " (1 = default resolution, 2 = half the voxel size)");
  params.detail = detail;
  params.voxel_size = 0;  // derived from the detail; an explicit voxel_size set later wins
}

void set_param(Params& params, std::string_view key, const json& value) {
  const std::string k = canonical(key);
  for (const std::string_view ignored : kStatsOnlyKeys)
    if (k == ignored) return;
  const ParamSpec* spec = find_parameter(k);
  if (spec == nullptr || k != spec->key) unknown_key(key);
  // The value is judged on its own (type and range); rules between parameters (r_inner < r_outer)
  // are left to the caller's final validate(), since keys come in any order.
  try {
    set_parameter(params, *spec, value);
  } catch (const InvalidParameter& e) {
    if (k == key) throw;
    throw InvalidParameter(fmt::format("{}: {}", printable(key), e.what()));  // the key as written, then the key
  }
}

Params params_from_json(const json& object, const Params& base) {
  if (!object.is_object())
    throw InvalidParameter(fmt::format("parameters: expected an object of keys and values, got {}", object.type_name()));
  Params params = base;
  // Precedence: preset < smoothness, detail < every other key, whatever the order in the object.
  const auto find = [&](const char* wanted) -> const json* {
    const json* found = nullptr;
    for (auto it = object.begin(); it != object.end(); ++it)
      if (canonical(it.key()) == wanted) {
        if (found != nullptr) throw InvalidParameter(fmt::format("parameter '{}' is given twice", wanted));
        found = &it.value();
      }
    return found;
  };
  for (const char* control : {"preset", "smoothness", "detail"})
    if (const json* value = find(control)) set_param(params, control, *value);
  for (auto it = object.begin(); it != object.end(); ++it) {
    const std::string k = canonical(it.key());
    if (k == "preset" || k == "smoothness" || k == "detail") continue;
    (void)find(k.c_str());  // refuses "steps-a" and "steps_a" in one object
    set_param(params, it.key(), it.value());
  }
  params.validate();
  return params;
}

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
    const std::string number = quote == std::string::npos ? "" : message.substr(quote + 1, message.find('\'', quote + 1) - quote - 1);
    const std::size_t at = number.empty() ? std::string::npos : text.find(number);
    throw FormatError(path, at == std::string::npos ? "" : fmt::format("line {}", line_of(text, at)),
                      fmt::format("the number {} is beyond the range of a double (about ±1.8e308)", number));
  }
  if (!duplicate.empty()) {
    const std::string quoted = "\"" + duplicate + "\"";
    const std::size_t first = text.find(quoted), second = first == std::string::npos ? first : text.find(quoted, first + 1);
    throw FormatError(path, second == std::string::npos ? "" : fmt::format("line {}", line_of(text, second)),
                      fmt::format("the key \"{}\" is given twice; give each parameter once", duplicate));
  }
  if (!document.is_object())
    throw FormatError(path, "", fmt::format("expected a JSON object of parameters, got {}", document.type_name()));
  // A --stats file replays its "parameters" (the counts and times beside them are ignored).
  const json& object = document.contains("parameters") && document["parameters"].is_object() ? document["parameters"]
                                                                                                : document;
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
