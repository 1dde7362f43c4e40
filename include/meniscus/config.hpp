// meniscus — parameters by name: presets, the artist controls (smoothness, detail) and
// configuration files. Every front end (CLI `--config`/`--preset`, the Python keywords, the
// Blender panel) goes through these functions, so a key means the same thing everywhere.
//
// Keys are those of the "parameters" object that `--stats` writes (spacing, voxel_size,
// r_inner, r_outer, extract, keep_voids, steps_a, steps_b, steps_free, relax, relax_b, solver,
// rebuild_b, erode, transfer, transfer_radius, threads, max_memory_gb, ...) plus the
// controls "preset", "smoothness" and "detail". '-' and '_' are interchangeable in keys.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "meniscus/params.hpp"

namespace meniscus {

/// The named presets ("preview", "production", "droplets"), in that order.
std::vector<std::string> preset_names();

/// Overwrites the settings a preset controls. Throws InvalidParameter listing the known names
/// for an unknown one.
void apply_preset(Params& params, std::string_view name);

/// Smoothness in [0, 1] onto the smoothing schedule (see README "Artist controls").
void apply_smoothness(Params& params, double smoothness);

/// Detail k > 0 onto the field resolution: voxel size = d / (2 k) (k = 1 is the default).
void apply_detail(Params& params, double detail);

/// Sets one parameter by key. Throws InvalidParameter naming the key for an unknown key or a
/// value of the wrong type or range.
void set_param(Params& params, std::string_view key, const nlohmann::json& value);

/// Applies every key of a JSON object on top of `base`: "preset" first, then "smoothness" and
/// "detail", then the explicit keys (so an explicit key always wins). Unknown keys are errors.
Params params_from_json(const nlohmann::json& object, const Params& base = {});

/// Reads a --config file (a JSON object of the keys above). Throws FormatError naming the file
/// and line for malformed JSON, InvalidParameter for a bad key or value.
Params read_config(const std::string& path, const Params& base = {});

}  // namespace meniscus
