// meniscus CLI — `meniscus inspect`: the quality metrics of a mesh or of a sequence of meshes.
#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <charconv>
#include <cmath>
#include <optional>

#include "cli.hpp"
#include "inspect.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "meniscus/messages.hpp"
#include "meniscus/quality.hpp"
#include "meniscus/reconstruct.hpp"
#include "meniscus/sequence.hpp"

namespace meniscus::cli {

namespace {


/// A finished sequence's meshes (a pattern): each frame's counts and topology and, with --flicker,
/// the distance of its vertices to the previous frame's surface, as `meniscus surface` measures
/// it during a run, for sequences surfaced in pieces (a job array's tasks do not see each other's
/// frames). The search cap: --flicker-cap, else 4 spacings (--spacing, or estimated on the first
/// frame of --particles), else 16 mean edges of the previous mesh.
int run_inspect_sequence(const InspectArgs& a, const FramePattern& pattern) {
  if (!a.previous.empty()) throw InvalidParameter("--previous: a sequence's frames are compared with each other (--flicker)");
  const std::vector<int> frames = a.frames.empty() ? discover_frames(pattern) : parse_frame_ranges(a.frames);
  if (frames.empty())
    throw IoError(fmt::format("no file matches '{}' (the placeholder is replaced by frame numbers)", printable(a.mesh)));
  double spacing = a.spacing;
  if (spacing == 0 && !a.particles.empty()) {
    const auto particles = parse_frame_pattern(a.particles);
    const std::string first = particles ? particles->format(frames.front()) : a.particles;
    Params in;
    spacing = resolve_params(read_particles(first), in).spacing;
  }
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  // With --flicker a frame's report waits for the next frame, which its jitter needs: the meshes
  // of the frame before, the frame and the frame after are held (three at a time).
  std::optional<TriangleMesh> earlier, previous;
  int previous_frame = 0;
  double flicker_sum = 0, flicker_max = 0;
  std::size_t pairs = 0, not_watertight = 0, beyond_cap = 0;
  std::vector<double> jitters;  // each measured frame's median, in d (or the meshes' units)
  const double unit = spacing > 0 ? spacing : 1.0;
  const std::string unit_name = spacing > 0 ? " d" : "";
  std::optional<std::pair<nlohmann::ordered_json, std::string>> waiting;  // the previous frame's report
  const auto emit = [&](std::pair<nlohmann::ordered_json, std::string>&& report) {
    if (!a.json) fmt::print("{}\n", report.second);
    list.push_back(std::move(report.first));
  };
  for (const int frame : frames) {
    const std::string file = pattern.format(frame);
    TriangleMesh mesh = read_mesh(file);
    const TopologyReport t = analyze_topology(mesh);
    not_watertight += t.watertight() ? 0 : 1;
    nlohmann::ordered_json j = {{"frame", frame}, {"mesh", file}, {"vertices", mesh.vertices.size()},
                                {"triangles", mesh.triangles.size()}, {"watertight", t.watertight()},
                                {"components", t.components},
                                {"genus", t.watertight() ? nlohmann::ordered_json(t.genus()) : nlohmann::ordered_json(nullptr)}};
    std::string line = fmt::format("frame {}: {} vertices, {} triangles, {}", frame, mesh.vertices.size(),
                                   mesh.triangles.size(), t.watertight() ? "watertight" : "NOT watertight");
    if (t.watertight()) line += fmt::format(", {} component(s), genus {}", t.components, t.genus());
    if (a.flicker && previous) {
      double cap = a.flicker_cap == 0 ? INFINITY : a.flicker_cap;
      if (a.flicker_cap < 0) cap = spacing > 0 ? kFlickerCapSpacings * spacing : kFlickerCapEdges * mean_edge_length(*previous);
      const SurfaceDistanceReport f = distance_to_surface(mesh.vertices, *previous, cap);
      j["flicker"] = {{"previous_frame", previous_frame}};
      j["flicker"].update(flicker_json(f));
      flicker_sum += f.mean, flicker_max = std::max(flicker_max, f.max), ++pairs;
      line += fmt::format("; flicker against frame {}: mean {:.4g}, max {:.4g}", previous_frame, f.mean, f.max);
      if (f.beyond_cap > 0)
        line += fmt::format(" ({} vertices farther than the search's cap {:.4g}, counted at it)", f.beyond_cap, f.cap);
      beyond_cap += f.beyond_cap;
      // The previous frame's jitter, between the one before it and this one.
      if (earlier && waiting) {
        const JitterReport r = surface_jitter(*earlier, *previous, mesh, kJitterPoints, uint32_t(previous_frame), cap);
        waiting->first["jitter"] = {{"median", r.median / unit}, {"p90", r.p90 / unit}, {"points", r.points},
                                    {"beyond_cap", r.beyond_cap}, {"unit", spacing > 0 ? "d" : "mesh"}};
        waiting->second += fmt::format("; jitter median {:.4g}{}, p90 {:.4g}{}", r.median / unit, unit_name,
                                       r.p90 / unit, unit_name);
        if (r.points > 0) jitters.push_back(r.median / unit);
      }
    }
    if (waiting) emit(std::move(*waiting));
    waiting = std::pair{std::move(j), std::move(line)};
    if (a.flicker) earlier = std::move(previous), previous = std::move(mesh), previous_frame = frame;
  }
  if (waiting) emit(std::move(*waiting));
  nlohmann::ordered_json summary = {{"frames", frames.size()}, {"not_watertight", not_watertight}};
  const SequenceJitter jitter = sequence_jitter(std::move(jitters));
  if (a.flicker) {
    summary["flicker"] = {{"pairs", pairs}, {"mean", pairs ? flicker_sum / double(pairs) : 0.0}, {"max", flicker_max},
                          {"beyond_cap", beyond_cap}};
    summary["jitter"] = {{"frames", jitter.frames}, {"median", jitter.median}, {"max", jitter.max},
                         {"unit", spacing > 0 ? "d" : "mesh"}};
  }
  if (a.json) {
    fmt::print("{}\n", nlohmann::ordered_json{{"sequence", a.mesh}, {"summary", summary}, {"frames", list}}.dump(2));
    return 0;
  }
  fmt::print("{} frames, {} not watertight", frames.size(), not_watertight);
  if (a.flicker) {
    fmt::print("; flicker mean {:.4g} over {} frame pairs, max {:.4g}{}", pairs ? flicker_sum / double(pairs) : 0.0, pairs,
               flicker_max, beyond_cap ? fmt::format(" ({} vertices at the search's cap)", beyond_cap) : std::string());
    if (jitter.frames > 0)
      fmt::print("; jitter (the flicker without the motion) median {:.4g}{} over {} frames, largest {:.4g}{}", jitter.median,
                 unit_name, jitter.frames, jitter.max, unit_name);
  }
  fmt::print("\n");
  return 0;
}

}  // namespace

/// Quality metrics of any mesh (docs/cli.md "meniscus inspect"), ours or another tool's.
int run_inspect(const InspectArgs& a) {
  if (const auto pattern = parse_frame_pattern(a.mesh)) return run_inspect_sequence(a, *pattern);
  if (!a.frames.empty() || a.flicker)
    throw InvalidParameter("--frames and --flicker need a mesh pattern with a frame placeholder (mesh_####.ply)");
  const TriangleMesh mesh = read_mesh(a.mesh);
  if (mesh.triangles.empty())
    throw InputError(fmt::format("'{}' holds {} points and no triangles: a point cloud, not a surface; inspect measures "
                                 "meshes (meniscus surface makes one from particles)",
                                 printable(a.mesh), mesh.vertices.size()));
  const TopologyReport t = analyze_topology(mesh);
  const ValenceReport v = valence(mesh);
  const AngleReport angles = triangle_angles(mesh);
  nlohmann::ordered_json j;
  j["mesh"] = a.mesh;
  j["vertices"] = mesh.vertices.size();
  j["triangles"] = mesh.triangles.size();
  j["topology"] = {{"watertight", t.watertight()}, {"closed", t.closed()}, {"edge_manifold", t.edge_manifold()},
                   {"vertex_manifold", t.nonmanifold_vertices == 0}, {"oriented", t.oriented()},
                   {"components", t.components}, {"euler", t.euler},
                   {"genus", t.watertight() ? nlohmann::ordered_json(t.genus()) : nlohmann::ordered_json(nullptr)},
                   {"boundary_edges", t.boundary_edges},
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
  fmt::print("{}: {} vertices, {} triangles\n", printable(a.mesh), mesh.vertices.size(), mesh.triangles.size());
  fmt::print("topology: {} — {} component(s), Euler characteristic {}{}; {} boundary, {} non-manifold, {} misoriented edges; "
             "{} non-manifold vertices; {} degenerate triangles\n",
             t.watertight() ? "watertight" : "NOT watertight", t.components, t.euler,
             t.watertight() ? fmt::format(", genus {} (holes and tunnels through it)", t.genus()) : "", t.boundary_edges,
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

namespace {

/// A finite number ≥ 0, said plainly when it is not (CLI11's own ranges print DBL_MAX in full).
const CLI::Validator kNonNegative(
    [](std::string& text) -> std::string {
      double v = 0;
      const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
      const bool ok = ec == std::errc() && end == text.data() + text.size() && std::isfinite(v) && v >= 0;
      return ok ? std::string() : fmt::format("'{}' is not a finite number ≥ 0", text);
    },
    "≥ 0");

}  // namespace

CLI::App* add_inspect_command(CLI::App& app, InspectArgs& inspect) {
  CLI::App* cmd = app.add_subcommand("inspect", "quality metrics of a mesh: topology, valence, angles, constraints");
  cmd->add_option("mesh", inspect.mesh, "mesh file (.ply, .obj, .vtk, .bgeo …), or a sequence pattern (mesh_####.ply)")
      ->required();
  cmd->add_option("--frames", inspect.frames, "frames of a sequence: 1-240, 1-240:2, 1,5,10-20 (default: all found)");
  cmd->add_flag("--flicker", inspect.flicker,
                "a sequence: each frame's flicker against the one before it in the list (as surface measures it)");
  cmd->add_option("--particles", inspect.particles, "the particles it was made from: constraint residual, "
                                                    "particles left outside (a sequence: the spacing for "
                                                    "the flicker cap, estimated on the first frame)");
  cmd->add_option("--spacing", inspect.spacing, "particle spacing (default: estimated)")->check(kNonNegative);
  cmd->add_option("--r-inner", inspect.r_inner, "inner constraint radius (default 0.5 r_outer)")
      ->check(kNonNegative);
  cmd->add_option("--r-outer", inspect.r_outer, "outer constraint radius (default 1.0 d)")->check(kNonNegative);
  cmd->add_option("--previous", inspect.previous,
                  "the previous frame's mesh: flicker = distance of each vertex to its surface");
  cmd->add_option("--flicker-cap", inspect.flicker_cap,
                  "with --previous: distances are searched up to this far, farther vertices count at it "
                  "(default 4 spacings, or 16 mean edges of the previous mesh; 0: no cap)")
      ->check(kNonNegative);
  cmd->add_flag("--json", inspect.json, "print the metrics as JSON");
  return cmd;
}

}  // namespace meniscus::cli
