// meniscus — command-line front end: `meniscus surface`, `meniscus render`, `meniscus inspect`, `meniscus info`.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <fmt/format.h>
#include <tbb/info.h>

#include <array>
#include <atomic>
#include <cmath>
#include <chrono>
#include <mutex>
#include <optional>
#include <thread>
#include <tuple>
#include <utility>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "common/clock.hpp"
#include "field/vdb_export.hpp"
#include "io/atomic_file.hpp"
#include "meniscus/backend.hpp"
#include "meniscus/config.hpp"
#include "meniscus/distributed.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "meniscus/memory.hpp"
#include "meniscus/quality.hpp"
#include "meniscus/reconstruct.hpp"
#include "meniscus/render.hpp"
#include "meniscus/sequence.hpp"
#include "mpi_surface.hpp"
#include "progress.hpp"

namespace {

using namespace meniscus;

constexpr int kExitRuntime = 1;
constexpr int kExitUsage = 2;

struct SurfaceArgs {
  std::string input, output, stats_path, preview_path, extract = "tiles", solver = "chebyshev", up = "z";
  std::string backend = "auto";
  std::string field = "distance";
  std::string frames, field_path;
  std::vector<std::string> columns;
  int jobs = 1;
  std::optional<int> estimates_from;  ///< a sequence: the frame the frame-wide estimates are made on
  bool quiet = false, drop_invalid = false, fail_fast = false, skip_existing = false, pieces = false;
  Params params;
  // Artist controls (README "Artist controls"): config file < preset < smoothness/detail < options.
  std::string config_path, preset;
  std::optional<double> smoothness, detail;
  std::string estimated_on;  ///< a sequence's frames: the frame whose estimates params holds
};

void add_surface_options(CLI::App& cmd, SurfaceArgs& a) {
  Params& p = a.params;
  cmd.add_option("input", a.input,
                 "particle file, or a sequence pattern with a frame placeholder: fluid_####.ply, fluid_{}.ply, fluid_%04d.ply")
      ->required();
  cmd.add_option("-o,--output", a.output, "mesh file to write (with a frame placeholder for a sequence)")->required();
  cmd.add_option("--frames", a.frames, "frames of a sequence: 1-240, 1-240:2, 1,5,10-20 (default: every file found)");
  cmd.add_option("--jobs", a.jobs, "frames of a sequence surfaced at once")->check(CLI::PositiveNumber)->capture_default_str();
  cmd.add_flag("--fail-fast", a.fail_fast, "stop a sequence at the first frame that fails");
  cmd.add_flag("--pieces", a.pieces,
               "over MPI ranks, -o X.pvtp: each rank writes its piece X_<rank>.vtp and rank 0 the ParaView index "
               "(meniscus merge X.pvtp -o X.ply welds them)");
  cmd.add_flag("--skip-existing", a.skip_existing,
               "a sequence: leave out the frames whose mesh exists (a resubmitted job redoes only what failed)");
  cmd.add_option("--estimates-from", a.estimates_from,
                 "a sequence: the frame the spacing, rest density and reference speed are estimated on when not "
                 "given (default: the first of --frames; a job array's tasks all name the sequence's first)");
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
  cmd.add_option("--relax", p.relax, "relaxation ω of the A sweeps, in (0, 1]; 0: 1")->capture_default_str();
  cmd.add_option("--relax-b", p.relax_b, "largest damping of the B sweeps, in (0, 1]; each vertex takes at most its stable one")
      ->capture_default_str();
  cmd.add_option("--solver", a.solver, "sweeps: chebyshev (Jacobi, the A sweeps accelerated) or jacobi (plain)")
      ->check(CLI::IsMember({"chebyshev", "jacobi", "gauss-seidel"}))->capture_default_str();
  cmd.add_option("--rebuild-b", p.rebuild_b, "rebuild the B operator every k sweeps (0: once)")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  cmd.add_option("--extract", a.extract, "extractor: tiles (Marching Tiles), cubes, tetrahedra")
      ->check(CLI::IsMember({"tiles", "cubes", "tetrahedra"}))->capture_default_str();
  cmd.add_option("--field", a.field, "field method: distance, metaball, sph, zhu-bridson, anisotropic (README: Field methods)")
      ->check(CLI::IsMember({"distance", "metaball", "sph", "zhu-bridson", "anisotropic"}))->capture_default_str();
  cmd.add_option("--iso", p.iso, "level of the field (metaball/sph/anisotropic: density threshold, default half the "
                                  "value inside the fluid; zhu-bridson: particle radius, default r_outer)")
      ->check(CLI::PositiveNumber);
  cmd.add_option("--kernel-radius", p.kernel_radius, "support radius of the field kernels (default 2 d)")
      ->check(CLI::PositiveNumber);
  cmd.add_option("--rest-density", p.rest_density,
                 "rest density ρ₀ of particles with a density but no mass (sph/anisotropic volumes d³·ρ₀/ρ; "
                 "default: the median density of the frame, or of a sequence's first frame)")
      ->check(CLI::PositiveNumber);
  cmd.add_option("--smooth-particles", p.smooth_particles,
                 "λ in [0, 1]: Laplacian smoothing of the particle positions before the field (default 0; 0.3 with "
                 "--field anisotropic)");
  cmd.add_flag("--velocity-weighted", p.velocity_weighted,
               "smooth fast (splashing) fluid less than calm fluid; needs a velocity attribute (v, vel, velocity)");
  cmd.add_option("--velocity-reference", p.velocity_reference,
                 "speed at which the smoothing reaches its minimum (default: 95th percentile of the particle speeds)")
      ->check(CLI::PositiveNumber);
  cmd.add_option("--velocity-min-weight", p.velocity_min_weight, "smallest smoothing factor of fast fluid, in (0, 1]")
      ->capture_default_str();
  cmd.add_option("--erode", p.erode, "move the surface inwards by this distance")->check(CLI::NonNegativeNumber);
  cmd.add_option("--particle-box", p.particle_box,
                 "xmin,ymin,zmin,xmax,ymax,zmax: surface only the particles inside this box (default: all)")
      ->delimiter(',')
      ->expected(6);
  cmd.add_option("--min-particles", p.min_particles,
                 "drop surface components enclosing fewer particles than this (strays, particles stuck in a wall; "
                 "default 0: keep every droplet)")
      ->check(CLI::NonNegativeNumber);
  cmd.add_option("--clip-box", p.clip_box,
                 "xmin,ymin,zmin,xmax,ymax,zmax: cut the finished surface by this box, open along the cut (the tank's "
                 "walls and floor go)")
      ->delimiter(',')
      ->expected(6);
  cmd.add_flag("--clip-cap", p.clip_cap, "close the --clip-box cut with the box's faces (the mesh stays watertight)");
  cmd.add_option("--decimate", p.decimate,
                 "simplify the mesh while it stays within this many spacings of the full one (e.g. 0.02; default 0: "
                 "keep every triangle)")
      ->check(CLI::Range(0.0, 1.0));
  cmd.add_option("--transfer", p.transfer, "particle attributes to carry onto the vertices (comma separated)")
      ->delimiter(',');
  cmd.add_option("--transfer-radius", p.transfer_radius, "radius of the attribute transfer kernel (default 2 d)")
      ->check(CLI::PositiveNumber);
  cmd.add_option("--backend", a.backend, "where to run: auto (cuda when a device is there), cpu, cuda")
      ->capture_default_str();
  cmd.add_option("--threads", p.threads, "worker threads (default: all cores)")->check(CLI::NonNegativeNumber);
  cmd.add_option("--max-memory", p.max_memory_gb, "refuse jobs estimated above this many GB (default 90 % of RAM)")
      ->check(CLI::PositiveNumber);
  cmd.add_option("--stats", a.stats_path, "write counts, stage times and the parameters used as JSON");
  cmd.add_option("--save-field", a.field_path, "also write the distance field as an OpenVDB level set (.vdb)");
  cmd.add_option("--preview", a.preview_path, "also render a shaded preview picture (.png)");
  cmd.add_option("--up", a.up, "up axis of the preview's camera (SPlisHSPlasH and Houdini scenes are y-up)")
      ->check(CLI::IsMember({"x", "y", "z"}))->capture_default_str();
  cmd.add_flag("--keep-voids", p.keep_voids, "keep interior voids smaller than (2 d)³ (removed by default)");
  cmd.add_option("--columns", a.columns, "column names of headerless text particles (e.g. x,y,z,vx,vy,vz,rho)")
      ->delimiter(',');
  cmd.add_flag("--drop-invalid", a.drop_invalid, "drop particles with NaN/Inf coordinates instead of failing");
  cmd.add_flag("-q,--quiet", a.quiet, "no progress bar and no summary");
  cmd.add_option("--config", a.config_path, "JSON file of parameters (or a --stats file to replay); options given win");
  cmd.add_option("--preset", a.preset, "preview (fast), production (the defaults) or droplets (keeps thin sheets and "
                                       "lone droplets)");
  cmd.add_option("--smoothness", a.smoothness, "0 (as extracted) .. 1 (twice the sweeps); 0.5 = the default schedule");
  cmd.add_option("--detail", a.detail, "resolution multiplier: voxel size d / (2·detail); 2 ≈ 4× the triangles");
}

/// The parameters from the artist controls, with every option given on the command line on top:
/// config file < preset < smoothness/detail < explicit options.
void apply_artist_controls(const CLI::App& cmd, SurfaceArgs& a) {
  if (a.config_path.empty() && a.preset.empty() && !a.smoothness && !a.detail) return;
  Params layered;
  if (!a.config_path.empty()) {
    try {
      layered = read_config(a.config_path);
    } catch (const std::runtime_error& e) {  // FormatError, IoError: a bad option, not bad input (exit 2)
      throw InvalidParameter(fmt::format("--config {}", e.what()));
    }
  }
  if (!a.preset.empty()) apply_preset(layered, a.preset);
  if (a.smoothness) apply_smoothness(layered, *a.smoothness);
  if (a.detail) apply_detail(layered, *a.detail);
  Params& p = a.params;
  const auto take = [&](const char* option, auto Params::*member) {
    if (cmd.count(option) == 0) p.*member = layered.*member;
  };
  take("--spacing", &Params::spacing);
  take("--voxel-size", &Params::voxel_size);
  take("--r-outer", &Params::r_outer);
  take("--r-inner", &Params::r_inner);
  take("--steps-a", &Params::steps_a);
  take("--steps-b", &Params::steps_b);
  take("--steps-free", &Params::steps_free);
  take("--relax", &Params::relax);
  take("--relax-b", &Params::relax_b);
  take("--solver", &Params::solver);
  take("--rebuild-b", &Params::rebuild_b);
  take("--extract", &Params::extract);
  take("--erode", &Params::erode);
  take("--min-particles", &Params::min_particles);
  take("--particle-box", &Params::particle_box);
  take("--clip-box", &Params::clip_box);
  take("--clip-cap", &Params::clip_cap);
  take("--decimate", &Params::decimate);
  take("--transfer", &Params::transfer);
  take("--transfer-radius", &Params::transfer_radius);
  take("--threads", &Params::threads);
  take("--max-memory", &Params::max_memory_gb);
  take("--keep-voids", &Params::keep_voids);
  take("--backend", &Params::backend);
  take("--field", &Params::field);
  take("--iso", &Params::iso);
  take("--kernel-radius", &Params::kernel_radius);
  take("--rest-density", &Params::rest_density);
  take("--smooth-particles", &Params::smooth_particles);
  take("--velocity-weighted", &Params::velocity_weighted);
  take("--velocity-reference", &Params::velocity_reference);
  take("--velocity-min-weight", &Params::velocity_min_weight);
  p.detail = layered.detail;  // no options of their own but --detail and --preset, applied above
  p.r_outer_factor = layered.r_outer_factor;
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

std::string read_text_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(fmt::format("{}: cannot open", path));
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void check_output_format(const std::string& output) {
  // Any format may be gzip-compressed: "mesh.bgeo.gz".
  const std::string name = output.size() > 3 && output.compare(output.size() - 3, 3, ".gz") == 0
                               ? output.substr(0, output.size() - 3)
                               : output;
  for (const std::string& ext : mesh_formats())
    if (name.size() >= ext.size() && name.compare(name.size() - ext.size(), ext.size(), ext) == 0) return;
  throw InvalidParameter(
      fmt::format("output '{}': unknown mesh format (supported: {})", output, fmt::join(mesh_formats(), ", ")));
}

Vec3f up_axis(const std::string& up) {
  return up == "x" ? Vec3f{1, 0, 0} : (up == "y" ? Vec3f{0, 1, 0} : Vec3f{0, 0, 1});
}

/// A growing axis-aligned box of finite points.
struct Box3 {
  Vec3f lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
  void add(Vec3f p) {
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) lo = min(lo, p), hi = max(hi, p);
  }
  bool valid() const { return lo.x <= hi.x; }
};

/// The files of one frame (or of the single job).
struct FrameFiles {
  std::string input, output, stats, preview, field;
};

ReadOptions read_options(const SurfaceArgs& a) {
  ReadOptions o;
  o.drop_invalid = a.drop_invalid;
  o.columns = a.columns;
  return o;
}

/// A frame's particles read ahead of surfacing it, and the time the read took.
struct ReadFrame {
  ParticleSet particles;
  double seconds = 0;
};

/// Reads, surfaces and writes one frame; `verbose` prints the per-frame report. `preread`: the
/// frame as it was read already (taken over).
Result surface_one(const SurfaceArgs& a, const FrameFiles& f, bool verbose, const ProgressFn& progress,
                   std::optional<ReadFrame> preread = std::nullopt) {
  const auto t0 = std::chrono::steady_clock::now();
  ReadReport report;
  const ParticleSet particles = preread ? std::move(preread->particles) : read_particles(f.input, read_options(a), &report);
  const double read_seconds = preread ? preread->seconds : seconds_since(t0);
  if (verbose) {
    fmt::print(stderr, "read {} particles from {} ({})\n", particles.size(), f.input, report.format);
    if (report.dropped_invalid) fmt::print(stderr, "dropped {} particles with NaN/Inf coordinates\n", report.dropped_invalid);
  }
  Result result = reconstruct(particles, a.params, progress);
  result.stats.stages.insert(result.stats.stages.begin(), StageTime{"read", read_seconds});
  if (!a.estimated_on.empty()) {  // a sequence's frame: the estimates come from its first frame
    result.stats.spacing_estimated = true;
    result.stats.estimated_on = a.estimated_on;
  }

  for (const std::string* out : {&f.output, &f.preview, &f.stats, &f.field})
    if (!out->empty()) make_parent_dirs(*out);
  const auto t1 = std::chrono::steady_clock::now();
  write_mesh(f.output, result.mesh);
  result.stats.stages.push_back({"write", seconds_since(t1)});
  if (!f.preview.empty()) {
    const auto t2 = std::chrono::steady_clock::now();
    RenderOptions view;
    view.up = up_axis(a.up);
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

void print_summary(const SurfaceArgs& a, const FrameFiles& f, const Result& result) {
  if (a.params.spacing == 0)
    fmt::print(stderr, "estimated particle spacing {:.6g} (from the particle distances and density; set --spacing to override)\n",
               result.params.spacing);
  for (const std::string& w : result.stats.warnings) fmt::print(stderr, "warning: {}\n", w);
  const Stats& s = result.stats;
  std::string stages;
  const SmoothingStats& sm = s.smoothing;
  for (const StageTime& t : s.stages) {
    stages += fmt::format("{}{} {:.3f}s", stages.empty() ? "" : ", ", t.name, t.seconds);
    if (t.name == "smooth" && sm.a_sweeps_seconds + sm.b_sweeps_seconds > 0)  // the CPU's split
      stages += fmt::format(" (set-up {:.3f}s, A {:.3f}s, B {:.3f}s)", sm.setup_seconds, sm.a_sweeps_seconds,
                            sm.b_sweeps_seconds);
  }
  fmt::print(stderr, "{} particles → {} vertices, {} triangles in {:.3f}s on {}, peak memory {:.0f} MB\n",
             s.particles, s.vertices, s.triangles, s.total_seconds(),
             s.backend == "cuda" ? std::string("the CUDA device")
                                 : fmt::format("{} threads{}", s.threads,
                                               s.threads_from == "--threads" ? "" : " (" + s.threads_from + ")"),
             double(s.peak_memory_bytes) / 1e6);
  fmt::print(stderr, "  {}\n", stages);
  fmt::print(stderr, "wrote {}{}{}\n", f.output, f.preview.empty() ? "" : ", " + f.preview, f.stats.empty() ? "" : ", " + f.stats);
}

/// Frame-to-frame flicker of a sequence (DESIGN §5): each surfaced frame is compared with the one
/// before it in the frame list (when both succeeded), whatever order the jobs finish in; a mesh
/// is kept only until both of its pairs are settled. Not thread-safe: callers hold a lock.
class SequenceFlicker {
 public:
  explicit SequenceFlicker(std::size_t frames) : status_(frames, kPending), flicker_(frames) {}
  /// Records frame i's result (mesh == nullptr: it failed) and its spacing; returns the frames
  /// whose flicker became known. A frame's flicker searches kFlickerCapSpacings of its spacing.
  std::vector<std::size_t> settle(std::size_t i, TriangleMesh* mesh, double spacing = 0) {
    status_[i] = mesh ? kDone : kFailed;
    if (mesh) meshes_[i] = std::move(*mesh), caps_[i] = kFlickerCapSpacings * spacing;
    std::vector<std::size_t> known;
    for (std::size_t k : {i, i + 1}) {
      if (k == 0 || k >= status_.size() || status_[k - 1] != kDone || status_[k] != kDone) continue;
      const auto t0 = std::chrono::steady_clock::now();
      flicker_[k] = Measured{distance_to_surface(meshes_.at(k).vertices, meshes_.at(k - 1), caps_.at(k)), 0};
      flicker_[k]->seconds = seconds_since(t0);
      known.push_back(k);
    }
    for (std::size_t k : {i == 0 ? i : i - 1, i, i + 1}) {  // drop meshes no pair needs any more
      if (k >= status_.size() || !meshes_.count(k)) continue;
      const bool before = k == 0 || status_[k - 1] != kPending;
      const bool after = k + 1 == status_.size() || status_[k + 1] != kPending;
      if (before && after) meshes_.erase(k), caps_.erase(k);
    }
    return known;
  }
  struct Measured {
    SurfaceDistanceReport report;
    double seconds;
  };
  const std::optional<Measured>& flicker(std::size_t k) const { return flicker_[k]; }

 private:
  enum Status : char { kPending, kDone, kFailed };
  std::vector<Status> status_;
  std::map<std::size_t, TriangleMesh> meshes_;
  std::map<std::size_t, double> caps_;
  std::vector<std::optional<Measured>> flicker_;
};

/// The flicker report as JSON: the distances, the cap (null when none) and what the measure cost.
nlohmann::ordered_json flicker_json(const SurfaceDistanceReport& f) {
  nlohmann::ordered_json j = {{"mean", f.mean}, {"p95", f.p95}, {"max", f.max}, {"beyond_cap", f.beyond_cap}};
  j["cap"] = std::isfinite(f.cap) ? nlohmann::ordered_json(f.cap) : nlohmann::ordered_json(nullptr);
  j["triangle_tests"] = f.triangle_tests;
  return j;
}

/// Adds the flicker against the previous frame to a frame's stats file.
void add_flicker_to_stats(const std::string& path, int previous_frame, const SequenceFlicker::Measured& f) {
  nlohmann::ordered_json j = nlohmann::ordered_json::parse(read_text_file(path));
  j["flicker"] = {{"previous_frame", previous_frame}};
  j["flicker"].update(flicker_json(f.report));
  j["flicker"]["seconds"] = f.seconds;
  write_text_file(path, j.dump(2) + "\n");
}

/// A sequence: every frame of the input pattern, in order, one progress bar; a failed frame is
/// reported with its number and the others go on unless --fail-fast.
int run_sequence(const SurfaceArgs& given, const FramePattern& in) {
  SurfaceArgs a = given;
  const auto out = parse_frame_pattern(a.output);
  if (!out) throw InvalidParameter(fmt::format("output '{}' needs a frame placeholder (####, {{}} or %04d) like the input", a.output));
  std::optional<FramePattern> stats, preview, field;
  for (auto [path, pattern] :
       {std::pair{&a.stats_path, &stats}, std::pair{&a.preview_path, &preview}, std::pair{&a.field_path, &field}}) {
    if (path->empty()) continue;
    *pattern = parse_frame_pattern(*path);
    if (!*pattern) throw InvalidParameter(fmt::format("'{}' needs a frame placeholder in a sequence", *path));
  }
  std::vector<int> frames = a.frames.empty() ? discover_frames(in) : parse_frame_ranges(a.frames);
  if (frames.empty()) throw InvalidParameter(fmt::format("no frames found for '{}' (give --frames)", a.input));
  // The frame the estimates come from: named, or the first of the list (also when its mesh exists,
  // so that a resubmission with --skip-existing estimates what the first submission did).
  std::vector<int> candidates = a.estimates_from ? std::vector<int>{*a.estimates_from} : frames;
  std::vector<int> skipped;
  if (a.skip_existing) {
    std::erase_if(frames, [&](int frame) {
      const bool exists = std::filesystem::exists(out->format(frame));
      if (exists) skipped.push_back(frame);
      return exists;
    });
    if (!a.quiet && !skipped.empty())
      fmt::print(stderr, "skipping {} frame(s) whose mesh exists (--skip-existing): {}\n", skipped.size(),
                 format_frame_ranges(skipped));
    if (frames.empty()) {
      if (!a.quiet) fmt::print(stderr, "every frame's mesh exists: nothing to do\n");
      return 0;
    }
  }

  // The frame-wide estimates (spacing, rest density, reference speed) not given are made on the
  // first frame that reads and used for every frame: re-estimated per frame, a droplet appearing
  // anywhere would move the whole surface. That frame's particles are surfaced as read here; a
  // frame that does not read is reported with the others.
  const Params& gp = given.params;
  std::size_t first = 0;
  std::optional<ReadFrame> first_frame;
  for (; first < candidates.size() && !first_frame; ++first) {
    try {
      const auto t0 = std::chrono::steady_clock::now();
      ParticleSet particles = read_particles(in.format(candidates[first]), read_options(a));
      first_frame = ReadFrame{std::move(particles), seconds_since(t0)};
    } catch (const std::exception& e) {
      if (a.estimates_from)  // a named frame must read: another frame would give other estimates
        throw IoError(fmt::format("--estimates-from {}: {}", *a.estimates_from, e.what()));
    }
  }
  const int estimate_frame = candidates[--first];
  if (first_frame) a.params = resolve_frame_estimates(first_frame->particles, gp);
  // The particles read are surfaced as they are when that frame is one to surface.
  const auto preread_at = std::find(frames.begin(), frames.end(), estimate_frame);
  first = std::size_t(preread_at - frames.begin());
  if (!(a.params == gp)) {
    a.estimated_on = in.format(estimate_frame);
    if (!a.quiet) {
      std::string what = fmt::format("spacing {:.6g}", a.params.spacing);
      if (a.params.rest_density != gp.rest_density) what += fmt::format(", rest density {:.6g}", a.params.rest_density);
      if (a.params.velocity_reference != gp.velocity_reference)
        what += fmt::format(", reference speed {:.6g}", a.params.velocity_reference);
      fmt::print(stderr, "estimated on frame {} and used for every frame: {}{}\n", estimate_frame, what,
                 gp.spacing == 0 ? " (set --spacing to override)" : "");
    }
  }

  const auto t0 = std::chrono::steady_clock::now();
  cli::ProgressBar bar(!a.quiet);
  std::mutex mutex;  // guards the bar, the report lines and the counters below
  std::vector<int> failed;
  std::size_t done = 0, triangles = 0;
  std::atomic<std::size_t> next{0};
  std::atomic<bool> stop{false};
  SequenceFlicker flicker(frames.size());
  auto record_flicker = [&](std::size_t i, TriangleMesh* mesh, double spacing) {  // with the mutex held
    for (std::size_t k : flicker.settle(i, mesh, spacing))
      if (stats) add_flicker_to_stats(stats->format(frames[k]), frames[k - 1], *flicker.flicker(k));
  };
  const int jobs = std::max(1, std::min<int>(a.jobs, int(frames.size())));
  auto worker = [&] {
    for (;;) {
      if (stop) return;
      const std::size_t i = next++;
      if (i >= frames.size()) return;
      const int frame = frames[i];
      FrameFiles f{in.format(frame), out->format(frame), stats ? stats->format(frame) : "",
                   preview ? preview->format(frame) : "", field ? field->format(frame) : ""};
      try {
        std::optional<ReadFrame> preread;
        if (i == first) preread = std::exchange(first_frame, std::nullopt);
        Result r = surface_one(
            a, f, false,
            [&](std::string_view stage, double fraction) {
              if (jobs > 1) return;
              std::lock_guard lock(mutex);
              bar.update(fmt::format("frame {} {}", frame, stage), (double(done) + fraction) / double(frames.size()));
            },
            std::move(preread));
        std::lock_guard lock(mutex);
        ++done;
        triangles += r.stats.triangles;
        record_flicker(i, &r.mesh, r.params.spacing);
        bar.update(fmt::format("frame {}", frame), double(done) / double(frames.size()));
      } catch (const std::exception& e) {
        std::lock_guard lock(mutex);
        ++done;
        failed.push_back(frame);
        try {
          record_flicker(i, nullptr, 0);
        } catch (const std::exception&) {
        }
        bar.finish();
        fmt::print(stderr, "meniscus: frame {}: error: {}\n", frame, e.what());
        if (a.fail_fast) stop = true;
      }
    }
  };
  std::vector<std::thread> threads;
  for (int j = 1; j < jobs; ++j) threads.emplace_back(worker);
  worker();
  for (std::thread& t : threads) t.join();
  bar.finish();
  std::sort(failed.begin(), failed.end());
  const std::size_t ok = done - failed.size();
  double flicker_sum = 0, flicker_max = 0, flicker_seconds = 0;
  std::size_t flicker_count = 0;
  for (std::size_t k = 0; k < frames.size(); ++k)
    if (const auto& f = flicker.flicker(k)) {
      flicker_sum += f->report.mean, flicker_max = std::max(flicker_max, f->report.max), ++flicker_count;
      flicker_seconds += f->seconds;
    }
  if (!a.quiet && flicker_count > 0)
    fmt::print(stderr, "flicker (vertex distance to the previous frame's surface): mean {:.4g} over {} frame pairs, max {:.4g}; measured in {:.3f}s\n",
               flicker_sum / double(flicker_count), flicker_count, flicker_max, flicker_seconds);
  if (!a.quiet || !failed.empty())
    fmt::print(stderr, "{} of {} frames surfaced ({} triangles) in {:.2f}s{}{}\n", ok, frames.size(), triangles,
               seconds_since(t0),
               failed.empty() ? ""
                              : fmt::format("; failed: {} (run again with --skip-existing, or --frames {})",
                                            format_frame_ranges(failed), format_frame_ranges(failed)),
               stop ? "; stopped at the first failure (--fail-fast)" : "");
  return failed.empty() ? 0 : kExitRuntime;
}

/// One frame over the ranks of an MPI job (mpirun, srun --mpi=pmix): docs/cluster.md.
int run_surface_ranks(const cli::MpiSession& mpi, const SurfaceArgs& a) {
  if (parse_frame_pattern(a.input))
    throw InvalidParameter("a sequence under an MPI launcher: surface its frames as a job array (docs/cluster.md); "
                           "MPI spreads one frame over the ranks");
  if (!a.preview_path.empty() || !a.field_path.empty())
    throw InvalidParameter("--preview and --save-field are not available over MPI ranks: render the mesh afterwards "
                           "(meniscus render)");
  if (!a.params.clip_box.empty() || a.params.decimate > 0)
    throw InvalidParameter("--clip-box and --decimate work on the whole mesh and are not available over MPI ranks: "
                           "surface in one process to use them");
  if (a.pieces && !a.output.ends_with(".pvtp"))
    throw InvalidParameter(fmt::format("--pieces: the output '{}' must be the .pvtp index of the pieces (big.pvtp → "
                                       "big_0.vtp, big_1.vtp …)", a.output));
  cli::MpiJob job{a.input, a.output, a.stats_path, a.params, read_options(a), a.quiet || mpi.rank() != 0, a.pieces};
  if (!a.stats_path.empty()) make_parent_dirs(a.stats_path);
  make_parent_dirs(a.output);
  return cli::run_surface_mpi(mpi, job);
}

int run_surface(const CLI::App& cmd, SurfaceArgs& a, const cli::MpiSession& mpi) {
  a.params.extract = parse_extractor(a.extract);
  a.params.solver = parse_solver(a.solver);
  a.params.backend = parse_backend(a.backend);
  a.params.field = parse_field(a.field);
  apply_artist_controls(cmd, a);
  if (a.detail && cmd.count("--voxel-size") && !a.quiet)
    fmt::print(stderr, "warning: --detail is ignored: --voxel-size {:g} is given\n", a.params.voxel_size);
  a.params.validate();
  if (a.pieces && !mpi.active())
    throw InvalidParameter("--pieces: one piece per MPI rank; run under mpirun or srun --mpi=pmix (docs/cluster.md)");
  if (!a.pieces) check_output_format(a.output);  // refuse an unknown format before any work is done
  if (!a.field_path.empty() && !has_openvdb())
    throw InvalidParameter("--save-field: this meniscus was built without OpenVDB (install libopenvdb-dev and rebuild)");
  if (a.jobs < 1) throw InvalidParameter(fmt::format("jobs = {}: must be ≥ 1", a.jobs));
  if (mpi.active()) return run_surface_ranks(mpi, a);
  if (cli::launched_ranks() > 1)
    throw InvalidParameter(fmt::format("started by an MPI launcher as one of {} processes, but this meniscus was built "
                                       "without MPI: each would surface the whole frame (install libopenmpi-dev and "
                                       "rebuild, or run one process)",
                                       cli::launched_ranks()));
  if (const auto pattern = parse_frame_pattern(a.input)) return run_sequence(a, *pattern);
  if (!a.frames.empty()) throw InvalidParameter("--frames needs an input pattern with a frame placeholder (####, {} or %04d)");

  const FrameFiles f{a.input, a.output, a.stats_path, a.preview_path, a.field_path};
  cli::ProgressBar bar(!a.quiet);
  const Result result = surface_one(a, f, !a.quiet, [&](std::string_view stage, double fraction) { bar.update(stage, fraction); });
  bar.finish();
  if (!a.quiet) print_summary(a, f, result);
  return 0;
}

struct MergeArgs {
  std::vector<std::string> inputs;
  std::string output;
  bool quiet = false;
};

/// The piece files an index names (`<Piece Source="…"/>`, relative to the index's folder).
std::vector<std::string> pvtp_pieces(const std::string& index) {
  const std::string text = read_text_file(index);
  std::vector<std::string> out;
  const std::filesystem::path dir = std::filesystem::path(index).parent_path();
  for (std::size_t at = text.find("<Piece"); at != std::string::npos; at = text.find("<Piece", at + 1)) {
    const std::size_t s = text.find("Source=\"", at), e = s == std::string::npos ? s : text.find('"', s + 8);
    const std::size_t end = text.find('>', at);
    if (s == std::string::npos || e == std::string::npos || s > end)
      throw FormatError(index, fmt::format("byte {}", at), "expected <Piece Source=\"…\"/>");
    out.push_back((dir / text.substr(s + 8, e - s - 8)).string());
  }
  if (out.empty()) throw FormatError(index, "", "expected <Piece Source=\"…\"/> entries in the .pvtp index");
  return out;
}

/// Welds pieces (a .pvtp index, or mesh files) into one mesh by their coincident seam vertices.
/// Each piece is read twice — its positions first, then (after the weld has numbered the
/// vertices) its attributes and triangles — so that the merge holds the pieces' positions and the
/// welded mesh, never every piece whole (PieceWelder).
int run_merge(const MergeArgs& a) {
  check_output_format(a.output);
  std::vector<std::string> files;
  for (const std::string& in : a.inputs) {
    if (in.ends_with(".pvtp")) {
      const std::vector<std::string> listed = pvtp_pieces(in);
      files.insert(files.end(), listed.begin(), listed.end());
    } else {
      files.push_back(in);
    }
  }
  const auto t0 = std::chrono::steady_clock::now();
  PieceWelder welder(files.size());
  std::vector<std::size_t> counts(files.size());  // each piece's vertices and triangles, to check the second read
  std::size_t vertices = 0, triangles = 0;
  bool normals = true;
  for (std::size_t p = 0; p < files.size(); ++p) {
    TriangleMesh piece = read_mesh(files[p]);
    normals = normals && piece.normals.size() == piece.vertices.size();
    counts[p] = piece.vertices.size() + piece.triangles.size();
    vertices += piece.vertices.size(), triangles += piece.triangles.size();
    welder.add_vertices(p, std::move(piece.vertices));
  }
  welder.weld_vertices();
  welder.reserve_triangles(triangles);
  for (std::size_t p = 0; p < files.size(); ++p) {
    const TriangleMesh piece = read_mesh(files[p]);
    if (piece.vertices.size() + piece.triangles.size() != counts[p])
      throw FormatError(files[p], "", "the piece changed while it was being merged");
    welder.add_attributes(p, piece.attributes);
    welder.add_triangles(p, piece.triangles);
  }
  const TriangleMesh mesh = welder.finish(normals);
  make_parent_dirs(a.output);
  write_mesh(a.output, mesh);
  if (!a.quiet) {
    const TopologyReport t = analyze_topology(mesh);
    fmt::print(stderr, "merged {} pieces: {} vertices ({} on seams welded), {} triangles, {} in {:.3f}s\nwrote {}\n",
               files.size(), mesh.vertices.size(), vertices - mesh.vertices.size(), mesh.triangles.size(),
               t.watertight() ? "watertight" : "NOT watertight", seconds_since(t0), a.output);
  }
  return 0;
}

struct RenderArgs {
  std::string mesh, output, particles, color_by, range, size = "960x720", up = "z", frames;
  float yaw = 35, pitch = 30;
  int turntable = 1;
  bool quiet = false;
};

/// "960x720" → {960, 720}; each side 1 ..= 8192.
std::pair<int, int> parse_size(const std::string& text) {
  const std::size_t x = text.find_first_of("xX");
  const auto side = [&](std::string_view digits) {
    if (digits.empty() || digits.size() > 5 || digits.find_first_not_of("0123456789") != std::string_view::npos) return 0;
    return std::stoi(std::string(digits));
  };
  const int w = x == std::string::npos ? 0 : side(std::string_view(text).substr(0, x));
  const int h = x == std::string::npos ? 0 : side(std::string_view(text).substr(x + 1));
  if (w < 1 || h < 1 || w > 8192 || h > 8192)
    throw InvalidParameter(fmt::format("--size '{}': expected WIDTHxHEIGHT with each side in 1 ..= 8192, e.g. 960x720", text));
  return {w, h};
}

/// "lo,hi" → {lo, hi} with lo < hi.
std::array<float, 2> parse_range(const std::string& text) {
  const std::size_t comma = text.find(',');
  float lo = 0, hi = 0;
  bool ok = comma != std::string::npos;
  if (ok) {
    try {
      std::size_t used_lo = 0, used_hi = 0;
      const std::string a = text.substr(0, comma), b = text.substr(comma + 1);
      lo = std::stof(a, &used_lo);
      hi = std::stof(b, &used_hi);
      ok = used_lo == a.size() && used_hi == b.size() && std::isfinite(lo) && std::isfinite(hi) && lo < hi;
    } catch (const std::exception&) {
      ok = false;
    }
  }
  if (!ok) throw InvalidParameter(fmt::format("--range '{}': expected LO,HI with LO < HI, e.g. 0,2.5", text));
  return {lo, hi};
}

/// Pictures of a mesh or a mesh sequence: one tile per frame (a row of --turntable views each),
/// all frames framed on their common bounding box and coloured over one range.
int run_render(const RenderArgs& a) {
  RenderOptions options;
  std::tie(options.width, options.height) = parse_size(a.size);
  options.up = up_axis(a.up);
  options.yaw_degrees = a.yaw;
  options.pitch_degrees = a.pitch;
  options.color_attribute = a.color_by;
  if (!a.range.empty()) options.color_range = parse_range(a.range);
  if (!a.range.empty() && a.color_by.empty()) throw InvalidParameter("--range needs --color-by");
  if (a.turntable < 1 || a.turntable > 64)
    throw InvalidParameter(fmt::format("--turntable {}: expected 1 ..= 64 views", a.turntable));
  options.validate();
  if (const std::string ext = std::filesystem::path(a.output).extension().string(); ext != ".png" && ext != ".PNG")
    throw InvalidParameter(fmt::format("output '{}': render writes .png pictures", a.output));

  // The files: one mesh, or the frames of a pattern (with a particle pattern beside it).
  const std::optional<FramePattern> mesh_pattern = parse_frame_pattern(a.mesh);
  const std::optional<FramePattern> particle_pattern =
      a.particles.empty() ? std::nullopt : parse_frame_pattern(a.particles);
  std::vector<std::pair<std::string, std::string>> files;  // mesh, particles
  std::vector<int> frames;
  if (mesh_pattern) {
    frames = a.frames.empty() ? discover_frames(*mesh_pattern) : parse_frame_ranges(a.frames);
    if (frames.empty()) throw InvalidParameter(fmt::format("no frames found for '{}' (give --frames)", a.mesh));
    for (const int frame : frames)
      files.emplace_back(mesh_pattern->format(frame), particle_pattern ? particle_pattern->format(frame) : a.particles);
  } else {
    if (!a.frames.empty()) throw InvalidParameter("--frames needs a mesh pattern with a frame placeholder (####, {} or %04d)");
    if (particle_pattern)
      throw InvalidParameter(fmt::format("--particles '{}' has a frame placeholder but the mesh is a single file", a.particles));
    files.emplace_back(a.mesh, a.particles);
  }
  const std::size_t tiles = files.size() * std::size_t(a.turntable);
  if (tiles > 256)
    throw InvalidParameter(fmt::format("{} frames × {} views = {} pictures: at most 256 (select fewer with --frames "
                                       "1-240:10)", files.size(), a.turntable, tiles));

  // Read everything first, so a missing file or attribute fails before any picture is made.
  std::vector<TriangleMesh> meshes;
  std::vector<ParticleSet> particles;
  Box3 box;
  for (const auto& [mesh_file, particle_file] : files) {
    meshes.push_back(read_mesh(mesh_file));
    particles.push_back(particle_file.empty() ? ParticleSet{} : read_particles(particle_file));
    for (const Vec3f& v : meshes.back().vertices) box.add(v);
    if (meshes.back().vertices.empty())
      for (const Vec3f& v : particles.back().positions) box.add(v);
  }
  std::optional<std::array<float, 2>> auto_range;
  ColorMapping mapping = ColorMapping::scalar;
  if (!a.color_by.empty()) {
    for (std::size_t i = 0; i < meshes.size(); ++i) {
      const Attribute* attribute = meshes[i].find(a.color_by);
      if (attribute == nullptr) {
        std::string available;
        for (const Attribute& at : meshes[i].attributes)
          if (at.components == 1 || at.components == 3) available += (available.empty() ? "" : ", ") + at.name;
        throw InvalidParameter(fmt::format("--color-by '{}': {} has no such vertex attribute (it has: {})", a.color_by,
                                           files[i].first, available.empty() ? "none" : available));
      }
      mapping = color_mapping(*attribute);
      if (const auto r = color_value_range(*attribute))
        auto_range = auto_range ? std::array{std::min((*auto_range)[0], (*r)[0]), std::max((*auto_range)[1], (*r)[1])} : *r;
    }
    // One range for every frame, so a colour means the same value in every tile.
    if (!options.color_range && auto_range && (*auto_range)[0] < (*auto_range)[1]) options.color_range = auto_range;
  }
  if (mesh_pattern && box.valid()) options.frame_bounds = Bounds{box.lo, box.hi};

  std::vector<Image> images;
  for (std::size_t i = 0; i < meshes.size(); ++i) {
    RenderOptions view = options;
    view.particles = particles[i].size() ? &particles[i] : nullptr;
    images.push_back(render_turntable(meshes[i], view, a.turntable));
  }
  // Frames side by side; with a turntable, one row of views per frame.
  const Image picture = join_images(images, a.turntable == 1 ? int(images.size()) : 1);
  make_parent_dirs(a.output);
  write_png(a.output, picture);
  if (!a.quiet) {
    if (!a.color_by.empty()) {
      if (mapping == ColorMapping::rgb)
        fmt::print(stderr, "coloured by '{}' as RGB\n", a.color_by);
      else if (options.color_range)
        fmt::print(stderr, "coloured by '{}'{} through viridis: {:.6g} (purple) .. {:.6g} (yellow)\n", a.color_by,
                   mapping == ColorMapping::magnitude ? " (magnitude)" : "", (*options.color_range)[0],
                   (*options.color_range)[1]);
    }
    fmt::print(stderr, "wrote {} ({}×{}: {} frame(s) × {} view(s))\n", a.output, picture.width, picture.height,
               meshes.size(), a.turntable);
  }
  return 0;
}

struct InspectArgs {
  std::string mesh, particles, previous, frames;
  double r_inner = 0, r_outer = 0, spacing = 0, flicker_cap = -1;
  bool json = false, flicker = false;
};

/// A finished sequence's meshes (a pattern): each frame's counts and topology and, with --flicker,
/// the distance of its vertices to the previous frame's surface, as `meniscus surface` measures
/// it during a run, for sequences surfaced in pieces (a job array's tasks do not see each other's
/// frames). The search cap: --flicker-cap, else 4 spacings (--spacing, or estimated on the first
/// frame of --particles), else 16 mean edges of the previous mesh.
int run_inspect_sequence(const InspectArgs& a, const FramePattern& pattern) {
  if (!a.previous.empty()) throw InvalidParameter("--previous: a sequence's frames are compared with each other (--flicker)");
  const std::vector<int> frames = a.frames.empty() ? discover_frames(pattern) : parse_frame_ranges(a.frames);
  if (frames.empty()) throw InvalidParameter(fmt::format("no frames found for '{}' (give --frames)", a.mesh));
  double spacing = a.spacing;
  if (spacing == 0 && !a.particles.empty()) {
    const auto particles = parse_frame_pattern(a.particles);
    const std::string first = particles ? particles->format(frames.front()) : a.particles;
    Params in;
    spacing = resolve_params(read_particles(first), in).spacing;
  }
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  std::optional<TriangleMesh> previous;
  int previous_frame = 0;
  double flicker_sum = 0, flicker_max = 0;
  std::size_t pairs = 0, not_watertight = 0;
  for (const int frame : frames) {
    const std::string file = pattern.format(frame);
    TriangleMesh mesh = read_mesh(file);
    const TopologyReport t = analyze_topology(mesh);
    not_watertight += t.watertight() ? 0 : 1;
    nlohmann::ordered_json j = {{"frame", frame}, {"mesh", file}, {"vertices", mesh.vertices.size()},
                                {"triangles", mesh.triangles.size()}, {"watertight", t.watertight()},
                                {"components", t.components}};
    std::string line = fmt::format("frame {}: {} vertices, {} triangles, {}", frame, mesh.vertices.size(),
                                   mesh.triangles.size(), t.watertight() ? "watertight" : "NOT watertight");
    if (a.flicker && previous) {
      double cap = a.flicker_cap == 0 ? INFINITY : a.flicker_cap;
      if (a.flicker_cap < 0) cap = spacing > 0 ? kFlickerCapSpacings * spacing : kFlickerCapEdges * mean_edge_length(*previous);
      const SurfaceDistanceReport f = distance_to_surface(mesh.vertices, *previous, cap);
      j["flicker"] = {{"previous_frame", previous_frame}};
      j["flicker"].update(flicker_json(f));
      flicker_sum += f.mean, flicker_max = std::max(flicker_max, f.max), ++pairs;
      line += fmt::format("; flicker against frame {}: mean {:.4g}, max {:.4g}", previous_frame, f.mean, f.max);
    }
    if (!a.json) fmt::print("{}\n", line);
    list.push_back(std::move(j));
    if (a.flicker) previous = std::move(mesh), previous_frame = frame;
  }
  nlohmann::ordered_json summary = {{"frames", frames.size()}, {"not_watertight", not_watertight}};
  if (a.flicker) summary["flicker"] = {{"pairs", pairs}, {"mean", pairs ? flicker_sum / double(pairs) : 0.0}, {"max", flicker_max}};
  if (a.json) {
    fmt::print("{}\n", nlohmann::ordered_json{{"sequence", a.mesh}, {"summary", summary}, {"frames", list}}.dump(2));
    return 0;
  }
  fmt::print("{} frames, {} not watertight", frames.size(), not_watertight);
  if (a.flicker) fmt::print("; flicker mean {:.4g} over {} frame pairs, max {:.4g}", pairs ? flicker_sum / double(pairs) : 0.0, pairs, flicker_max);
  fmt::print("\n");
  return 0;
}

/// Quality metrics of any mesh (DESIGN §5), ours or another tool's.
int run_inspect(const InspectArgs& a) {
  if (const auto pattern = parse_frame_pattern(a.mesh)) return run_inspect_sequence(a, *pattern);
  if (!a.frames.empty() || a.flicker)
    throw InvalidParameter("--frames and --flicker need a mesh pattern with a frame placeholder (mesh_####.ply)");
  const TriangleMesh mesh = read_mesh(a.mesh);
  const TopologyReport t = analyze_topology(mesh);
  const ValenceReport v = valence(mesh);
  const AngleReport angles = triangle_angles(mesh);
  nlohmann::ordered_json j;
  j["mesh"] = a.mesh;
  j["vertices"] = mesh.vertices.size();
  j["triangles"] = mesh.triangles.size();
  j["topology"] = {{"watertight", t.watertight()}, {"closed", t.closed()}, {"edge_manifold", t.edge_manifold()},
                   {"vertex_manifold", t.nonmanifold_vertices == 0}, {"oriented", t.oriented()},
                   {"components", t.components}, {"euler", t.euler}, {"boundary_edges", t.boundary_edges},
                   {"nonmanifold_edges", t.nonmanifold_edges}, {"misoriented_edges", t.misoriented_edges},
                   {"nonmanifold_vertices", t.nonmanifold_vertices}, {"degenerate_triangles", t.degenerate_triangles},
                   {"unreferenced_vertices", t.unreferenced_vertices}};
  j["valence"] = {{"min", v.min}, {"max", v.max}, {"mean", v.mean}, {"below_5", v.below_5},
                  {"share_below_5", mesh.vertices.empty() ? 0.0 : double(v.below_5) / double(mesh.vertices.size())},
                  {"histogram", v.histogram}};
  j["angles"] = {{"min_degrees", angles.min_degrees}, {"max_degrees", angles.max_degrees},
                 {"share_below_10", angles.share_below_10}};
  const double volume = signed_volume(mesh);
  j["volume"] = volume;
  double spacing = a.spacing;  // known when given or estimated from the particles
  if (!a.particles.empty()) {
    const ParticleSet ps = read_particles(a.particles);
    Params in;
    in.spacing = a.spacing;
    in.r_inner = a.r_inner;
    in.r_outer = a.r_outer;
    const Params p = resolve_params(ps, in);
    spacing = p.spacing;
    const ConstraintReport c = constraint_residual(mesh.vertices, ps.positions, p.r_inner, p.r_outer);
    const std::size_t outside = points_outside(mesh, ps.positions);
    const double particle_volume = double(ps.size()) * p.spacing * p.spacing * p.spacing;
    j["particles"] = {{"file", a.particles}, {"count", ps.size()}, {"spacing", p.spacing},
                      {"r_inner", p.r_inner}, {"r_outer", p.r_outer},
                      {"constraint_residual", c.max_violation},
                      {"vertex_distance_min", c.min_distance}, {"vertex_distance_max", c.max_distance},
                      {"outside_surface", outside},
                      {"share_outside_surface", double(outside) / double(std::max<std::size_t>(ps.size(), 1))},
                      {"volume_over_particle_volume", volume / particle_volume}};
  }
  if (!a.previous.empty()) {
    const TriangleMesh previous = read_mesh(a.previous);
    // The search distance: as given (0: none); else kFlickerCapSpacings spacings when the spacing
    // is known; else kFlickerCapEdges mean edges of the previous mesh (about as far on ours).
    double cap = a.flicker_cap == 0 ? INFINITY : a.flicker_cap;
    if (a.flicker_cap < 0)
      cap = spacing > 0 ? kFlickerCapSpacings * spacing : kFlickerCapEdges * mean_edge_length(previous);
    const SurfaceDistanceReport f = distance_to_surface(mesh.vertices, previous, cap);
    j["flicker"] = {{"previous", a.previous}};
    j["flicker"].update(flicker_json(f));
  }
  if (a.json) {
    fmt::print("{}\n", j.dump(2));
    return 0;
  }
  fmt::print("{}: {} vertices, {} triangles\n", a.mesh, mesh.vertices.size(), mesh.triangles.size());
  fmt::print("topology: {} — {} component(s), Euler characteristic {}; {} boundary, {} non-manifold, {} misoriented edges; "
             "{} non-manifold vertices; {} degenerate triangles\n",
             t.watertight() ? "watertight" : "NOT watertight", t.components, t.euler, t.boundary_edges,
             t.nonmanifold_edges, t.misoriented_edges, t.nonmanifold_vertices, t.degenerate_triangles);
  fmt::print("valence: min {}, max {}, mean {:.2f}; {:.2f} % under 5\n", v.min, v.max, v.mean,
             100.0 * j["valence"]["share_below_5"].get<double>());
  fmt::print("angles: min {:.2f}°, max {:.2f}°; {:.2f} % under 10°\n", angles.min_degrees, angles.max_degrees,
             100.0 * angles.share_below_10);
  fmt::print("volume: {:.6g}\n", volume);
  if (j.contains("particles")) {
    const auto& q = j["particles"];
    fmt::print("particles: {} (spacing {:.4g}); vertex distances {:.4g} .. {:.4g} for [r_inner {:.4g}, r_outer {:.4g}], "
               "constraint residual {:.3g}\n",
               q["count"].get<std::size_t>(), q["spacing"].get<double>(), q["vertex_distance_min"].get<double>(),
               q["vertex_distance_max"].get<double>(), q["r_inner"].get<double>(), q["r_outer"].get<double>(),
               q["constraint_residual"].get<double>());
    fmt::print("particles outside the surface: {} ({:.2f} %); volume / (N·d³) = {:.3f}\n",
               q["outside_surface"].get<std::size_t>(), 100.0 * q["share_outside_surface"].get<double>(),
               q["volume_over_particle_volume"].get<double>());
  }
  if (j.contains("flicker")) {
    const auto& f = j["flicker"];
    const std::size_t beyond = f["beyond_cap"].get<std::size_t>();
    fmt::print("flicker (distance of each vertex to {}): mean {:.4g}, 95th percentile {:.4g}, max {:.4g}{}\n", a.previous,
               f["mean"].get<double>(), f["p95"].get<double>(), f["max"].get<double>(),
               beyond == 0 ? std::string()
                           : fmt::format("; {} vertices ({:.1f} %) farther than the cap {:.4g}, counted at it", beyond,
                                         100.0 * double(beyond) / double(std::max<std::size_t>(mesh.vertices.size(), 1)),
                                         f["cap"].get<double>()));
  }
  return 0;
}

int run_info() {
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
  fmt::print("mpi: {}\n", cli::mpi_built() ? "yes (mpirun -n K meniscus surface spreads one frame over K ranks)"
                                            : "no (built without MPI)");
  fmt::print("particle formats: {}\n", fmt::join(particle_formats(), " "));
  fmt::print("mesh formats: {} (each also gzip-compressed: .bgeo.gz, .ply.gz …)\n", fmt::join(mesh_formats(), " "));
  fmt::print("extractors: tiles cubes tetrahedra\n");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const meniscus::cli::MpiSession mpi(&argc, &argv);  // MPI_Init where an MPI launcher started us
  const bool quiet_rank = mpi.active() && mpi.rank() != 0;  // messages come from rank 0
  meniscus::release_large_blocks_eagerly();  // a lower peak: freed stage arrays leave the process
  meniscus::reuse_freed_blocks_between_stages();  // except up to the smoothing, where they serve the next stage
  CLI::App app{"meniscus — smooth, watertight meshes from fluid particles (Williams' constrained smoothing)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string(meniscus::version()));
  SurfaceArgs surface;
  CLI::App* surface_cmd = app.add_subcommand("surface", "surface a particle file into a triangle mesh");
  add_surface_options(*surface_cmd, surface);
  InspectArgs inspect;
  CLI::App* inspect_cmd = app.add_subcommand("inspect", "quality metrics of a mesh: topology, valence, angles, constraints");
  inspect_cmd->add_option("mesh", inspect.mesh, "mesh file (.ply, .obj, .vtk, .bgeo), or a sequence pattern (mesh_####.ply)")
      ->required();
  inspect_cmd->add_option("--frames", inspect.frames, "frames of a sequence: 1-240, 1-240:2, 1,5,10-20 (default: all found)");
  inspect_cmd->add_flag("--flicker", inspect.flicker,
                        "a sequence: each frame's flicker against the one before it in the list (as surface measures it)");
  inspect_cmd->add_option("--particles", inspect.particles, "the particles it was made from: constraint residual, "
                                                            "particles left outside (a sequence: the spacing for "
                                                            "the flicker cap, estimated on the first frame)");
  inspect_cmd->add_option("--spacing", inspect.spacing, "particle spacing (default: estimated)")->check(CLI::PositiveNumber);
  inspect_cmd->add_option("--r-inner", inspect.r_inner, "inner constraint radius (default 0.5 r_outer)")
      ->check(CLI::PositiveNumber);
  inspect_cmd->add_option("--r-outer", inspect.r_outer, "outer constraint radius (default 1.0 d)")->check(CLI::PositiveNumber);
  inspect_cmd->add_option("--previous", inspect.previous,
                          "the previous frame's mesh: flicker = distance of each vertex to its surface");
  inspect_cmd->add_option("--flicker-cap", inspect.flicker_cap,
                          "with --previous: distances are searched up to this far, farther vertices count at it "
                          "(default 4 spacings, or 16 mean edges of the previous mesh; 0: no cap)")
      ->check(CLI::NonNegativeNumber);
  inspect_cmd->add_flag("--json", inspect.json, "print the metrics as JSON");
  CLI::App* info_cmd = app.add_subcommand("info", "version, backends, threads and formats");
  MergeArgs merge;
  CLI::App* merge_cmd = app.add_subcommand("merge", "weld mesh pieces (an MPI run's .pvtp, or mesh files) into one mesh");
  merge_cmd->add_option("pieces", merge.inputs, "a .pvtp index, or the piece files")->required();
  merge_cmd->add_option("-o,--output", merge.output, "mesh file to write")->required();
  merge_cmd->add_flag("-q,--quiet", merge.quiet, "print nothing");
  RenderArgs render;
  CLI::App* render_cmd = app.add_subcommand("render", "preview picture (.png) of a mesh or a mesh sequence");
  render_cmd->add_option("mesh", render.mesh, "mesh file, or a sequence pattern (mesh_####.ply): one tile per frame")
      ->required();
  render_cmd->add_option("-o,--output", render.output, "picture to write (.png)")->required();
  render_cmd->add_option("--size", render.size, "size of each tile, WIDTHxHEIGHT")->capture_default_str();
  render_cmd->add_option("--up", render.up, "up axis (SPlisHSPlasH and Houdini scenes are y-up)")
      ->check(CLI::IsMember({"x", "y", "z"}))->capture_default_str();
  render_cmd->add_option("--yaw", render.yaw, "camera azimuth around the up axis, degrees")->capture_default_str();
  render_cmd->add_option("--pitch", render.pitch, "camera elevation, degrees in [-89, 89]")->capture_default_str();
  render_cmd->add_option("--particles", render.particles,
                         "overlay these particles as dots, hidden where the surface is in front (a pattern for a sequence)");
  render_cmd->add_option("--color-by", render.color_by,
                         "colour by a vertex attribute: scalar or vector magnitude through viridis, colours as RGB");
  render_cmd->add_option("--range", render.range, "values at the ends of the colormap, LO,HI (default: min,max over all frames)");
  render_cmd->add_option("--turntable", render.turntable, "N views at evenly spaced azimuths, side by side")
      ->capture_default_str();
  render_cmd->add_option("--frames", render.frames, "frames of a sequence: 1-240, 1-240:10, 1,5,10-20 (default: all found)");
  render_cmd->add_flag("-q,--quiet", render.quiet, "print nothing");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : kExitUsage;  // --help is not an error; every bad option is
  }
  try {
    if (surface_cmd->parsed()) return run_surface(*surface_cmd, surface, mpi);
    if (info_cmd->parsed()) return run_info();
    if (merge_cmd->parsed()) return run_merge(merge);
    if (render_cmd->parsed()) return run_render(render);
    if (inspect_cmd->parsed()) return run_inspect(inspect);
  } catch (const meniscus::InvalidParameter& e) {
    if (!quiet_rank) fmt::print(stderr, "meniscus: error: {}\n", e.what());
    return kExitUsage;
  } catch (const std::exception& e) {
    if (!quiet_rank) fmt::print(stderr, "meniscus: error: {}\n", e.what());
    return kExitRuntime;
  }
  return 0;
}
