// meniscus CLI — what the subcommands share: exit codes, the checks of a run's files, small
// output helpers, and each subcommand's entry points (one file per subcommand).
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "meniscus/quality.hpp"
#include "meniscus/vec.hpp"

namespace CLI {
class App;
}

namespace meniscus::cli {

/// The exit codes (docs/cli.md "Exit codes").
constexpr int kExitOk = 0;
constexpr int kExitFailed = 1;  ///< bad input, or the work failed (a file, the memory, a frame)
constexpr int kExitUsage = 2;   ///< bad options or usage

/// A file a run reads or writes, for check_run_files.
struct RunFile {
  std::string path;
  std::string role;  ///< how the message names it: "the input", "--stats", "-o"
  bool output = false;
};

/// Before any work: refuses (InvalidParameter, exit 2) an output that is the same file as an
/// input or as another output — the same device and inode where the file exists (through
/// symlinks and hard links), the same normalised path otherwise — and an output that cannot be
/// written: a folder, or in a folder that does not exist and cannot be made, or is not writable.
void check_run_files(const std::vector<RunFile>& files);

/// Creates the folders an output file goes into (like a renderer's output path).
void make_parent_dirs(const std::string& path);

/// Writes a text file through the atomic writer.
void write_text_file(const std::string& path, const std::string& text);

/// A text file the CLI reads (a .pvtp index, a stats file to amend): at most 64 MB.
std::string read_text_file(const std::string& path);

/// Refuses an output name whose extension is no mesh format (before any work).
void check_output_format(const std::string& output);

/// Prints "warning: <text>" on stderr, with control characters escaped.
void print_warning(std::string_view text);

/// A flicker report as JSON: the distances, the cap (null when none) and what the measure cost.
nlohmann::ordered_json flicker_json(const SurfaceDistanceReport& f);

/// A sequence's jitter from its frames' medians (surface_jitter): the median of them and the largest.
struct SequenceJitter {
  std::size_t frames = 0;
  double median = 0, max = 0;
};
SequenceJitter sequence_jitter(std::vector<double> medians);

/// The byte limit of a run's reads and pictures: --max-memory, or 90 % of what is granted.
double memory_limit_bytes(double max_memory_gb);

}  // namespace meniscus::cli
