// meniscus CLI — `meniscus surface` of one frame, and what the sequence runner shares with it.
#include "surface.hpp"

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <chrono>

#include "cli.hpp"
#include "help.hpp"
#include "common/clock.hpp"
#include "io/vdb_export.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/messages.hpp"
#include "meniscus/render.hpp"
#include "post/available.hpp"
#include "mpi_surface.hpp"
#include "progress.hpp"

namespace meniscus::cli {

namespace {

/// The most frames surfaced at once: each holds a frame's memory, and --max-memory is shared.
constexpr int kMaxJobs = 256;

/// "1 thread", "2 threads"; "1 vertex", "2 vertices".
std::string count_of(std::size_t n, std::string_view one, std::string_view many) {
  return fmt::format("{} {}", n, n == 1 ? one : many);
}

void print_summary(const FrameFiles& f, const Result& result, const std::optional<UpAxis>& preview_up) {
  for (const std::string& w : result.stats.warnings) print_warning(w);
  const Stats& s = result.stats;
  std::string stages;
  const SmoothingStats& sm = s.smoothing;
  for (const StageTime& t : s.stages) {
    stages += fmt::format("{}{} {:.3f} s", stages.empty() ? "" : ", ", t.name, t.seconds);
    if (t.name == "smooth" && sm.a_sweeps_seconds + sm.b_sweeps_seconds > 0)  // the CPU's split
      stages += fmt::format(" (set-up {:.3f} s, Laplacian sweeps {:.3f} s, bilaplacian sweeps {:.3f} s)",
                            sm.setup_seconds, sm.a_sweeps_seconds, sm.b_sweeps_seconds);
  }
  fmt::print(stderr, "{} → {}, {} in {:.3f} s on {}, peak memory {}\n", count_of(s.particles, "particle", "particles"),
             count_of(s.vertices, "vertex", "vertices"), count_of(s.triangles, "triangle", "triangles"), s.total_seconds(),
             s.backend == "cuda" ? std::string("the CUDA device")
                                 : count_of(std::size_t(s.threads), "thread", "threads") +
                                       (s.threads_from == "--threads" ? "" : " (" + s.threads_from + ")"),
             human_bytes(double(s.peak_memory_bytes)));
  if (s.genus >= 0)
    fmt::print(stderr, "  {}, genus {} (holes and tunnels through the surface){}\n",
               count_of(s.components, "piece", "pieces"), s.genus,
               s.closed_handles > 0 ? fmt::format("; {} closed", count_of(s.closed_handles, "handle", "handles")) : "");
  fmt::print(stderr, "{}\n", wrap_text("time per stage: " + stages, kHelpColumns - 2, kHelpColumns, 4).insert(0, "  "));
  fmt::print(stderr, "wrote {}{}{}{}\n", printable(f.output), f.preview.empty() ? "" : ", " + printable(f.preview),
             f.stats.empty() ? "" : ", " + printable(f.stats), f.field.empty() ? "" : ", " + printable(f.field));
  if (preview_up)
    fmt::print(stderr, "the preview's up axis: {} ({})\n", preview_up->name(),
               preview_up->reason == "--up" ? "--up" : preview_up->reason + "; --up sets it");
}

/// One frame over the ranks of an MPI job (mpirun, srun --mpi=pmix): docs/cluster.md.
int run_surface_ranks(const MpiSession& mpi, const SurfaceArgs& a) {
  if (parse_frame_pattern(a.input))
    throw InvalidParameter("a sequence under an MPI launcher: surface its frames as a job array (docs/cluster.md); "
                           "MPI spreads one frame over the ranks");
  if (!a.preview_path.empty() || !a.field_path.empty())
    throw InvalidParameter("--preview and --save-field are not available over MPI ranks: render the mesh afterwards "
                           "(meniscus render)");
  if (!a.params.clip_box.empty() || a.params.decimate > 0)
    throw InvalidParameter("--clip-box and --decimate work on the whole mesh and are not available over MPI ranks: "
                           "surface in one process to use them");
  // The gather puts the mesh in one process's order from the CPU extraction's vertex keys and the
  // reorder's triangle order (meniscus/distributed.hpp: reconstruct_ordered).
  if (!a.pieces && a.params.backend == Backend::cuda)
    throw InvalidParameter("--backend cuda is not available over MPI ranks, whose mesh is one CPU process's bit for "
                           "bit: use --backend cpu or auto (the ranks surface on the CPU), or --pieces");
  if (!a.pieces && a.params.steps_a + a.params.steps_b + a.params.steps_free == 0)
    throw InvalidParameter("no smoothing sweep (--steps-a, --steps-b and --steps-free all 0, or --smoothness 0) is not "
                           "available over MPI ranks: without a sweep the triangles keep the extraction's block order, "
                           "which the ranks' pieces cannot be gathered in; run at least one sweep, use --pieces, or "
                           "surface in one process");
  if (!a.pieces && a.params.erode > 0)
    throw InvalidParameter("--erode is not available over MPI ranks: each rank would move its vertices along normals "
                           "summed in its slab's triangle order, which rounds differently from one process's at a few "
                           "vertices; use --pieces, or surface in one process");
  if (a.pieces && !a.output.ends_with(".pvtp"))
    throw InvalidParameter(fmt::format("--pieces: the output '{}' must be the .pvtp index of the pieces (big.pvtp → "
                                       "big_0.vtp, big_1.vtp …)", printable(a.output)));
  std::vector<RunFile> files = {{a.input, "the input", false}, {a.config_path, "--config", false},
                                {a.output, "-o", true}, {a.stats_path, "--stats", true}};
  if (a.pieces)
    for (int rank = 0; rank < mpi.size(); ++rank) files.push_back({piece_path(a.output, rank), "a piece", true});
  check_run_files(files);
  MpiJob job{a.input, a.output, a.stats_path, a.params, read_options(a), a.quiet || mpi.rank() != 0, a.pieces};
  if (!a.stats_path.empty()) make_parent_dirs(a.stats_path);
  make_parent_dirs(a.output);
  return run_surface_mpi(mpi, job);
}

}  // namespace

CLI::App* add_surface_command(CLI::App& app, SurfaceArgs& a) {
  CLI::App* cmd = app.add_subcommand("surface", "surface a particle file (or a sequence of them) into a triangle mesh");
  // The help's groups come in the order of their first option: what an artist reaches for first.
  const std::string common = "Common options";
  cmd->set_help_flag("-h,--help", "print this help and exit")->group(common);
  cmd->add_option("input", a.input,
                  "particle file, or a sequence pattern with a frame placeholder: fluid_####.ply, fluid_{}.ply, "
                  "fluid_%04d.ply")
      ->required()->type_name("FILE");
  cmd->add_option("-o,--output", a.output, "mesh file to write (with a frame placeholder for a sequence)")
      ->required()->type_name("FILE")->group(common);
  a.options.add_to(*cmd, {"preset", "smoothness", "detail", "transfer"}, common);
  cmd->add_option("--preview", a.preview_path, "also render a shaded preview picture (.png)")->type_name("FILE")
      ->group(common);
  cmd->add_option("--up", a.up,
                  "up axis of the preview's camera; auto: y for Houdini files, else the way gravity shows in the "
                  "particles' velocities and heights, else z")
      ->check(CLI::IsMember({"auto", "x", "y", "z"}))->type_name("auto|x|y|z")->capture_default_str()->group(common);
  cmd->add_option("--stats", a.stats_path, "write counts, stage times and the parameters used as JSON")
      ->type_name("FILE")->group(common);
  cmd->add_flag("-q,--quiet", a.quiet, "no progress bar and no summary")->group(common);
  const std::string files = "Files";
  cmd->add_option("--save-field", a.field_path, "also write the distance field as an OpenVDB level set (.vdb)")
      ->type_name("FILE")->group(files);
  cmd->add_option("--columns", a.columns, "column names of headerless text particles (e.g. x,y,z,vx,vy,vz,rho)")
      ->delimiter(',')->type_name("NAME,…")->group(files);
  cmd->add_flag("--drop-invalid", a.drop_invalid, "drop particles with NaN/Inf coordinates instead of failing")
      ->group(files);
  cmd->add_option("--config", a.config_path, "JSON file of parameters (or a --stats file to replay); options given win")
      ->type_name("FILE")->group(files);
  const std::string sequence = "Sequences";
  cmd->add_option("--frames", a.frames, "frames of a sequence: 1-240, 1-240:2, 1,5,10-20 (default: every file found)")
      ->type_name("RANGES")->group(sequence);
  cmd->add_option("--jobs", a.jobs, fmt::format("frames of a sequence surfaced at once, 1 to {} (they share "
                                                "--max-memory)", kMaxJobs))
      ->type_name("INT")->capture_default_str()->group(sequence);
  cmd->add_flag("--fail-fast", a.fail_fast, "stop a sequence at the first frame that fails")->group(sequence);
  cmd->add_flag("--skip-existing", a.skip_existing,
                "leave out the frames whose mesh exists (a resubmitted job redoes only what failed)")
      ->group(sequence);
  cmd->add_option("--estimates-from", a.estimates_from,
                  "the frame the spacing, rest density and reference speed are estimated on when not given "
                  "(default: the first of --frames; a job array's tasks all name the sequence's first)")
      ->type_name("FRAME")->group(sequence);
  cmd->add_flag("--pieces", a.pieces,
                "over MPI ranks, -o X.pvtp: each rank writes its piece X_<rank>.vtp and rank 0 the ParaView index "
                "(meniscus merge X.pvtp -o X.ply welds them)")
      ->group(sequence);
  a.options.add_to(*cmd);
  cmd->footer(
      "Examples:\n"
      "  meniscus surface fluid.ply -o fluid_mesh.ply --preview fluid.png\n"
      "  meniscus surface 'sim/fluid_####.bgeo.sc' -o 'mesh/fluid_####.bgeo.sc' --frames 1-240 \\\n"
      "      --spacing 0.05 --preset droplets --transfer v --jobs 2\n"
      "Every option with its range and default, presets and config files: docs/cli.md");
  return cmd;
}

ReadOptions read_options(const SurfaceArgs& a, double memory_share) {
  ReadOptions o;
  o.drop_invalid = a.drop_invalid;
  o.columns = a.columns;
  o.max_memory_gb = memory_limit_bytes(a.params.max_memory_gb) * memory_share / 1e9;
  return o;
}

void add_frame_files(std::vector<RunFile>& files, const FrameFiles& f) {
  files.push_back({f.input, "the input", false});
  files.push_back({f.output, "-o", true});
  files.push_back({f.stats, "--stats", true});
  files.push_back({f.preview, "--preview", true});
  files.push_back({f.field, "--save-field", true});
  files.push_back({f.previous, "the previous frame", false});
  files.push_back({f.next, "the next frame", false});
}

UpAxis preview_up_axis(const SurfaceArgs& a, const ParticleSet& particles, std::string_view format) {
  if (a.up != "auto") return {a.up[0] - 'x', "--up"};
  const Attribute* velocity = particles.find("velocity");
  if (velocity == nullptr) velocity = particles.find("v");
  return guess_up_axis(particles.positions, velocity, format);
}

Result surface_one(const SurfaceArgs& a, const FrameFiles& f, bool verbose, const ProgressFn& progress,
                   std::optional<ReadFrame> preread, UpAxis* preview_up) {
  const auto t0 = std::chrono::steady_clock::now();
  ReadReport report;
  ParticleSet particles = preread ? std::move(preread->particles) : read_particles(f.input, read_options(a), &report);
  if (preread) report.format = preread->format;
  const double read_seconds = preread ? preread->seconds : seconds_since(t0);
  if (verbose) {
    fmt::print(stderr, "read {} particles from {} ({})\n", particles.size(), printable(f.input), report.format);
    if (report.dropped_invalid) fmt::print(stderr, "dropped {} particles with NaN/Inf coordinates\n", report.dropped_invalid);
  }
  // A single frame's frame-wide estimates are made here, before the work, so that the spacing
  // is told before the progress bar starts (a sequence's come from its first frame: a.params).
  Params params = a.params;
  double estimate_seconds = 0;
  if (a.estimated_on.empty()) {
    const auto te = std::chrono::steady_clock::now();
    params = resolve_frame_estimates(particles, a.params);
    estimate_seconds = seconds_since(te);
    if (verbose && a.params.spacing == 0)
      fmt::print(stderr, "estimated particle spacing {:.6g} (from the particle distances and density; --spacing sets it)\n",
                 params.spacing);
  }
  // A sequence's frame: its particles smoothed in time with the frames either side, the shift
  // at most r_inner / 2 (the limit's r_inner is the frame's as resolved).
  TemporalReport temporal;
  double temporal_seconds = -1;
  if (params.temporal_smoothing > 0 && (!f.previous.empty() || !f.next.empty() || !f.no_neighbours.empty())) {
    if (!f.no_neighbours.empty()) {
      temporal.skipped = f.no_neighbours;
    } else if (particles.find(kParticleIdAttribute) == nullptr) {  // not worth reading the neighbours
      temporal.skipped = fmt::format("no '{}' attribute in the current frame", kParticleIdAttribute);
    } else {
      // A neighbour that does not read leaves the frame its own positions (in every chunk alike).
      const auto tt = std::chrono::steady_clock::now();
      ParticleSet before, after;
      try {
        before = read_particles(f.previous, read_options(a));
        after = read_particles(f.next, read_options(a));
      } catch (const std::exception& e) {
        temporal.skipped = fmt::format("a neighbouring frame does not read ({})",
                                       dynamic_cast<const std::bad_alloc*>(&e) ? "out of memory" : e.what());
      }
      if (temporal.skipped.empty()) {
        const double limit = 0.5 * resolve_params(particles, params).r_inner;
        particles.positions = temporal_smoothing(before, particles, after, params.temporal_smoothing, limit, &temporal);
      }
      temporal_seconds = seconds_since(tt);
    }
  }
  Result result = reconstruct(particles, params, progress);
  result.stats.temporal = temporal;
  if (temporal_seconds >= 0) result.stats.stages.insert(result.stats.stages.begin(), StageTime{"temporal", temporal_seconds});
  result.stats.stages.insert(result.stats.stages.begin(), StageTime{"read", read_seconds});
  if (!a.estimated_on.empty()) {  // a sequence's frame: the estimates come from its first frame
    result.stats.spacing_estimated = true;
    result.stats.estimated_on = a.estimated_on;
  } else {
    result.stats.spacing_estimated = a.params.spacing == 0;
    for (StageTime& t : result.stats.stages)
      if (t.name == "parameters") t.seconds += estimate_seconds;
  }

  for (const std::string* out : {&f.output, &f.preview, &f.stats, &f.field})
    if (!out->empty()) make_parent_dirs(*out);
  const auto t1 = std::chrono::steady_clock::now();
  write_mesh(f.output, result.mesh);
  result.stats.stages.push_back({"write", seconds_since(t1)});
  if (!f.preview.empty()) {
    const auto t2 = std::chrono::steady_clock::now();
    RenderOptions view;
    const UpAxis up = preview_up_axis(a, particles, report.format);
    view.up = up.direction();
    if (preview_up) *preview_up = up;
    write_png(f.preview, render_mesh(result.mesh, view));
    result.stats.stages.push_back({"preview", seconds_since(t2)});
  }
  if (!f.field.empty()) {
    const auto t3 = std::chrono::steady_clock::now();
    write_field_vdb(f.field, particles, result.params);
    result.stats.stages.push_back({"save_field", seconds_since(t3)});
  }
  if (!f.stats.empty()) write_text_file(f.stats, stats_to_json(result) + "\n");
  return result;
}

int run_surface(const CLI::App& cmd, SurfaceArgs& a, const MpiSession& mpi) {
  a.params = run_parameters(cmd, a.options, a.config_path);
  if (cmd.count("--detail") && cmd.count("--voxel-size") && !a.quiet)
    print_warning(fmt::format("--detail is ignored: --voxel-size {:g} is given", a.params.voxel_size));
  if (a.jobs < 1 || a.jobs > kMaxJobs)
    throw InvalidParameter(fmt::format("--jobs {}: must be a whole number from 1 to {}", a.jobs, kMaxJobs));
  if (a.pieces && !mpi.active())
    throw InvalidParameter("--pieces: one piece per MPI rank; run under mpirun or srun --mpi=pmix (docs/cluster.md)");
  if (!a.pieces) check_output_format(a.output);  // refuse an unknown format before any work is done
  if (!a.preview_path.empty() && !a.preview_path.ends_with(".png") && !a.preview_path.ends_with(".PNG"))
    throw InvalidParameter(fmt::format("--preview '{}': previews are PNG pictures (name it .png)", printable(a.preview_path)));
  if (!a.field_path.empty() && !has_openvdb())
    throw InvalidParameter("--save-field: this meniscus was built without OpenVDB (install libopenvdb-dev and rebuild)");
  // What an optional dependency does, refused before the particles are read.
  check_post_processing_available(a.params);
  if (mpi.active()) return run_surface_ranks(mpi, a);
  if (launched_ranks() > 1)
    throw InvalidParameter(fmt::format("started by an MPI launcher as one of {} processes, but this meniscus was built "
                                       "without MPI: each would surface the whole frame (install libopenmpi-dev and "
                                       "rebuild, or run one process)",
                                       launched_ranks()));
  if (const auto pattern = parse_frame_pattern(a.input)) return run_sequence(a, *pattern);
  if (!a.frames.empty()) throw InvalidParameter("--frames needs an input pattern with a frame placeholder (####, {} or %04d)");

  const FrameFiles f{a.input, a.output, a.stats_path, a.preview_path, a.field_path};
  std::vector<RunFile> files = {{a.config_path, "--config", false}};
  add_frame_files(files, f);
  check_run_files(files);
  ProgressBar bar(!a.quiet);
  UpAxis preview_up;
  const Result result = surface_one(
      a, f, !a.quiet, [&](std::string_view stage, double fraction) { bar.update(stage, fraction); }, std::nullopt,
      &preview_up);
  bar.finish();
  if (!a.quiet) print_summary(f, result, f.preview.empty() ? std::nullopt : std::optional<UpAxis>(preview_up));
  return kExitOk;
}

}  // namespace meniscus::cli
