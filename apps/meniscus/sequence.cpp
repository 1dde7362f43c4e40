// meniscus CLI — `meniscus surface` of a sequence: every frame of a pattern, one progress bar,
// failed frames reported and skipped, each frame's flicker against the one before it.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <mutex>
#include <thread>
#include <utility>

#include "cli.hpp"
#include "help.hpp"
#include "common/clock.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/messages.hpp"
#include "meniscus/quality.hpp"
#include "progress.hpp"
#include "surface.hpp"

namespace meniscus::cli {

namespace {

/// Frame-to-frame flicker of a sequence (docs/method.md): each surfaced frame is compared with
/// the one before it in the frame list (when both succeeded), whatever order the jobs finish in;
/// a mesh is kept only until both of its pairs are settled. Not thread-safe: callers hold a lock.
class SequenceFlicker {
 public:
  explicit SequenceFlicker(std::size_t frames) : status_(frames, kPending), flicker_(frames), jitter_(frames) {}
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
    // A frame's jitter (surface_jitter): its mesh between the frames before and after it.
    for (std::size_t k = i == 0 ? 0 : i - 1; k <= i + 1; ++k) {
      if (k == 0 || k + 1 >= status_.size() || jitter_[k]) continue;
      if (status_[k - 1] != kDone || status_[k] != kDone || status_[k + 1] != kDone) continue;
      const auto t0 = std::chrono::steady_clock::now();
      jitter_[k] = Jitter{surface_jitter(meshes_.at(k - 1), meshes_.at(k), meshes_.at(k + 1), kJitterPoints,
                                         uint32_t(k), caps_.at(k)),
                          0};
      jitter_[k]->seconds = seconds_since(t0);
    }
    // Drop the meshes no pair or triple needs any more: those of frames whose two neighbours on
    // each side are settled.
    for (std::size_t k = i < 2 ? 0 : i - 2; k <= i + 2; ++k) {
      if (k >= status_.size() || !meshes_.count(k)) continue;
      bool settled = true;
      for (std::size_t n = k < 2 ? 0 : k - 2; n <= k + 2 && n < status_.size(); ++n) settled = settled && status_[n] != kPending;
      if (settled) meshes_.erase(k), caps_.erase(k);
    }
    return known;
  }
  struct Measured {
    SurfaceDistanceReport report;
    double seconds;
  };
  const std::optional<Measured>& flicker(std::size_t k) const { return flicker_[k]; }
  struct Jitter {
    JitterReport report;
    double seconds;
  };
  const std::optional<Jitter>& jitter(std::size_t k) const { return jitter_[k]; }

 private:
  enum Status : char { kPending, kDone, kFailed };
  std::vector<Status> status_;
  std::map<std::size_t, TriangleMesh> meshes_;
  std::map<std::size_t, double> caps_;
  std::vector<std::optional<Measured>> flicker_;
  std::vector<std::optional<Jitter>> jitter_;
};

/// Adds the flicker against the previous frame to a frame's stats file.
void add_flicker_to_stats(const std::string& path, int previous_frame, const SequenceFlicker::Measured& f) {
  nlohmann::ordered_json j = nlohmann::ordered_json::parse(read_text_file(path));
  j["flicker"] = {{"previous_frame", previous_frame}};
  j["flicker"].update(flicker_json(f.report));
  j["flicker"]["seconds"] = f.seconds;
  write_text_file(path, j.dump(2) + "\n");
}

}  // namespace

nlohmann::ordered_json flicker_json(const SurfaceDistanceReport& f) {
  nlohmann::ordered_json j = {{"mean", f.mean}, {"p95", f.p95}, {"max", f.max}, {"beyond_cap", f.beyond_cap}};
  j["cap"] = std::isfinite(f.cap) ? nlohmann::ordered_json(f.cap) : nlohmann::ordered_json(nullptr);
  j["triangle_tests"] = f.triangle_tests;
  return j;
}

SequenceJitter sequence_jitter(std::vector<double> medians) {
  SequenceJitter j;
  j.frames = medians.size();
  if (medians.empty()) return j;
  std::sort(medians.begin(), medians.end());
  j.median = medians[(medians.size() - 1) / 2];
  j.max = medians.back();
  return j;
}

int run_sequence(const SurfaceArgs& given, const FramePattern& in) {
  SurfaceArgs a = given;
  const auto out = parse_frame_pattern(a.output);
  if (!out)
    throw InvalidParameter(fmt::format("output '{}' needs a frame placeholder (####, {{}} or %04d) like the input",
                                       printable(a.output)));
  std::optional<FramePattern> stats, preview, field;
  for (auto [path, pattern] :
       {std::pair{&a.stats_path, &stats}, std::pair{&a.preview_path, &preview}, std::pair{&a.field_path, &field}}) {
    if (path->empty()) continue;
    *pattern = parse_frame_pattern(*path);
    if (!*pattern) throw InvalidParameter(fmt::format("'{}' needs a frame placeholder in a sequence", printable(*path)));
  }
  std::vector<int> frames = a.frames.empty() ? discover_frames(in) : parse_frame_ranges(a.frames);
  if (frames.empty())
    throw IoError(fmt::format("no file matches '{}': the frames are looked up by replacing the placeholder with "
                              "numbers (e.g. '{}')",
                              printable(a.input), printable(in.format(1))));
  // Temporal smoothing reads the frames either side from disk, whether or not they are in the
  // list: a frame's mesh is the same in any chunk of the sequence.
  const auto files_of = [&](int frame) {
    FrameFiles f{in.format(frame), out->format(frame), stats ? stats->format(frame) : "",
                 preview ? preview->format(frame) : "", field ? field->format(frame) : ""};
    if (a.params.temporal_smoothing > 0) {
      for (const auto& [path, neighbour] : {std::pair{&f.previous, frame - 1}, std::pair{&f.next, frame + 1}}) {
        const std::string name = in.format(neighbour);
        if (std::filesystem::exists(name)) *path = name;
        else if (f.no_neighbours.empty())
          f.no_neighbours = fmt::format("frame {} is not on disk ({})", neighbour, printable(name));
      }
      if (!f.no_neighbours.empty()) f.previous.clear(), f.next.clear();
    }
    return f;
  };
  // Every frame's files before any work: an output pattern that names an input frame, or two
  // outputs that meet, are refused whole.
  {
    std::vector<RunFile> files = {{a.config_path, "--config", false}};
    for (const int frame : frames) add_frame_files(files, files_of(frame));
    check_run_files(files);
  }
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
      return kExitOk;
    }
  }
  const int jobs = std::max(1, std::min<int>(a.jobs, int(frames.size())));
  // The frames surfaced at once share the memory limit.
  const double memory_share = 1.0 / jobs;
  a.params.max_memory_gb = memory_limit_bytes(a.params.max_memory_gb) * memory_share / 1e9;

  // The frame-wide estimates (spacing, rest density, reference speed) not given are made on the
  // first frame that reads and used for every frame: re-estimated per frame, a droplet appearing
  // anywhere would move the whole surface. That frame's particles are surfaced as read here; a
  // frame that does not read is reported with the others.
  const Params gp = a.params;
  Params estimated = gp;
  std::size_t first = 0;
  std::optional<ReadFrame> first_frame;
  for (; first < candidates.size() && !first_frame; ++first) {
    try {
      const auto t0 = std::chrono::steady_clock::now();
      ReadReport report;
      ParticleSet particles = read_particles(in.format(candidates[first]), read_options(a), &report);
      first_frame = ReadFrame{std::move(particles), seconds_since(t0), report.format};
    } catch (const std::exception& e) {
      if (a.estimates_from)  // a named frame must read: another frame would give other estimates
        throw IoError(fmt::format("--estimates-from {}: {}", *a.estimates_from, e.what()));
    }
  }
  const int estimate_frame = candidates[--first];
  if (first_frame) estimated = resolve_frame_estimates(first_frame->particles, gp);
  // Every preview of a sequence is drawn with one up axis: the one that frame shows.
  if (first_frame && preview && a.up == "auto") {
    const UpAxis up = preview_up_axis(a, first_frame->particles, first_frame->format);
    a.up = std::string(1, up.name());
    if (!a.quiet)
      fmt::print(stderr, "the previews' up axis: {} ({}, on frame {}; --up sets it)\n", up.name(), up.reason,
                 estimate_frame);
  }
  // The particles read are surfaced as they are when that frame is one to surface.
  const auto preread_at = std::find(frames.begin(), frames.end(), estimate_frame);
  first = std::size_t(preread_at - frames.begin());
  if (!(estimated == gp)) {
    a.estimated_on = in.format(estimate_frame);
    if (!a.quiet) {
      std::string what = fmt::format("spacing {:.6g}", estimated.spacing);
      if (estimated.rest_density != gp.rest_density) what += fmt::format(", rest density {:.6g}", estimated.rest_density);
      if (estimated.velocity_reference != gp.velocity_reference)
        what += fmt::format(", reference speed {:.6g}", estimated.velocity_reference);
      fmt::print(stderr, "estimated on frame {} and used for every frame: {}{}\n", estimate_frame, what,
                 gp.spacing == 0 ? " (set --spacing to override)" : "");
    }
  }
  a.params = estimated;

  const auto t0 = std::chrono::steady_clock::now();
  ProgressBar bar(!a.quiet, /*eta=*/true);
  std::mutex mutex;  // guards the bar, the report lines and the counters below
  std::vector<int> failed;
  std::size_t done = 0, triangles = 0, smoothed = 0;
  std::map<std::string, std::vector<int>> unsmoothed;  // why a frame was surfaced from its own positions
  std::atomic<std::size_t> next{0};
  std::atomic<bool> stop{false};
  SequenceFlicker flicker(frames.size());
  auto record_flicker = [&](std::size_t i, TriangleMesh* mesh, double spacing) {  // with the mutex held
    for (std::size_t k : flicker.settle(i, mesh, spacing))
      if (stats) add_flicker_to_stats(stats->format(frames[k]), frames[k - 1], *flicker.flicker(k));
  };
  auto worker = [&] {
    for (;;) {
      if (stop) return;
      const std::size_t i = next++;
      if (i >= frames.size()) return;
      const int frame = frames[i];
      try {
        std::optional<ReadFrame> preread;
        if (i == first) preread = std::exchange(first_frame, std::nullopt);
        Result r = surface_one(
            a, files_of(frame), false,
            [&](std::string_view stage, double fraction) {
              if (jobs > 1) return;
              std::lock_guard lock(mutex);
              bar.update(fmt::format("frame {} {}", frame, stage), (double(done) + fraction) / double(frames.size()));
            },
            std::move(preread));
        std::lock_guard lock(mutex);
        ++done;
        triangles += r.stats.triangles;
        if (r.stats.temporal.applied) ++smoothed;
        else if (!r.stats.temporal.skipped.empty()) unsmoothed[r.stats.temporal.skipped].push_back(frame);
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
        fmt::print(stderr, "meniscus: frame {}: error: {}\n", frame,
                   printable(dynamic_cast<const std::bad_alloc*>(&e) ? "out of memory" : e.what()));
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
  std::size_t flicker_count = 0, beyond_cap = 0, vertices = 0;
  for (std::size_t k = 0; k < frames.size(); ++k)
    if (const auto& f = flicker.flicker(k)) {
      flicker_sum += f->report.mean, flicker_max = std::max(flicker_max, f->report.max), ++flicker_count;
      flicker_seconds += f->seconds;
      beyond_cap += f->report.beyond_cap;
      vertices += f->report.count;
    }
  if (!a.quiet && flicker_count > 0) {
    // In spacings d, the unit every distance of the method is set in, and in the scene's units.
    const double d = a.params.spacing;
    const double mean = flicker_sum / double(flicker_count);
    fmt::print(stderr, "{}\n",
               wrap_text(fmt::format("change between frames (each vertex's distance to the previous frame's surface; "
                                     "the water's own motion included): mean {:.3g} d ({:.4g} scene units), max {:.3g} "
                                     "d, over {} frame pairs{}; measured in {:.3f} s",
                                     mean / d, mean, flicker_max / d, flicker_count,
                                     beyond_cap == 0 ? std::string()
                                                     : fmt::format(" ({} of {} vertices were farther than the search's "
                                                                   "cap of {} d and count at it)",
                                                                   beyond_cap, vertices, kFlickerCapSpacings),
                                     flicker_seconds),
                         kHelpColumns, kHelpColumns, 2));
  }
  if (!a.quiet && a.params.temporal_smoothing > 0 && ok > 0) {
    std::string others;
    for (auto& [why, list] : unsmoothed) {
      std::sort(list.begin(), list.end());
      others += fmt::format("; frame{} {}: {}", list.size() == 1 ? "" : "s", format_frame_ranges(list), why);
    }
    fmt::print(stderr, "{}\n",
               wrap_text(fmt::format("temporal smoothing (w = {:g}, particles matched by '{}' in the frames either "
                                     "side): {} of {} frames{}",
                                     a.params.temporal_smoothing, kParticleIdAttribute, smoothed, ok,
                                     others.empty() ? std::string() : "; from their own positions" + others),
                         kHelpColumns, kHelpColumns, 2));
  }
  std::vector<double> jitters;
  double jitter_seconds = 0;
  for (std::size_t k = 0; k < frames.size(); ++k)
    if (const auto& j = flicker.jitter(k); j && j->report.points > 0)
      jitters.push_back(j->report.median), jitter_seconds += j->seconds;
  if (!a.quiet && !jitters.empty()) {
    const SequenceJitter j = sequence_jitter(std::move(jitters));
    const double d = a.params.spacing;
    fmt::print(stderr, "{}\n",
               wrap_text(fmt::format("jitter (the change without the motion: |s₋ + s₊| / 2 from each frame to the "
                                     "frames either side): median {:.3g} d over {} frames, largest {:.3g} d; measured "
                                     "in {:.3f} s",
                                     j.median / d, j.frames, j.max / d, jitter_seconds),
                         kHelpColumns, kHelpColumns, 2));
  }
  if (!a.quiet || !failed.empty())
    fmt::print(stderr, "{} of {} frames surfaced ({} triangles) in {:.2f} s{}{}\n", ok, frames.size(), triangles,
               seconds_since(t0),
               failed.empty() ? ""
                              : fmt::format("; failed: {} (run again with --skip-existing, or --frames {})",
                                            format_frame_ranges(failed), format_frame_ranges(failed)),
               stop ? "; stopped at the first failure (--fail-fast)" : "");
  return failed.empty() ? kExitOk : kExitFailed;
}

}  // namespace meniscus::cli
