// meniscus CLI — the table of parameters (meniscus/parameters.hpp) as command-line options.
#pragma once

#include <map>
#include <string>
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
  void add_to(CLI::App& cmd);
  /// The options given, as an object of the table's keys (typed values), for params_from_json.
  nlohmann::json given(const CLI::App& cmd) const;

 private:
  std::map<std::string, std::string> texts_;                // key → the value typed
  std::map<std::string, std::vector<std::string>> lists_;   // boxes and names
  std::map<std::string, bool> flags_;
};

/// The parameters of a run: a --config file (when given), then the options given on top of it
/// with params_from_json's precedence (preset < smoothness, detail < every other option),
/// validated. InvalidParameter (exit 2) for a bad value, naming the option or the file's key.
Params run_parameters(const CLI::App& cmd, const ParameterOptions& options, const std::string& config_path);

}  // namespace meniscus::cli
