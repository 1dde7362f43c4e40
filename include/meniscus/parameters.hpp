// meniscus — the table of parameters: every setting of a reconstruction once, with its type,
// range, default, unit and help. Params::validate, the configuration keys (config.hpp), the
// "parameters" of the --stats JSON, the CLI's options and their help, the Python keywords and
// the Blender panel's limits are all made from it, so a name, a range or a default cannot differ
// between them. Adding a parameter: a member of Params, one entry in src/params/parameters.cpp, and its use.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "meniscus/params.hpp"

namespace meniscus {

enum class ParamType {
  number,   ///< a finite real number in [min, max] ((min, max] when min_open)
  integer,  ///< a whole number in [min, max]
  flag,     ///< true or false
  choice,   ///< one of `choices`
  numbers,  ///< `count` numbers (a box: xmin, ymin, zmin, xmax, ymax, zmax), or none
  names,    ///< a list of names (attributes)
};

struct ParamSpec {
  std::string_view key;     ///< config key, Python keyword and --stats name: "steps_a"
  std::string_view option;  ///< the CLI's option: "--steps-a"; empty where there is none (set by presets)
  ParamType type = ParamType::number;
  std::string_view group;   ///< the section of the help and of docs/cli.md: "geometry", "smoothing" …
  double min = 0, max = 0;  ///< number, integer: the range
  bool min_open = false;    ///< number: min itself is refused
  std::string_view zero;    ///< what 0 (or −1 for smooth_particles) means, when it derives the value: "estimated"
  std::string_view unit;    ///< "length", "spacings", "sweeps", "GB" … (empty: none)
  std::string_view help;    ///< one line for --help and the docs
  std::string_view why;     ///< why the range is what it is, added to a refusal (or empty)
  std::vector<std::string_view> choices;  ///< choice: the names accepted
  std::size_t count = 0;                  ///< numbers: how many
  bool control = false;  ///< preset, smoothness: sets other parameters, has no value of its own in Params
};

/// Every parameter, in the order of the --stats "parameters" object, then the controls (preset,
/// smoothness).
const std::vector<ParamSpec>& parameter_table();

/// The parameter named `name`: its key, with '-' for '_' too ("steps-a"), or its CLI option
/// ("--steps-a"); nullptr when there is none.
const ParamSpec* find_parameter(std::string_view name);

/// The largest value a parameter accepts (max, or for threads a multiple of this machine's CPUs).
double parameter_max(const ParamSpec& spec);

/// What a parameter accepts, for messages and help: "an integer from 0 to 10000",
/// "a number > 0 and ≤ 8", "a number ≥ 0 (0: estimated)", "one of tiles, cubes, tetrahedra".
std::string accepted_values(const ParamSpec& spec);

/// The value of a parameter in `params`, as JSON (null for the controls).
nlohmann::json get_parameter(const Params& params, const ParamSpec& spec);

/// Sets a parameter from JSON after checking the value's type and range (InvalidParameter naming
/// the key, with `written` as the value shown, or the JSON text when empty). Cross-parameter
/// rules (r_inner < r_outer …) are Params::validate's.
void set_parameter(Params& params, const ParamSpec& spec, const nlohmann::json& value, std::string_view written = {});

/// A parameter's value from text as a command line gives it ("20", "1e-3", "tiles", "0,0,0,1,1,1",
/// "velocity,color", "true"), as JSON of the parameter's type; InvalidParameter naming the
/// parameter when it does not read as one.
nlohmann::json parse_parameter_text(const ParamSpec& spec, const std::string& text);

/// The table as JSON (key, option, type, range, default, unit, help …): `meniscus info
/// --parameters`, the Python module's parameters(), docs/cli.md's test.
nlohmann::json parameter_table_json();

}  // namespace meniscus
