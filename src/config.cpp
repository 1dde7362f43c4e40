// meniscus — parameters by name: presets, the artist controls (smoothness, detail) and JSON
// configuration files (README "Artist controls"). One table of keys serves the CLI's --config,
// the Python keywords and the Blender panel.
#include "meniscus/config.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "meniscus/errors.hpp"

namespace meniscus {

namespace {

using nlohmann::json;

// ---------------------------------------------------------------------------------------------
// JSON values of the expected type, or an InvalidParameter naming the key.

[[noreturn]] void wrong_type(std::string_view key, const json& value, const char* expected) {
  std::string shown = value.dump();
  if (shown.size() > 40) shown = shown.substr(0, 37) + "...";
  throw InvalidParameter(fmt::format("{}: expected {}, got {} {}", key, expected, value.type_name(), shown));
}

double as_number(std::string_view key, const json& value) {
  if (!value.is_number()) wrong_type(key, value, "a number");
  return value.get<double>();
}

int as_int(std::string_view key, const json& value) {
  if (value.is_number_integer()) {
    // Signed and unsigned JSON integers alike; anything beyond int is a range error.
    const auto v = value.is_number_unsigned() ? (value.get<uint64_t>() > uint64_t(std::numeric_limits<int>::max())
                                                     ? std::numeric_limits<int64_t>::max()
                                                     : int64_t(value.get<uint64_t>()))
                                              : value.get<int64_t>();
    if (v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max())
      throw InvalidParameter(fmt::format("{} = {}: out of range", key, v));
    return int(v);
  }
  // 40.0 (a float that holds an integer, as some front ends send) is accepted; 40.5 is not.
  if (value.is_number_float()) {
    const double v = value.get<double>();
    if (v == std::floor(v) && std::abs(v) <= double(std::numeric_limits<int>::max())) return int(v);
  }
  wrong_type(key, value, "an integer");
}

bool as_bool(std::string_view key, const json& value) {
  if (!value.is_boolean()) wrong_type(key, value, "true or false");
  return value.get<bool>();
}

std::string as_string(std::string_view key, const json& value) {
  if (!value.is_string()) wrong_type(key, value, "a string");
  return value.get<std::string>();
}

/// A list of names: a JSON array of strings, or one comma-separated string ("velocity,color").
/// An array of numbers, or a string of comma-separated numbers ("0,0,0,1,1,1").
std::vector<double> as_numbers(std::string_view key, const json& value) {
  std::vector<double> numbers;
  if (value.is_string()) {
    std::stringstream in(value.get<std::string>());
    for (std::string item; std::getline(in, item, ',');) {
      std::size_t used = 0;
      double x = 0;
      try {
        x = std::stod(item, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used == 0 || item.find_first_not_of(" \t", used) != std::string::npos) wrong_type(key, value, "numbers separated by commas");
      numbers.push_back(x);
    }
    return numbers;
  }
  if (!value.is_array()) wrong_type(key, value, "an array of numbers");
  for (const json& item : value) numbers.push_back(as_number(key, item));
  return numbers;
}

std::vector<std::string> as_names(std::string_view key, const json& value) {
  std::vector<std::string> names;
  if (value.is_string()) {
    std::stringstream in(value.get<std::string>());
    for (std::string name; std::getline(in, name, ',');)
      if (!name.empty()) names.push_back(name);
    return names;
  }
  if (!value.is_array()) wrong_type(key, value, "an array of attribute names");
  for (const json& item : value) {
    if (!item.is_string()) wrong_type(key, value, "an array of attribute names");
    names.push_back(item.get<std::string>());
  }
  return names;
}

// ---------------------------------------------------------------------------------------------
// The keys. Each setter checks the type; ranges are checked by Params::validate on a default
// Params holding only that value (so a key is judged on its own, whatever order keys come in).

using Setter = void (*)(Params&, std::string_view key, const json& value);

struct Key {
  const char* name;
  Setter set;
};

#define MENISCUS_NUMBER_KEY(member) \
  Key { #member, [](Params& p, std::string_view k, const json& v) { p.member = as_number(k, v); } }
#define MENISCUS_INT_KEY(member) \
  Key { #member, [](Params& p, std::string_view k, const json& v) { p.member = as_int(k, v); } }

const std::vector<Key>& keys() {
  static const std::vector<Key> table = {
      MENISCUS_NUMBER_KEY(spacing),
      // Written by --stats; a replayed stats file gives the spacing itself, so this is ignored.
      Key{"spacing_estimated", [](Params&, std::string_view k, const json& v) { (void)as_bool(k, v); }},
      Key{"estimated_on", [](Params&, std::string_view k, const json& v) { (void)as_string(k, v); }},
      MENISCUS_NUMBER_KEY(voxel_size),
      Key{"detail", [](Params& p, std::string_view k, const json& v) { apply_detail(p, as_number(k, v)); }},
      MENISCUS_NUMBER_KEY(r_inner),
      MENISCUS_NUMBER_KEY(r_outer),
      MENISCUS_NUMBER_KEY(r_outer_factor),
      Key{"extract", [](Params& p, std::string_view k, const json& v) { p.extract = parse_extractor(as_string(k, v)); }},
      Key{"keep_voids", [](Params& p, std::string_view k, const json& v) { p.keep_voids = as_bool(k, v); }},
      MENISCUS_INT_KEY(steps_a),
      MENISCUS_INT_KEY(steps_b),
      MENISCUS_INT_KEY(steps_free),
      MENISCUS_NUMBER_KEY(relax),
      MENISCUS_NUMBER_KEY(relax_b),
      Key{"solver", [](Params& p, std::string_view k, const json& v) { p.solver = parse_solver(as_string(k, v)); }},
      MENISCUS_INT_KEY(rebuild_b),
      MENISCUS_NUMBER_KEY(erode),
      MENISCUS_INT_KEY(min_particles),
      Key{"particle_box", [](Params& p, std::string_view k, const json& v) { p.particle_box = as_numbers(k, v); }},
      Key{"clip_box", [](Params& p, std::string_view k, const json& v) { p.clip_box = as_numbers(k, v); }},
      Key{"clip_cap", [](Params& p, std::string_view k, const json& v) { p.clip_cap = as_bool(k, v); }},
      MENISCUS_NUMBER_KEY(decimate),
      Key{"transfer", [](Params& p, std::string_view k, const json& v) { p.transfer = as_names(k, v); }},
      MENISCUS_NUMBER_KEY(transfer_radius),
      MENISCUS_INT_KEY(threads),
      MENISCUS_NUMBER_KEY(max_memory_gb),
      Key{"field", [](Params& p, std::string_view k, const json& v) { p.field = parse_field(as_string(k, v)); }},
      MENISCUS_NUMBER_KEY(iso),
      MENISCUS_NUMBER_KEY(kernel_radius),
      MENISCUS_NUMBER_KEY(rest_density),
      MENISCUS_NUMBER_KEY(smooth_particles),
      Key{"velocity_weighted", [](Params& p, std::string_view k, const json& v) { p.velocity_weighted = as_bool(k, v); }},
      MENISCUS_NUMBER_KEY(velocity_reference),
      MENISCUS_NUMBER_KEY(velocity_min_weight),
      Key{"backend", [](Params& p, std::string_view k, const json& v) { p.backend = parse_backend(as_string(k, v)); }},
      // The controls: applied before the keys above by params_from_json.
      Key{"preset", [](Params& p, std::string_view k, const json& v) { apply_preset(p, as_string(k, v)); }},
      Key{"smoothness", [](Params& p, std::string_view k, const json& v) { apply_smoothness(p, as_number(k, v)); }},
  };
  return table;
}

#undef MENISCUS_NUMBER_KEY
#undef MENISCUS_INT_KEY

std::string canonical(std::string_view key) {
  std::string k(key);
  std::replace(k.begin(), k.end(), '-', '_');
  return k;
}

std::size_t edit_distance(std::string_view a, std::string_view b) {
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
}

[[noreturn]] void unknown_key(std::string_view key) {
  const std::string k = canonical(key);
  const Key* best = nullptr;
  std::size_t best_distance = std::numeric_limits<std::size_t>::max();
  for (const Key& candidate : keys()) {
    const std::size_t d = edit_distance(k, candidate.name);
    if (d < best_distance) best_distance = d, best = &candidate;
  }
  std::string known;
  for (const Key& candidate : keys()) known += (known.empty() ? "" : ", ") + std::string(candidate.name);
  const bool close = best != nullptr && best_distance <= std::max<std::size_t>(2, k.size() / 3);
  throw InvalidParameter(fmt::format("unknown parameter '{}'{} (known: {})", key,
                                     close ? fmt::format(" — did you mean '{}'?", best->name) : "", known));
}

const Key& find_key(std::string_view key) {
  const std::string k = canonical(key);
  for (const Key& candidate : keys())
    if (k == candidate.name) return candidate;
  unknown_key(key);
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
// lone particles, stretched sheets and the real frames of tests/data (README "Artist controls").
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
  throw InvalidParameter(fmt::format("preset: unknown preset '{}' (known: {})", name, fmt::join(preset_names(), ", ")));
}

void apply_smoothness(Params& params, double smoothness) {
  if (!(smoothness >= 0 && smoothness <= 1))
    throw InvalidParameter(fmt::format("smoothness = {:g}: must be in [0, 1] (0.5 = the defaults)", smoothness));
  params.steps_a = int(std::lround(kStepsAAtFull * smoothness));
  params.steps_b = int(std::lround(kStepsBAtFull * smoothness));
  params.steps_free = int(std::lround(kStepsFreeAtFull * smoothness));
}

void apply_detail(Params& params, double detail) {
  Params probe;
  probe.detail = detail;
  probe.validate();  // names "detail" and the range
  params.detail = detail;
  params.voxel_size = 0;  // derived from the detail; an explicit voxel_size set later wins
}

void set_param(Params& params, std::string_view key, const json& value) {
  const Key& k = find_key(key);
  // Judge the value on its own: a default Params holding only it. Cross-parameter checks
  // (r_inner < r_outer) are left to the caller's final validate(), since keys come in any order.
  Params probe;
  if (canonical(key) == "clip_cap") probe.clip_box = {0, 0, 0, 1, 1, 1};  // needs a box: checked at the end
  k.set(probe, key, value);
  try {
    probe.validate();
  } catch (const InvalidParameter& e) {
    if (canonical(key) == key) throw;
    throw InvalidParameter(fmt::format("{}: {}", key, e.what()));
  }
  k.set(params, key, value);
}

Params params_from_json(const json& object, const Params& base) {
  if (!object.is_object())
    throw InvalidParameter(fmt::format("parameters: expected a JSON object of keys, got {}", object.type_name()));
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
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(fmt::format("{}: cannot open the configuration file", path));
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw IoError(fmt::format("{}: cannot read the configuration file", path));
  json document;
  try {
    document = json::parse(text);
  } catch (const json::parse_error& e) {
    // e.byte is 1-based (the byte that could not be read; one past the end for a truncated file).
    std::string message = e.what();
    const std::size_t colon = message.find(": ", message.find("parse error"));
    if (colon != std::string::npos) message = message.substr(colon + 2);
    throw FormatError(path, fmt::format("line {}", line_of(text, e.byte == 0 ? 0 : e.byte - 1)),
                      "malformed JSON: " + message);
  }
  if (!document.is_object())
    throw FormatError(path, "", fmt::format("expected a JSON object of parameters, got {}", document.type_name()));
  // A --stats file replays its "parameters" (the counts and times beside them are ignored).
  const json& object = document.contains("parameters") && document["parameters"].is_object() ? document["parameters"]
                                                                                                : document;
  try {
    return params_from_json(object, base);
  } catch (const InvalidParameter& e) {
    throw InvalidParameter(fmt::format("{}: {}", path, e.what()));
  }
}

}  // namespace meniscus
