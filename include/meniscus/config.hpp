// meniscus — parameters by name: presets, the artist controls (smoothness, detail) and
// configuration files. Every front end (CLI `--config`/`--preset`, the Python keywords, the
// Blender panel) goes through these functions, so a key means the same thing everywhere.
//
// Keys are those of the "parameters" object that `--stats` writes (spacing, voxel_size, detail,
// r_inner, r_outer, r_outer_factor, extract, keep_voids, steps_a, steps_b, steps_free, relax,
// relax_b, solver, rebuild_b, erode, transfer, transfer_radius, threads, max_memory_gb;
// "spacing_estimated" and "estimated_on" are accepted and ignored) plus the controls "preset" and "smoothness".
// '-' and '_' are interchangeable in keys. Value types: numbers for lengths and factors,
// integers for counts (40.0 is accepted, 40.5 is not), booleans, strings for extract/solver/
// preset, and for transfer an array of names or one comma-separated string.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "meniscus/params.hpp"

namespace meniscus {

/// The named presets ("preview", "production", "droplets"), in that order.
std::vector<std::string> preset_names();

/// Overwrites the settings a preset controls — every preset sets the same ones: detail,
/// r_outer_factor, steps_a, steps_b, steps_free, and resets voxel_size, r_outer and r_inner to 0
/// (derive). Throws InvalidParameter listing the known names for an unknown one.
void apply_preset(Params& params, std::string_view name);

/// Smoothness s in [0, 1] onto the smoothing schedule (see docs/cli.md "Artist controls"): steps_a =
/// round(40 s), steps_b = round(20 s), steps_free = round(6 s); s = 0.5 gives the defaults 20,
/// 10, 3 and s = 0 the mesh as extracted. Throws InvalidParameter naming "smoothness" outside [0, 1].
void apply_smoothness(Params& params, double smoothness);

/// Detail k in (0, 8] onto the field resolution: sets params.detail and resets voxel_size to 0,
/// so that resolve_params uses d / (2 k) (k = 1 is the default; k = 2 gives about 4× the
/// triangles). Throws InvalidParameter naming "detail" outside the range.
void apply_detail(Params& params, double detail);

/// Sets one parameter by key. Throws InvalidParameter naming the key for an unknown key or a
/// value of the wrong type or range.
void set_param(Params& params, std::string_view key, const nlohmann::json& value);

/// Applies every key of a JSON object on top of `base`: "preset" first, then "smoothness" and
/// "detail", then the explicit keys (so an explicit key always wins), then validates the result.
/// Unknown keys (the message suggests the closest known one), a key given twice ("steps-a" and
/// "steps_a"), wrong types and out-of-range values throw InvalidParameter naming the key.
Params params_from_json(const nlohmann::json& object, const Params& base = {});

/// Reads a --config file: a JSON object of the keys above, or a whole `--stats` file, whose
/// "parameters" object is used (so a run can be replayed exactly). Throws IoError when it cannot
/// be read, FormatError naming the file and line for malformed JSON or a top level that is not
/// an object, InvalidParameter (prefixed with the file) for a bad key or value.
Params read_config(const std::string& path, const Params& base = {});

}  // namespace meniscus
