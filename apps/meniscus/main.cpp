// meniscus — the command-line front end: the subcommands (one file each), how their errors are
// reported and the exit codes (docs/cli.md "Exit codes").
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <exception>
#include <memory>
#include <new>
#include <string>
#include <vector>

#include "cli.hpp"
#include "help.hpp"
#include "info.hpp"
#include "inspect.hpp"
#include "io/atomic_file.hpp"
#include "merge.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/memory.hpp"
#include "meniscus/messages.hpp"
#include "meniscus/reconstruct.hpp"
#include "mpi_surface.hpp"
#include "render.hpp"
#include "surface.hpp"

namespace {

using namespace meniscus;
using namespace meniscus::cli;

void print_error(std::string_view message) { fmt::print(stderr, "meniscus: error: {}\n", printable(message)); }

/// The long options of a subcommand, "--name".
std::vector<std::string> long_options(const CLI::App& cmd) {
  std::vector<std::string> names;
  for (const CLI::Option* o : cmd.get_options())
    for (const std::string& name : o->get_lnames()) names.push_back("--" + name);
  return names;
}

/// A parse error as a person reads it: a misspelt subcommand or option gets the nearest name.
int report_parse_error(CLI::App& app, const CLI::ParseError& e, int argc, char** argv) {
  std::vector<std::string> commands;
  for (const CLI::App* sub : app.get_subcommands({})) commands.push_back(sub->get_name());
  const CLI::App* active = nullptr;
  for (const CLI::App* sub : app.get_subcommands({}))
    if (sub->parsed()) active = sub;
  if (active == nullptr && argc > 1 && argv[1][0] != '-') {
    const std::string close = closest_name(argv[1], commands);
    print_error(fmt::format("unknown command '{}'{} (commands: {})", argv[1],
                            close.empty() ? "" : fmt::format(" — did you mean '{}'?", close), fmt::join(commands, ", ")));
    return kExitUsage;
  }
  if (active != nullptr && dynamic_cast<const CLI::ExtrasError*>(&e) != nullptr) {
    const std::vector<std::string> options = long_options(*active);
    for (const std::string& extra : active->remaining()) {
      if (!extra.starts_with("-")) continue;
      const std::string close = closest_name(extra.substr(0, extra.find('=')), options);
      print_error(fmt::format("unknown option '{}' for '{}'{} (meniscus {} --help lists them)", extra,
                              active->get_name(), close.empty() ? "" : fmt::format(" — did you mean '{}'?", close),
                              active->get_name()));
      return kExitUsage;
    }
  }
  // --help and --version print what they ask for; every other parse error is one message with
  // the prefix and its quoted arguments escaped (a file name picked up by a glob may hold ESC).
  if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e) == 0 ? kExitOk : kExitUsage;
  const CLI::App* help_of = active != nullptr ? active : &app;
  print_error(fmt::format("{} (meniscus{}{} --help lists the options)", e.what(), help_of == &app ? "" : " ",
                          help_of == &app ? "" : help_of->get_name()));
  return kExitUsage;
}

}  // namespace

int main(int argc, char** argv) {
  const MpiSession mpi(&argc, &argv);  // MPI_Init where an MPI launcher started us
  const bool quiet_rank = mpi.active() && mpi.rank() != 0;  // messages come from rank 0
  set_message_spelling(Spelling::cli);
  io::remove_temporaries_on_signals();  // Ctrl-C or a scheduler's SIGTERM leaves no temporary file
  release_large_blocks_eagerly();  // a lower peak: freed stage arrays leave the process
  reuse_freed_blocks_between_stages();  // except up to the smoothing, where they serve the next stage
  CLI::App app{"meniscus — smooth, watertight meshes from fluid particles (Williams' constrained smoothing)"};
  app.formatter(std::make_shared<HelpFormatter>());  // before the subcommands, which take it over
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string(version()));
  SurfaceArgs surface;
  CLI::App* surface_cmd = add_surface_command(app, surface);
  RenderArgs render;
  CLI::App* render_cmd = add_render_command(app, render);
  InspectArgs inspect;
  CLI::App* inspect_cmd = add_inspect_command(app, inspect);
  MergeArgs merge;
  CLI::App* merge_cmd = add_merge_command(app, merge);
  InfoArgs info;
  CLI::App* info_cmd = add_info_command(app, info);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return report_parse_error(app, e, argc, argv);
  }
  try {
    if (surface_cmd->parsed()) return run_surface(*surface_cmd, surface, mpi);
    if (render_cmd->parsed()) return run_render(render);
    if (inspect_cmd->parsed()) return run_inspect(inspect);
    if (merge_cmd->parsed()) return run_merge(merge);
    if (info_cmd->parsed()) return run_info(info);
  } catch (const InvalidParameter& e) {
    if (!quiet_rank) print_error(e.what());
    return kExitUsage;
  } catch (const std::bad_alloc&) {
    if (!quiet_rank)
      print_error("out of memory: the system refused an allocation (give the job more memory, lower --max-memory so "
                  "that meniscus refuses such work up front, or use a larger --voxel-size)");
    return kExitFailed;
  } catch (const std::exception& e) {
    if (!quiet_rank) print_error(e.what());
    return kExitFailed;
  }
  return kExitOk;
}
