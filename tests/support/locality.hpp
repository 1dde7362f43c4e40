// meniscus tests — the locality checks of README "A local surface": surface a frame, change it
// somewhere (add a particle, a droplet, remove a splash), surface it again, and compare the two
// meshes vertex by vertex, bit for bit, near the change and far from it.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "meniscus/mesh.hpp"
#include "meniscus/particles.hpp"
#include "meniscus/params.hpp"

namespace meniscus::test {

/// A changed frame: the particles and the positions that changed (added or removed).
struct FrameChange {
  std::string what;
  ParticleSet particles;
  std::vector<Vec3f> changed;
};

/// `base` with particles added at `positions` (their attributes copied from particle 0).
ParticleSet with_particles(const ParticleSet& base, std::span<const Vec3f> positions);
/// `base` without the particles whose indices are listed (ascending).
ParticleSet without_particles(const ParticleSet& base, std::span<const std::size_t> indices);

/// The changes the locality tests make to a frame of spacing d:
/// - a particle R + 2d beyond the frame's bounding box (every vertex must stay as it is);
/// - a particle 1.5 d off the surface at the low-x end (it joins the surface there);
/// - a droplet of 20 particles (a 3 × 3 × 2 lattice and two more, spacing d) 1.5 d off the
///   surface at the high-x end;
/// - a splash removed: the 40 particles nearest to the highest particle.
std::vector<FrameChange> frame_changes(const ParticleSet& base, double d, double reach);

/// How two meshes compare: the vertices of `before` farther than `reach` from every changed
/// position (the region), and the others (near); how many of each have no bit-identical vertex
/// in `after`; and the distance of the farthest vertex that changed from the nearest change.
struct LocalityReport {
  std::size_t region = 0, region_changed = 0, near = 0, near_changed = 0;
  double farthest_changed = 0;
};
LocalityReport compare_locally(const TriangleMesh& before, const TriangleMesh& after, std::span<const Vec3f> changed,
                               double reach);

/// The configurations the locality tests cover: the defaults, --field anisotropic, --extract cubes.
enum class Variant { standard, anisotropic, cubes };
Params variant_params(Variant v);
const char* to_string(Variant v);

/// Surfaces `base` and every change of it with `p` (whose frame-wide estimates must be fixed, as
/// a sequence fixes them on its first frame) and expects, for each change, every vertex farther
/// than `reach` from it bit-identical and (where there are vertices near it) some near it moved.
/// Prints what moved and how far. Returns the vertices checked beyond `reach`, over the changes.
std::size_t expect_local(const std::string& label, const ParticleSet& base, const Params& p,
                         const std::vector<FrameChange>& changes, double reach);

/// A pool 100 d long (100 × 16 × 4 particles, jittered) with a splash at its low-x end: a
/// column rising 8 d above the water and droplets of 1–4 particles thrown beyond it. The
/// splash's particles are the last `splash_count` of the set.
struct SplashScene {
  ParticleSet particles;
  std::size_t splash_count = 0;
  float d = 0.1f;
};
SplashScene synthetic_splash();

}  // namespace meniscus::test
