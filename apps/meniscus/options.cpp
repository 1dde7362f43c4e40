// meniscus CLI — the table of parameters as options (options.hpp).
#include "options.hpp"

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <cmath>

#include "meniscus/config.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/parameters.hpp"

namespace meniscus::cli {

namespace {

/// A group heading of --help for a group of the table.
std::string heading(std::string_view group) {
  std::string h(group);
  if (!h.empty()) h[0] = char(std::toupper(static_cast<unsigned char>(h[0])));
  return h;
}

/// "help — accepts; default X".
std::string help_text(const ParamSpec& spec) {
  if (spec.type == ParamType::flag) return std::string(spec.help);  // a flag takes no value
  std::string text = fmt::format("{} — {}", spec.help, accepted_values(spec));
  if (!spec.control && spec.type != ParamType::flag) {
    const nlohmann::json value = get_parameter(Params{}, spec);
    const bool derived = (value.is_number() && value.get<double>() == 0 && !spec.zero.empty()) ||
                         (spec.key == "smooth_particles");
    if (value.is_array() && value.empty()) text += "; default: none";
    else if (!derived) text += fmt::format("; default {}", value.is_string() ? value.get<std::string>() : value.dump());
  }
  return text;
}

}  // namespace

void ParameterOptions::add_to(CLI::App& cmd, const std::vector<std::string_view>& keys, const std::string& group) {
  std::vector<const ParamSpec*> specs;
  if (keys.empty()) {
    for (const ParamSpec& spec : parameter_table())
      if (!spec.option.empty() && !added_.count(std::string(spec.key))) specs.push_back(&spec);
  } else {
    for (const std::string_view key : keys) specs.push_back(find_parameter(key));
  }
  for (const ParamSpec* s : specs) {
    const ParamSpec& spec = *s;
    const std::string key(spec.key), option(spec.option), help = help_text(spec);
    added_.insert(key);
    CLI::Option* o = nullptr;
    // The value's type as the help shows it (the values are kept as text and converted by the
    // table's rules, so CLI11 would call every one TEXT).
    switch (spec.type) {
      case ParamType::flag: o = cmd.add_flag(option, flags_[key], help); break;
      case ParamType::numbers:
        o = cmd.add_option(option, lists_[key], help)->delimiter(',')->expected(1, int(spec.count));
        o->type_name(spec.count == 6 ? "X0,Y0,Z0,X1,Y1,Z1" : "NUMBERS");
        break;
      case ParamType::names:
        o = cmd.add_option(option, lists_[key], help)->delimiter(',');
        o->type_name("NAME,…");
        break;
      case ParamType::integer: o = cmd.add_option(option, texts_[key], help)->type_name("INT"); break;
      case ParamType::choice: o = cmd.add_option(option, texts_[key], help)->type_name("NAME"); break;
      case ParamType::number: o = cmd.add_option(option, texts_[key], help)->type_name("NUMBER"); break;
    }
    o->group(group.empty() ? heading(spec.group) : group);
  }
}

nlohmann::json ParameterOptions::given(const CLI::App& cmd) const {
  nlohmann::json object = nlohmann::json::object();
  for (const ParamSpec& spec : parameter_table()) {
    if (spec.option.empty() || cmd.count(std::string(spec.option)) == 0) continue;
    const std::string key(spec.key);
    switch (spec.type) {
      case ParamType::flag: object[key] = true; break;
      case ParamType::numbers:
      case ParamType::names: {
        std::string joined;
        for (const std::string& item : lists_.at(key)) joined += (joined.empty() ? "" : ",") + item;
        object[key] = parse_parameter_text(spec, joined);
        break;
      }
      default: object[key] = parse_parameter_text(spec, texts_.at(key)); break;
    }
  }
  return object;
}

Params run_parameters(const CLI::App& cmd, const ParameterOptions& options, const std::string& config_path) {
  Params base;
  if (!config_path.empty()) {
    try {
      base = read_config(config_path);
    } catch (const std::runtime_error& e) {  // FormatError, IoError: the options are bad (exit 2)
      throw InvalidParameter(fmt::format("--config {}", e.what()));
    }
  }
  return params_from_json(options.given(cmd), base);
}

}  // namespace meniscus::cli
