// meniscus bench — deterministic synthetic particle scenes sized by particle count.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "meniscus/particles.hpp"

namespace meniscus::bench {

/// A generated scene: the particles plus what the metrics need to know about it.
struct Scene {
  std::string name;
  ParticleSet particles;
  float spacing = 0;      ///< the rest spacing d the generator used (exact, no estimation needed)
  bool has_flat_top = false;
  /// For scenes with a flat top face: the xy rectangle of that face and its height, so the
  /// flatness metric can pick the top vertices away from the edges.
  Vec3f top_lo, top_hi;
};

/// "block": a cube of about `count` particles on a lattice of spacing d, 10 % jitter.
/// "sphere": a ball of concentric Fibonacci shells (outermost shell exactly at R).
/// "splash": a pool slab (≈ 80 % of the particles) with droplets of 1–30 particles above it.
/// Throws std::invalid_argument for another name. Same name + count + d → same particles.
Scene make_scene(const std::string& name, std::size_t count, float d = 0.01f);

/// The scene names make_scene understands.
std::vector<std::string> scene_names();

}  // namespace meniscus::bench
