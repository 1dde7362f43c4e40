// meniscus — command-line front end: `meniscus surface`, `meniscus info`.
#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <tbb/info.h>

#include <chrono>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

#include "io/atomic_file.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "meniscus/reconstruct.hpp"
#include "meniscus/render.hpp"
#include "progress.hpp"

namespace {

using namespace meniscus;

constexpr int kExitRuntime = 1;
constexpr int kExitUsage = 2;

struct SurfaceArgs {
  std::string input, output, stats_path, preview_path, extract = "tiles", solver = "gauss-seidel", up = "z";
  bool quiet = false, drop_invalid = false;
  Params params;
};

void add_surface_options(CLI::App& cmd, SurfaceArgs& a) {
  Params& p = a.params;
  cmd.add_option("input", a.input, "particle file (.ply, .xyz)")->required();
  cmd.add_option("-o,--output", a.output, "mesh file to write (.ply)")->required();
  cmd.add_option("--spacing", p.spacing, "particle separation d (default: estimated from the particles, see README)")
      ->check(CLI::PositiveNumber);
  cmd.add_option("--voxel-size", p.voxel_size, "field resolution h (default d/2)")->check(CLI::PositiveNumber);
  cmd.add_option("--r-outer", p.r_outer, "initial surface radius around each particle (default 1.0 d)")
      ->check(CLI::PositiveNumber);
  cmd.add_option("--r-inner", p.r_inner, "vertices stay at least this far from particles (default 0.5 r_outer)")
      ->check(CLI::PositiveNumber);
  cmd.add_option("--steps-a", p.steps_a, "constrained graph-Laplacian sweeps")->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd.add_option("--steps-b", p.steps_b, "constrained bilaplacian sweeps")->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd.add_option("--steps-free", p.steps_free, "unconstrained bilaplacian sweeps at the end")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  cmd.add_option("--relax", p.relax, "damping ω of the A sweeps, in (0, 1]")->capture_default_str();
  cmd.add_option("--relax-b", p.relax_b, "initial damping of the B sweeps, in (0, 2)")->capture_default_str();
  cmd.add_option("--solver", a.solver, "sweep type: gauss-seidel (coloured, in place) or jacobi")
      ->check(CLI::IsMember({"gauss-seidel", "jacobi"}))->capture_default_str();
  cmd.add_option("--rebuild-b", p.rebuild_b, "rebuild the B operator every k sweeps (0: once)")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  cmd.add_option("--extract", a.extract, "extractor: tiles (Marching Tiles), cubes, tetrahedra")
      ->check(CLI::IsMember({"tiles", "cubes", "tetrahedra"}))->capture_default_str();
  cmd.add_option("--erode", p.erode, "move the surface inwards by this distance")->check(CLI::NonNegativeNumber);
  cmd.add_option("--transfer", p.transfer, "particle attributes to carry onto the vertices (comma separated)")
      ->delimiter(',');
  cmd.add_option("--transfer-radius", p.transfer_radius, "radius of the attribute transfer kernel (default 2 d)")
      ->check(CLI::PositiveNumber);
  cmd.add_option("--threads", p.threads, "worker threads (default: all cores)")->check(CLI::NonNegativeNumber);
  cmd.add_option("--max-memory", p.max_memory_gb, "refuse jobs estimated above this many GB (default 90 % of RAM)")
      ->check(CLI::PositiveNumber);
  cmd.add_option("--stats", a.stats_path, "write counts, stage times and the parameters used as JSON");
  cmd.add_option("--preview", a.preview_path, "also render a shaded preview picture (.png)");
  cmd.add_option("--up", a.up, "up axis of the preview's camera (SPlisHSPlasH and Houdini scenes are y-up)")
      ->check(CLI::IsMember({"x", "y", "z"}))->capture_default_str();
  cmd.add_flag("--keep-voids", p.keep_voids, "keep interior voids smaller than (2 d)³ (removed by default)");
  cmd.add_flag("--drop-invalid", a.drop_invalid, "drop particles with NaN/Inf coordinates instead of failing");
  cmd.add_flag("-q,--quiet", a.quiet, "no progress bar and no summary");
}

/// Creates the directories an output file goes into (like a renderer's output path).
void make_parent_dirs(const std::string& path) {
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  if (parent.empty()) return;
  std::error_code ec;
  std::filesystem::create_directories(parent, ec);
  if (ec) throw IoError(fmt::format("{}: cannot create directory {}: {}", path, parent.string(), ec.message()));
}

void write_text_file(const std::string& path, const std::string& text) {
  io::AtomicFile file(path);
  file.write(text.data(), text.size());
  file.commit();
}

int run_surface(SurfaceArgs& a) {
  a.params.extract = parse_extractor(a.extract);
  a.params.solver = parse_solver(a.solver);
  a.params.validate();
  // Refuse an unknown output format before any work is done.
  {
    bool known = false;
    for (const std::string& ext : mesh_formats())
      if (a.output.size() >= ext.size() && a.output.compare(a.output.size() - ext.size(), ext.size(), ext) == 0)
        known = true;
    if (!known) throw InvalidParameter(fmt::format("output '{}': unknown mesh format (supported: {})", a.output,
                                                   fmt::join(mesh_formats(), ", ")));
  }
  const auto t0 = std::chrono::steady_clock::now();
  ReadOptions read_options;
  read_options.drop_invalid = a.drop_invalid;
  ReadReport report;
  const ParticleSet particles = read_particles(a.input, read_options, &report);
  const double read_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!a.quiet) {
    fmt::print(stderr, "read {} particles from {} ({})\n", particles.size(), a.input, report.format);
    if (report.dropped_invalid) fmt::print(stderr, "dropped {} particles with NaN/Inf coordinates\n", report.dropped_invalid);
  }

  cli::ProgressBar bar(!a.quiet);
  Result result = reconstruct(particles, a.params, [&](std::string_view stage, double f) { bar.update(stage, f); });
  bar.finish();
  if (!a.quiet && a.params.spacing == 0)
    fmt::print(stderr, "estimated particle spacing {:.6g} (from the particle distances and density; set --spacing to override)\n",
               result.params.spacing);

  for (const std::string* out : {&a.output, &a.preview_path, &a.stats_path})
    if (!out->empty()) make_parent_dirs(*out);
  const auto t1 = std::chrono::steady_clock::now();
  write_mesh(a.output, result.mesh);
  result.stats.stages.insert(result.stats.stages.begin(), StageTime{"read", read_seconds});
  result.stats.stages.push_back(
      {"write", std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count()});
  if (!a.preview_path.empty()) {
    const auto t2 = std::chrono::steady_clock::now();
    RenderOptions view;
    view.up = a.up == "x" ? Vec3f{1, 0, 0} : (a.up == "y" ? Vec3f{0, 1, 0} : Vec3f{0, 0, 1});
    write_png(a.preview_path, render_mesh(result.mesh, view));
    result.stats.stages.push_back(
        {"preview", std::chrono::duration<double>(std::chrono::steady_clock::now() - t2).count()});
  }
  if (!a.stats_path.empty()) write_text_file(a.stats_path, stats_to_json(result) + "\n");

  if (!a.quiet) {
    for (const std::string& w : result.stats.warnings) fmt::print(stderr, "warning: {}\n", w);
    const Stats& s = result.stats;
    std::string stages;
    for (const StageTime& t : s.stages) stages += fmt::format("{}{} {:.3f}s", stages.empty() ? "" : ", ", t.name, t.seconds);
    fmt::print(stderr, "{} particles → {} vertices, {} triangles in {:.3f}s on {} threads, peak memory {:.0f} MB\n",
               s.particles, s.vertices, s.triangles, s.total_seconds(), s.threads, double(s.peak_memory_bytes) / 1e6);
    fmt::print(stderr, "  {}\n", stages);
    fmt::print(stderr, "wrote {}{}{}\n", a.output, a.preview_path.empty() ? "" : ", " + a.preview_path,
               a.stats_path.empty() ? "" : ", " + a.stats_path);
  }
  return 0;
}

int run_info() {
  fmt::print("meniscus {}\n", version());
  fmt::print("backends: cpu (oneTBB, {} threads)\n", tbb::info::default_concurrency());
  fmt::print("cuda: not built\n");
  fmt::print("particle formats: {}\n", fmt::join(particle_formats(), " "));
  fmt::print("mesh formats: {}\n", fmt::join(mesh_formats(), " "));
  fmt::print("extractors: tiles cubes tetrahedra\n");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"meniscus — smooth, watertight meshes from fluid particles (Williams' constrained smoothing)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string(meniscus::version()));
  SurfaceArgs surface;
  CLI::App* surface_cmd = app.add_subcommand("surface", "surface a particle file into a triangle mesh");
  add_surface_options(*surface_cmd, surface);
  CLI::App* info_cmd = app.add_subcommand("info", "version, backends, threads and formats");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    if (surface_cmd->parsed()) return run_surface(surface);
    if (info_cmd->parsed()) return run_info();
  } catch (const meniscus::InvalidParameter& e) {
    fmt::print(stderr, "meniscus: error: {}\n", e.what());
    return kExitUsage;
  } catch (const std::exception& e) {
    fmt::print(stderr, "meniscus: error: {}\n", e.what());
    return kExitRuntime;
  }
  return 0;
}
