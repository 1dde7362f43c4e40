// meniscus CLI — `meniscus surface`: one frame, a sequence of frames, or one frame over MPI ranks.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "meniscus/io.hpp"
#include "meniscus/params.hpp"
#include "meniscus/reconstruct.hpp"
#include "meniscus/render.hpp"
#include "meniscus/sequence.hpp"
#include "options.hpp"

namespace CLI {
class App;
}

namespace meniscus::cli {

class MpiSession;

struct SurfaceArgs {
  std::string input, output, stats_path, preview_path, field_path, config_path, frames, up = "auto";
  std::vector<std::string> columns;
  int jobs = 1;
  std::optional<int> estimates_from;  ///< a sequence: the frame the frame-wide estimates are made on
  bool quiet = false, drop_invalid = false, fail_fast = false, skip_existing = false, pieces = false;
  ParameterOptions options;  ///< the table's options as typed
  Params params;             ///< resolved from --config and the options
  std::string estimated_on;  ///< a sequence's frames: the frame whose estimates params holds
};

CLI::App* add_surface_command(CLI::App& app, SurfaceArgs& a);
int run_surface(const CLI::App& cmd, SurfaceArgs& a, const MpiSession& mpi);

// --- shared by the single frame and the sequence (surface.cpp) ---------------------------------

/// The files of one frame (or of the single job).
struct FrameFiles {
  std::string input, output, stats, preview, field;
  /// A sequence's frame with temporal smoothing: the inputs of the frames either side (empty: not
  /// on disk) and, when one is missing, why the frame is surfaced from its own positions.
  std::string previous = {}, next = {}, no_neighbours = {};
};

/// A frame's particles read ahead of surfacing it, and the time the read took.
struct ReadFrame {
  ParticleSet particles;
  double seconds = 0;
  std::string format;  ///< as the reader names it (ReadReport::format)
};

/// The preview's up axis: --up's, or (auto) what the frame's file and particles show.
UpAxis preview_up_axis(const SurfaceArgs& a, const ParticleSet& particles, std::string_view format);

/// The read options of a run; `memory_share`: the part of --max-memory one frame may use.
ReadOptions read_options(const SurfaceArgs& a, double memory_share = 1.0);

/// Reads, surfaces and writes one frame; `verbose` prints the per-frame report. `preread`: the
/// frame as it was read already (taken over).
/// `preview_up`, when given and a preview is drawn: the up axis it was drawn with.
Result surface_one(const SurfaceArgs& a, const FrameFiles& f, bool verbose, const ProgressFn& progress,
                   std::optional<ReadFrame> preread = std::nullopt, UpAxis* preview_up = nullptr);

/// The run's files of one frame, for check_run_files.
void add_frame_files(std::vector<struct RunFile>& files, const FrameFiles& f);

/// A sequence: every frame of the input pattern (sequence.cpp).
int run_sequence(const SurfaceArgs& a, const FramePattern& in);

}  // namespace meniscus::cli
