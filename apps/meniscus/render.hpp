// meniscus CLI — `meniscus render`: a preview picture (.png) of a mesh or a mesh sequence.
#pragma once

#include <string>

namespace CLI {
class App;
}

namespace meniscus::cli {

struct RenderArgs {
  std::string mesh, output, particles, color_by, range, size = "960x720", up = "auto", frames;
  float yaw = 35, pitch = 30;
  int turntable = 1;
  double max_memory_gb = 0;
  bool quiet = false;
};

CLI::App* add_render_command(CLI::App& app, RenderArgs& a);
int run_render(const RenderArgs& a);

}  // namespace meniscus::cli
