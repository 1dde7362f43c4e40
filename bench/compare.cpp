// meniscus bench — meniscus vs the OpenVDB baseline on the same particles, voxel size and
// radius: per-stage times, ratios, throughput, memory and mesh quality side by side (issue #4).
#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "memory.hpp"
#include "meniscus/io.hpp"
#include "meniscus/memory.hpp"
#include "meniscus/quality.hpp"
#include "meniscus/reconstruct.hpp"
#include "metrics.hpp"
#include "openvdb_baseline.hpp"
#include "scenes.hpp"

using namespace meniscus;
using namespace meniscus::bench;

namespace {

// One column of the table: a tool + configuration, its stage times and its mesh.
struct Column {
  std::string name;
  std::vector<StageTime> stages;
  std::vector<StageTime> smooth_parts;  ///< the smoothing stage's set-up, A and B sweeps (meniscus)
  double total = 0;
  std::size_t peak_delta = 0;
  MeshQuality quality;
  // Throughputs (0: not applicable to this column).
  double voxels_per_s = 0, iterations_per_s = 0;
  std::size_t field_samples = 0;
  TriangleMesh mesh;             ///< kept for meniscus' full and decimated columns (their distance)
  double distance_to_full = -1;  ///< the decimated column: the largest distance to the full mesh / d
};

/// The vertices of `mesh` and `count` random points on its triangles.
std::vector<Vec3f> points_on(const TriangleMesh& mesh, std::size_t count) {
  std::vector<Vec3f> points = mesh.vertices, random = random_surface_points(mesh, count, 1);
  points.insert(points.end(), random.begin(), random.end());
  return points;
}

/// The largest distance between two meshes, both ways: every vertex and `count` random points of
/// each to the other (Embree's BVH, exact point–triangle distances).
double distance_between(const TriangleMesh& a, const TriangleMesh& b, std::size_t count) {
  return std::max(distance_to_surface(points_on(a, count), b).max, distance_to_surface(points_on(b, count), a).max);
}

Column run_meniscus(const std::string& name, const Scene& scene, const Params& params, int repeat,
                    std::size_t samples) {
  Column c;
  c.name = name;
  Result best;
  for (int i = 0; i < repeat; ++i) {
    const std::size_t base = begin_peak_measurement();
    Result r = reconstruct(scene.particles, params);
    const std::size_t peak = peak_delta_bytes(base);
    if (i == 0 || r.stats.total_seconds() < best.stats.total_seconds()) {
      best = std::move(r);
      c.peak_delta = peak;
    }
  }
  c.stages = best.stats.stages;
  const SmoothingStats& sm = best.stats.smoothing;
  c.smooth_parts = {{"setup", sm.setup_seconds}, {"A sweeps", sm.a_sweeps_seconds}, {"B sweeps", sm.b_sweeps_seconds}};
  c.total = best.stats.total_seconds();
  c.quality = measure_quality(best.mesh, scene, samples);
  c.mesh = std::move(best.mesh);
  const int sweeps = best.params.steps_a + best.params.steps_b + best.params.steps_free;
  c.field_samples = best.stats.field_blocks * 512;
  for (const StageTime& s : c.stages) {
    if (s.name == "field" && s.seconds > 0) c.voxels_per_s = double(c.field_samples) / s.seconds;
    if (s.name == "smooth" && s.seconds > 0 && sweeps > 0)
      c.iterations_per_s = double(best.stats.vertices) * sweeps / s.seconds;
  }
  return c;
}

Column run_vdb(const std::string& name, const Scene& scene, const VdbOptions& options, int repeat,
               std::size_t samples) {
  Column c;
  c.name = name;
  VdbResult best;
  for (int i = 0; i < repeat; ++i) {
    VdbResult r = run_openvdb(scene.particles.positions, options);
    if (i == 0 || r.total_seconds() < best.total_seconds()) best = std::move(r);
  }
  c.stages = {{"rasterize", best.rasterize_seconds}, {"filter", best.filter_seconds}, {"mesh", best.mesh_seconds}};
  c.total = best.total_seconds();
  c.peak_delta = best.peak_delta_bytes;
  c.quality = measure_quality(best.mesh, scene, samples);
  c.field_samples = best.active_voxels;
  if (best.rasterize_seconds > 0) c.voxels_per_s = double(best.active_voxels) / best.rasterize_seconds;
  if (best.filter_seconds > 0 && options.filter_passes > 0)
    c.iterations_per_s = double(best.active_voxels) * options.filter_passes / best.filter_seconds;
  return c;
}

double stage_seconds(const Column& c, const std::string& stage) {
  for (const StageTime& s : c.stages)
    if (s.name == stage) return s.seconds;
  return -1;
}

std::string fmt_time(double s) { return s < 0 ? "-" : fmt::format("{:.3f}", s); }
std::string fmt_rate(double r) { return r <= 0 ? "-" : fmt::format("{:.3g}", r); }

void print_table(const Scene& scene, const Params& p, const std::vector<Column>& cols) {
  fmt::print("\n== {}: {} particles, d = {:g}, h = {:g}, r_outer = {:g}, r_inner = {:g}\n", scene.name,
             scene.particles.size(), p.spacing, p.voxel_size, p.r_outer, p.r_inner);
  const auto row = [&](const std::string& label, auto&& cell) {
    std::string line = fmt::format("{:<26}", label);
    for (const Column& c : cols) line += fmt::format(" {:>17}", cell(c));
    fmt::print("{}\n", line);
  };
  row("", [](const Column& c) { return c.name; });
  // The union of stage names, in the order they first appear.
  std::vector<std::string> stages;
  for (const Column& c : cols)
    for (const StageTime& s : c.stages)
      if (std::find(stages.begin(), stages.end(), s.name) == stages.end()) stages.push_back(s.name);
  for (const std::string& s : stages) {
    row("  " + s + " [s]", [&](const Column& c) { return fmt_time(stage_seconds(c, s)); });
    if (s != "smooth") continue;
    for (const char* part : {"setup", "A sweeps", "B sweeps"})
      row(fmt::format("    {} [s]", part), [&](const Column& c) {
        for (const StageTime& t : c.smooth_parts)
          if (t.name == part && stage_seconds(c, "smooth") > 0) return fmt_time(t.seconds);
        return fmt_time(-1);
      });
  }
  row("total [s]", [](const Column& c) { return fmt_time(c.total); });
  row("peak RSS delta [MB]", [](const Column& c) { return fmt::format("{:.0f}", double(c.peak_delta) / 1e6); });
  row("particles/s", [&](const Column& c) { return fmt_rate(double(scene.particles.size()) / c.total); });
  row("voxels/s (field/raster)", [](const Column& c) { return fmt_rate(c.voxels_per_s); });
  row("iterations/s (smooth/filt)", [](const Column& c) { return fmt_rate(c.iterations_per_s); });
  row("vertices", [](const Column& c) { return std::to_string(c.quality.vertices); });
  row("triangles", [](const Column& c) { return std::to_string(c.quality.triangles); });
  row("components", [](const Column& c) { return std::to_string(c.quality.components); });
  row("watertight", [](const Column& c) { return std::string(c.quality.watertight ? "yes" : "no"); });
  row("genus", [](const Column& c) { return c.quality.genus < 0 ? std::string("-") : std::to_string(c.quality.genus); });
  row("volume / (N d^3)", [](const Column& c) { return fmt::format("{:.3f}", c.quality.volume_over_nd3); });
  row("min valence", [](const Column& c) { return std::to_string(c.quality.min_valence); });
  row("valence < 5 [%]", [](const Column& c) { return fmt::format("{:.2f}", 100 * c.quality.share_valence_below_5); });
  row("min angle [deg]", [](const Column& c) { return fmt::format("{:.2f}", c.quality.min_angle_degrees); });
  row("angles < 10 deg [%]", [](const Column& c) { return fmt::format("{:.2f}", 100 * c.quality.share_angles_below_10); });
  row("particles outside", [](const Column& c) { return fmt::format("{}/{}", c.quality.outside, c.quality.sampled); });
  row("distance to full / d", [](const Column& c) {
    return c.distance_to_full < 0 ? std::string("-") : fmt::format("{:.4f}", c.distance_to_full);
  });
  if (scene.has_flat_top)
    row("top flatness RMS/d", [](const Column& c) {
      return c.quality.flatness_rms_over_d < 0 ? std::string("-") : fmt::format("{:.4f}", c.quality.flatness_rms_over_d);
    });
}

}  // namespace

int main(int argc, char** argv) {
  // As the CLI does; the same for both tools, which run in this process.
  meniscus::release_large_blocks_eagerly();
  meniscus::reuse_freed_blocks_between_stages();
  CLI::App app{"meniscus vs OpenVDB (ParticlesToLevelSet + LevelSetFilter + volumeToMesh) on the same particles"};
  std::string scene_name = "block", file;
  std::size_t count = 100000, samples = 2000;
  int repeat = 1, filter_passes = 4;
  std::string write_particles;
  bool json = false;
  double decimate = 0;
  app.add_option("--scene", scene_name, "synthetic scene: block | sphere | splash");
  app.add_option("--count", count, "particles of the synthetic scene");
  app.add_option("--file", file, "a particle file instead of a synthetic scene (spacing estimated)");
  app.add_option("--repeat", repeat, "runs per configuration; the fastest is reported")->check(CLI::PositiveNumber);
  app.add_option("--filter-passes", filter_passes, "mean-curvature passes of the filtered OpenVDB run");
  bool warmup = true;
  app.add_flag("!--no-warmup", warmup, "time the first run of each tool too (by default one untimed run of each comes first)");
  app.add_option("--samples", samples, "particles tested for being outside each mesh");
  app.add_flag("--json", json, "print JSON instead of the table");
  app.add_option("--decimate", decimate,
                 "also meniscus with --decimate E, its largest distance to the full mesh measured both ways, and the "
                 "fewest triangles any mesh within E and within 0.01 d of the full one can have")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--write-particles", write_particles,
                 "write the scene's particles (.ply point cloud) and exit: the same data for `meniscus surface`, "
                 "perf or callgrind");
  std::string write_vdb_mesh;
  double spacing = 0;
  app.add_option("--write-vdb-mesh", write_vdb_mesh,
                 "surface the scene with OpenVDB + the filter passes only, write that mesh and exit: a sequence's "
                 "frames for `meniscus inspect PATTERN --flicker` (bench/jitter.sh)");
  app.add_option("--spacing", spacing, "the particle spacing d instead of the estimate (one d for a sequence's frames)")
      ->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);

  try {
    Scene scene;
    Params base;
    if (!file.empty()) {
      scene.name = std::filesystem::path(file).filename().string();
      scene.particles.positions = read_particles(file).positions;  // attributes are not benchmarked
      // Estimated once here, outside the timed runs, so both tools get the same d and
      // meniscus' "parameters" stage does not charge it the estimation OpenVDB is spared.
      base.spacing = spacing > 0 ? spacing : estimate_spacing(scene.particles);
      scene.spacing = float(base.spacing);
    } else {
      scene = make_scene(scene_name, count);
      base.spacing = scene.spacing;
    }
    if (!write_particles.empty()) {
      TriangleMesh points;  // a mesh without triangles: a .ply point cloud the readers take back
      points.vertices = scene.particles.positions;
      write_mesh(write_particles, points);
      fmt::print("{}: {} particles, spacing {}\n", write_particles, scene.particles.size(), scene.spacing);
      return 0;
    }
    const Params p = resolve_params(scene.particles, base);
    if (!write_vdb_mesh.empty()) {
      VdbOptions only;
      only.voxel_size = p.voxel_size;
      only.radius = p.r_outer;
      only.filter_passes = filter_passes;
      const VdbResult r = run_openvdb(scene.particles.positions, only);
      write_mesh(write_vdb_mesh, r.mesh);
      fmt::print("{}: {} triangles in {:.3f} s (d = {})\n", write_vdb_mesh, r.mesh.triangles.size(), r.total_seconds(),
                 p.spacing);
      return 0;
    }

    Params no_smooth = base;
    no_smooth.steps_a = no_smooth.steps_b = no_smooth.steps_free = 0;
    VdbOptions vdb;
    vdb.voxel_size = p.voxel_size;
    vdb.radius = p.r_outer;
    VdbOptions vdb_filtered = vdb;
    vdb_filtered.filter_passes = filter_passes;

    // One untimed run of each tool right before its timed ones: the first surfacing in a process
    // pays for the thread pool's start and the allocator's first growth, which a frame of a
    // sequence never sees; and a tool's first run after the other tool's inherits that tool's
    // heap (OpenVDB's freed tree nodes, meniscus' freed arrays), which a sequence of one tool's
    // frames never does either, and which slows the run that follows (bench/RESULTS.md#caveats).
    std::vector<Column> cols;
    if (warmup) (void)reconstruct(scene.particles, no_smooth);
    cols.push_back(run_meniscus("meniscus-nosmooth", scene, no_smooth, repeat, samples));
    cols.push_back(run_meniscus("meniscus-full", scene, base, repeat, samples));
    if (warmup) (void)run_openvdb(scene.particles.positions, vdb);
    cols.push_back(run_vdb("vdb", scene, vdb, repeat, samples));
    cols.push_back(run_vdb(fmt::format("vdb-filter{}", filter_passes), scene, vdb_filtered, repeat, samples));
    if (decimate > 0) {
      Params lean = base;
      lean.decimate = decimate;
      cols.push_back(run_meniscus(fmt::format("meniscus-dec{:g}", decimate), scene, lean, repeat, samples));
      cols.back().distance_to_full = distance_between(cols.back().mesh, cols[1].mesh, 200000) / p.spacing;
    }
    // The fewest triangles any mesh within E (and within 0.01 d, the lean goal's bound) of the full
    // one can have, from the curvature of its convex parts: what the counts are measured against.
    std::vector<std::pair<double, double>> least;
    if (decimate > 0)
      for (double e : {decimate, 0.01}) least.push_back({e, least_triangles_within(cols[1].mesh, e * p.spacing)});

    const double vdb_plain = cols[2].total, vdb_filt = cols[3].total;
    const double ratio_nosmooth = cols[0].total / vdb_plain, ratio_full = cols[1].total / vdb_filt;
    const double ratio_mem = cols[3].peak_delta ? double(cols[1].peak_delta) / double(cols[3].peak_delta) : 0;

    if (json) {
      nlohmann::ordered_json j;
      j["scene"] = scene.name;
      j["particles"] = scene.particles.size();
      j["spacing"] = p.spacing;
      j["voxel_size"] = p.voxel_size;
      j["r_outer"] = p.r_outer;
      j["r_inner"] = p.r_inner;
      j["threads"] = p.threads;
      for (const Column& c : cols) {
        nlohmann::ordered_json k;
        nlohmann::ordered_json st = nlohmann::ordered_json::object();
        for (const StageTime& s : c.stages) st[s.name] = s.seconds;
        k["stages"] = st;
        if (!c.smooth_parts.empty()) {
          nlohmann::ordered_json parts = nlohmann::ordered_json::object();
          for (const StageTime& s : c.smooth_parts) parts[s.name] = s.seconds;
          k["smooth_parts"] = parts;
        }
        k["total_seconds"] = c.total;
        k["peak_rss_delta_bytes"] = c.peak_delta;
        k["particles_per_s"] = double(scene.particles.size()) / c.total;
        k["voxels_per_s"] = c.voxels_per_s;
        k["iterations_per_s"] = c.iterations_per_s;
        const MeshQuality& q = c.quality;
        k["quality"] = {{"vertices", q.vertices},
                        {"triangles", q.triangles},
                        {"components", q.components},
                        {"watertight", q.watertight},
                        {"genus", q.genus},
                        {"volume_over_particle_volume", q.volume_over_nd3},
                        {"min_valence", q.min_valence},
                        {"share_valence_below_5", q.share_valence_below_5},
                        {"min_angle_degrees", q.min_angle_degrees},
                        {"share_angles_below_10", q.share_angles_below_10},
                        {"particles_outside", q.outside},
                        {"particles_sampled", q.sampled},
                        {"flatness_rms_over_d", q.flatness_rms_over_d}};
        if (c.distance_to_full >= 0) k["distance_to_full_over_d"] = c.distance_to_full;
        j["runs"][c.name] = k;
      }
      for (const auto& [e, n] : least) j["least_triangles_within"][fmt::format("{:g}", e)] = std::llround(n);
      j["ratios"] = {{"nosmooth_over_vdb", ratio_nosmooth},
                     {"full_over_vdb_filtered", ratio_full},
                     {"memory_full_over_vdb_filtered", ratio_mem}};
      fmt::print("{}\n", j.dump(2));
    } else {
      print_table(scene, p, cols);
      fmt::print("ratio meniscus-nosmooth / vdb        {:.2f}x  (target <= 0.5)\n", ratio_nosmooth);
      fmt::print("ratio meniscus-full / vdb-filter{}    {:.2f}x  (target <= 1.0)\n", filter_passes, ratio_full);
      fmt::print("memory meniscus-full / vdb-filter{}   {:.2f}x  (target <= 1.5)\n", filter_passes, ratio_mem);
      for (const auto& [e, n] : least)
        fmt::print("fewest triangles within {:g} d of meniscus-full (its convex parts' curvature): {:.0f}\n", e, n);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "meniscus_bench_compare: %s\n", e.what());
    return 1;
  }
  return 0;
}
