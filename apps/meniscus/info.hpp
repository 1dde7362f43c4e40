// meniscus CLI — `meniscus info`: the version, the backends, the formats; the parameter table.
#pragma once

namespace CLI {
class App;
}

namespace meniscus::cli {

struct InfoArgs {
  bool parameters = false;
};

CLI::App* add_info_command(CLI::App& app, InfoArgs& a);
int run_info(const InfoArgs& a);

}  // namespace meniscus::cli
