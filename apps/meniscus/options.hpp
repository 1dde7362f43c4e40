// meniscus CLI — the table of parameters (meniscus/parameters.hpp) as command-line options.
#pragma once

#include <map>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "meniscus/params.hpp"

namespace CLI {
class App;
}

namespace meniscus::cli {

/// Every parameter with a CLI option becomes one, its help and group made from the table: the
/// values are kept as text and converted with the table's rules, so every front end reads them
/// alike and a message names the option as typed.
class ParameterOptions {
 public:
  /// Adds the options of the table's keys in `keys` (in that order) under `group`, or, with no
  /// keys, every other option under its table group's heading, in the table's order.
  void add_to(CLI::App& cmd, const std::vector<std::string_view>& keys = {}, const std::string& group = "");
  /// The options given, as an object of the table's keys (typed values), for params_from_json.
  nlohmann::json given(const CLI::App& cmd) const;

 private:
  std::map<std::string, std::string> texts_;                // key → the value typed
  std::map<std::string, std::vector<std::string>> lists_;   // boxes and names
  std::map<std::string, bool> flags_;
  std::set<std::string> added_;  // the keys whose option exists
};

/// The parameters of a run: a --config file (when given), then the options given on top of it
/// with params_from_json's precedence (preset < smoothness, detail < every other option),
/// validated. InvalidParameter (exit 2) for a bad value, naming the option or the file's key.
Params run_parameters(const CLI::App& cmd, const ParameterOptions& options, const std::string& config_path);

}  // namespace meniscus::cli
