// meniscus — the --stats document: counts, stage times, what the smoothing did, every parameter.
#include <nlohmann/json.hpp>

#include "meniscus/parameters.hpp"
#include "meniscus/reconstruct.hpp"

namespace meniscus {

double Stats::total_seconds() const {
  double t = 0;
  for (const StageTime& s : stages) t += s.seconds;
  return t;
}

std::string stats_to_json(const Result& result) {
  const Stats& s = result.stats;
  const Params& p = result.params;
  nlohmann::ordered_json j;
  j["meniscus"] = version();
  j["particles"] = s.particles;
  j["vertices"] = s.vertices;
  j["triangles"] = s.triangles;
  j["pinhole_bridges"] = s.pinhole_bridges;
  j["closed_handles"] = s.closed_handles;
  j["components"] = s.components;
  if (s.genus >= 0)
    j["genus"] = s.genus;
  else
    j["genus"] = nullptr;  // not closed
  j["field_blocks"] = s.field_blocks;
  j["dropped_triangles"] = s.dropped_triangles;
  j["removed_voids"] = s.removed_voids;
  j["removed_blobs"] = s.removed_blobs;
  j["removed_strays"] = s.removed_strays;
  j["particles_outside_box"] = s.particles_outside_box;
  j["clipped_triangles"] = s.clipped_triangles;
  j["cut_triangles"] = s.cut_triangles;
  j["cap_triangles"] = s.cap_triangles;
  j["cap_open_edges"] = s.cap_open_edges;
  j["decimated_triangles"] = s.decimated_triangles;
  j["decimate_error"] = s.decimate_error;
  j["decimate_rounds"] = s.decimate_rounds;
  j["flipped_triangles"] = s.flipped_triangles;
  j["ranks"] = 1;  // one process (an MPI run over K ranks says K: docs/cluster.md)
  j["threads"] = s.threads;
  j["threads_from"] = s.threads_from;
  j["max_memory_from"] = s.max_memory_from;
  j["backend"] = s.backend;
  j["peak_memory_bytes"] = s.peak_memory_bytes;
  j["total_seconds"] = s.total_seconds();
  nlohmann::ordered_json stages = nlohmann::ordered_json::object();
  for (const StageTime& t : s.stages) stages[t.name] = t.seconds;
  j["stages"] = stages;
  if (!s.device_calls.empty()) {  // the CUDA backend: what each stage asked of the device, and in all
    nlohmann::ordered_json calls = nlohmann::ordered_json::object();
    DeviceStageCalls total{"total"};
    for (const DeviceStageCalls& c : s.device_calls) {
      calls[c.name] = {{"launches", c.launches}, {"uploads", c.uploads}, {"downloads", c.downloads},
                       {"device_copies", c.device_copies}, {"memsets", c.memsets}, {"waits", c.waits}};
      total.launches += c.launches, total.uploads += c.uploads, total.downloads += c.downloads;
      total.device_copies += c.device_copies, total.memsets += c.memsets, total.waits += c.waits;
    }
    calls["total"] = {{"launches", total.launches}, {"uploads", total.uploads}, {"downloads", total.downloads},
                      {"device_copies", total.device_copies}, {"memsets", total.memsets}, {"waits", total.waits}};
    j["device_calls"] = calls;
  }
  if (s.temporal.applied)
    j["temporal_smoothing"] = {{"applied", true},
                               {"matched", s.temporal.matched},
                               {"clamped", s.temporal.clamped},
                               {"mean_shift", s.temporal.mean_shift},
                               {"max_shift", s.temporal.max_shift}};
  else if (!s.temporal.skipped.empty())
    j["temporal_smoothing"] = {{"applied", false}, {"skipped", s.temporal.skipped}};
  j["smoothing"] = {{"energy_start", s.smoothing.energy_start},
                    {"energy_final", s.smoothing.energy_final},
                    {"damped_vertices", s.smoothing.damped_vertices},
                    {"relax_b_min", s.smoothing.relax_b_min},
                    {"batches", s.smoothing.batches},
                    {"setup_seconds", s.smoothing.setup_seconds},
                    {"a_sweeps_seconds", s.smoothing.a_sweeps_seconds},
                    {"b_sweeps_seconds", s.smoothing.b_sweeps_seconds}};
  // Every parameter of the table, in its order (a --stats file replays as a --config file).
  nlohmann::ordered_json q = nlohmann::ordered_json::object();
  for (const ParamSpec& spec : parameter_table()) {
    if (spec.control) continue;
    const nlohmann::json value = get_parameter(p, spec);
    if (spec.type == ParamType::numbers && value.empty()) continue;  // the boxes, only when given
    q[std::string(spec.key)] = nlohmann::ordered_json::parse(value.dump());
    if (spec.key == "spacing") {
      q["spacing_estimated"] = s.spacing_estimated;
      if (!s.estimated_on.empty()) q["estimated_on"] = s.estimated_on;
    }
  }
  j["parameters"] = q;
  j["warnings"] = s.warnings;
  return j.dump(2);
}

}  // namespace meniscus
