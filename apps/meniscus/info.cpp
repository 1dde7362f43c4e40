// meniscus CLI — `meniscus info`: the version, the backends, the formats; the parameter table.
#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <tbb/info.h>

#include "cli.hpp"
#include "io/vdb_export.hpp"
#include "info.hpp"
#include "meniscus/backend.hpp"
#include "meniscus/io.hpp"
#include "meniscus/parameters.hpp"
#include "meniscus/reconstruct.hpp"
#include "mpi_surface.hpp"
#include "post/clip.hpp"

namespace meniscus::cli {

CLI::App* add_info_command(CLI::App& app, InfoArgs& info) {
  CLI::App* cmd = app.add_subcommand("info", "version, backends, threads and formats");
  cmd->add_flag("--parameters", info.parameters,
                "print the table of parameters as JSON: names, options, types, ranges, defaults, help");
  return cmd;
}

int run_info(const InfoArgs& a) {
  if (a.parameters) {
    fmt::print("{}\n", parameter_table_json().dump(2));
    return kExitOk;
  }
  fmt::print("meniscus {}\n", version());
  fmt::print("backends: cpu (oneTBB, {} threads)\n", tbb::info::default_concurrency());
  std::string why_no_cuda;
  const std::vector<CudaDeviceInfo> devices = cuda_devices(&why_no_cuda);
  if (devices.empty()) fmt::print("cuda: none ({})\n", why_no_cuda);
  for (const CudaDeviceInfo& d : devices) {
    if (d.emulated)
      fmt::print("cuda: device {}: EMULATED on the CPU — a test build (MENISCUS_CUDA_EMULATION): --backend cuda runs "
                 "the CUDA backend's kernels on the CPU, --backend auto does not use it\n",
                 d.index);
    else
      fmt::print("cuda: device {}: {} (compute capability {}.{}, {:.1f} GB, {:.1f} GB free)\n", d.index, d.name, d.major,
                 d.minor, double(d.total_memory) / 1e9, double(d.free_memory) / 1e9);
  }
  fmt::print("openvdb: {}\n", has_openvdb() ? "yes (--save-field writes .vdb level sets)" : "no");
  fmt::print("cgal: {}\n", clip_cap_unavailable() ? "no (--clip-cap refused)" : "yes (--clip-cap closes the cut)");
  fmt::print("mpi: {}\n", mpi_built() ? "yes (mpirun -n K meniscus surface spreads one frame over K ranks)"
                                            : "no (built without MPI)");
  fmt::print("particle formats: {}\n", fmt::join(particle_formats(), " "));
  fmt::print("mesh formats: {} (each also gzip-compressed: .bgeo.gz, .ply.gz …)\n", fmt::join(mesh_formats(), " "));
  fmt::print("extractors: tiles cubes tetrahedra\n");
  return kExitOk;
}


}  // namespace meniscus::cli
