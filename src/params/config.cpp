// meniscus — parameters by name: presets, the artist controls (smoothness, detail) and JSON
// objects of keys (docs/cli.md "Artist controls"; the files that hold them: io/config_file.cpp). One table of keys
// serves the CLI's --config, the Python keywords and the Blender panel.
#include "meniscus/config.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

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
    // Coarser than 0.6 and lone droplets collapse to a small part of their volume.
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

}  // namespace meniscus
