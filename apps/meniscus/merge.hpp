// meniscus CLI — `meniscus merge`: the pieces of an MPI run welded into one mesh.
#pragma once

#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace meniscus::cli {

struct MergeArgs {
  std::vector<std::string> inputs;
  std::string output;
  bool quiet = false;
};

CLI::App* add_merge_command(CLI::App& app, MergeArgs& a);
int run_merge(const MergeArgs& a);

}  // namespace meniscus::cli
