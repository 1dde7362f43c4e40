// meniscus — frame sequences: file-name patterns with a frame number, and frame ranges.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace meniscus {

/// A file name with a frame-number placeholder: `####` (the number zero-padded to the number
/// of #), `{}` (unpadded), or printf style `%d` / `%04d`. Only the last placeholder counts.
struct FramePattern {
  std::string prefix, suffix;
  int width = 0;  ///< zero-padding width (0: none)

  /// The file name of `frame` (negative frames get a leading '-').
  std::string format(int frame) const;
  /// The frame number of `name` if it matches the pattern, else nullopt.
  std::optional<int> match(const std::string& name) const;
};

/// The pattern in `path`, or nullopt when it has no placeholder.
std::optional<FramePattern> parse_frame_pattern(const std::string& path);

/// Parses "1-240", "1-240:2" (every 2nd), "7", and comma-separated lists of those, in the
/// order given, without duplicates. Throws InvalidParameter (naming the text) on bad syntax or
/// more than 10 million frames.
std::vector<int> parse_frame_ranges(const std::string& spec);

/// The frames as the shortest list parse_frame_ranges() reads back: {1,2,3,4,7} → "1-4,7"
/// (runs of consecutive frames joined; the order kept).
std::string format_frame_ranges(const std::vector<int>& frames);

/// The frames whose files exist on disk for this pattern, sorted.
std::vector<int> discover_frames(const FramePattern& pattern);

}  // namespace meniscus
