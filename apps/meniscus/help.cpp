// meniscus CLI — the help pages (help.hpp).
#include "help.hpp"

#include <sstream>
#include <string_view>

namespace meniscus::cli {

namespace {

constexpr std::size_t kLeftColumn = 30;

/// Display width of UTF-8 text: its characters, continuation bytes not counted.
std::size_t columns(std::string_view text) {
  std::size_t n = 0;
  for (const char c : text) n += (static_cast<unsigned char>(c) & 0xC0) != 0x80;
  return n;
}

}  // namespace

std::string wrap_text(const std::string& text, std::size_t first_width, std::size_t width, std::size_t indent) {
  std::string out, line;
  std::size_t limit = first_width;
  std::istringstream words(text);
  for (std::string word; words >> word;) {
    if (!line.empty() && columns(line) + 1 + columns(word) > limit) {
      out += line + "\n" + std::string(indent, ' ');
      line.clear();
      limit = width - indent;
    }
    line += (line.empty() ? "" : " ") + word;
  }
  return out + line;
}

HelpFormatter::HelpFormatter() { column_width(kLeftColumn); }

std::string HelpFormatter::make_option_opts(const CLI::Option* opt) const {
  if (opt->get_type_size() == 0) return "";  // a flag
  std::string type = opt->get_type_name();
  type = type.substr(0, type.find(':'));  // the validators' own descriptions repeat the text's
  std::string out = type.empty() ? "" : " " + type;
  if (!opt->get_default_str().empty()) out += "=" + opt->get_default_str();
  if (opt->get_required()) out += " (required)";
  return out;
}

std::string HelpFormatter::make_option(const CLI::Option* opt, bool is_positional) const {
  const std::string left = "  " + make_option_name(opt, is_positional) + make_option_opts(opt);
  const std::string desc = make_option_desc(opt);
  const std::size_t width = columns(left);
  if (width + 2 <= kLeftColumn)
    return left + std::string(kLeftColumn - width, ' ') +
           wrap_text(desc, kHelpColumns - kLeftColumn, kHelpColumns, kLeftColumn) + "\n";
  return left + "\n" + std::string(kLeftColumn, ' ') +
         wrap_text(desc, kHelpColumns - kLeftColumn, kHelpColumns, kLeftColumn) + "\n";
}

std::string HelpFormatter::make_group(std::string group, bool is_positional,
                                      std::vector<const CLI::Option*> opts) const {
  // One blank line before each group: make_groups puts a line break between two groups, so
  // a group's last line break is left to it (the positionals, printed alone, keep theirs).
  std::string out = "\n" + group + ":\n";
  for (const CLI::Option* opt : opts) out += make_option(opt, is_positional);
  if (!is_positional && !out.empty()) out.pop_back();
  return out;
}

std::string HelpFormatter::make_description(const CLI::App* app) const {
  const std::string text = app->get_description();
  return text.empty() ? "" : wrap_text(text, kHelpColumns, kHelpColumns, 0) + "\n";
}

std::string HelpFormatter::make_footer(const CLI::App* app) const {
  const std::string footer = app->get_footer();
  return footer.empty() ? "" : "\n" + footer + "\n";  // written to the width already (examples keep their lines)
}

}  // namespace meniscus::cli
