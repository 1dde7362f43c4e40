// meniscus CLI — `meniscus inspect`: the quality metrics of a mesh or of a sequence of meshes.
#pragma once

#include <string>

namespace CLI {
class App;
}

namespace meniscus::cli {

struct InspectArgs {
  std::string mesh, particles, previous, frames;
  double r_inner = 0, r_outer = 0, spacing = 0, flicker_cap = -1;
  bool json = false, flicker = false;
};

CLI::App* add_inspect_command(CLI::App& app, InspectArgs& a);
int run_inspect(const InspectArgs& a);

}  // namespace meniscus::cli
