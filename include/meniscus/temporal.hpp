// meniscus — a frame's particles smoothed in time with the frames either side (docs/method.md
// "Temporal smoothing"): the calm water's shimmer, which follows the particles' frame-to-frame
// noise, filtered out without making a frame depend on another frame's mesh.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "meniscus/particles.hpp"

namespace meniscus {

/// The attribute that names each particle across frames (Houdini, partio, SPlisHSPlasH: "id").
inline constexpr const char* kParticleIdAttribute = "id";

/// What temporal_smoothing did with one frame.
struct TemporalReport {
  bool applied = false;     ///< the positions were filtered (else they are the frame's own)
  std::string skipped;      ///< why not, when not: "no 'id' attribute in the next frame" …
  std::size_t matched = 0;  ///< particles found in both neighbouring frames (the others kept their position)
  std::size_t clamped = 0;  ///< particles whose shift was cut to the limit
  double mean_shift = 0;    ///< mean |shift| over the matched particles (scene units)
  double max_shift = 0;     ///< largest |shift| (scene units; at most the limit)
};

/// Frame t's positions, in its particles' order, each x replaced by (1 − 2w)·x + w·(x₋ + x₊), x₋ and x₊ the
/// same particle's positions in frames t − 1 and t + 1, matched by the "id" attribute. The shift
/// w·(x₋ − 2x + x₊) is w·a·Δt² for a particle moving with acceleration a, zero for steady motion,
/// and −4w·e for noise e on one frame: noise between frames is filtered, motion kept. Each shift
/// is cut to `limit` (collisions, ids reused far away), so a particle stays that near its own
/// position. Particles missing from either neighbour, and every particle of a frame whose ids are
/// missing, not whole numbers below 2²⁴ (ids are read as floats) or not unique, keep their
/// positions (report.skipped says why). Only positions come back: the frame's attributes stay
/// where they are, in the same order. The result is the same for any thread count and any order of
/// the particles in the three frames.
/// Throws InvalidParameter for w outside [0, 0.5] or a limit that is negative or not finite.
std::vector<Vec3f> temporal_smoothing(const ParticlesView& previous, const ParticlesView& current,
                                      const ParticlesView& next, double weight, double limit,
                                      TemporalReport* report = nullptr);

}  // namespace meniscus
