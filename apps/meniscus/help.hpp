// meniscus CLI — the help pages: options grouped, wrapped to 100 columns, true value types.
#pragma once

#include <CLI/CLI.hpp>

#include <string>

namespace meniscus::cli {

/// The width every help page is wrapped to.
constexpr std::size_t kHelpColumns = 100;

/// CLI11's formatter with each option's description wrapped under its own column (a name too
/// wide for the left column puts the description on the next line), and the option's value shown
/// by its type name alone (NUMBER, INT, FILE …; its range is in the description). Set on the app
/// before the subcommands are added, which take it over.
class HelpFormatter : public CLI::Formatter {
 public:
  HelpFormatter();
  std::string make_option(const CLI::Option* opt, bool is_positional) const override;
  std::string make_option_opts(const CLI::Option* opt) const override;
  std::string make_group(std::string group, bool is_positional, std::vector<const CLI::Option*> opts) const override;
  std::string make_description(const CLI::App* app) const override;
  std::string make_footer(const CLI::App* app) const override;
};

/// `text` wrapped to `width` columns (UTF-8 characters counted as one), every line after the
/// first indented by `indent` spaces; the first line is `first_width` wide. Words longer than a
/// line stand alone on theirs.
std::string wrap_text(const std::string& text, std::size_t first_width, std::size_t width, std::size_t indent);

}  // namespace meniscus::cli
