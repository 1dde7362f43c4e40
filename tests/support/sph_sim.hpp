// meniscus tests — a small weakly compressible SPH dam break, for the tests that need consecutive
// frames of moving fluid (the bundled real frames are single frames of unrelated scenes).
#pragma once

#include <vector>

#include "meniscus/particles.hpp"

namespace meniscus::test {

/// A column of nx × ny × nz particles (spacing d, y up) in the corner of a tank [0, tank], let go.
struct DamBreakSetup {
  float spacing = 0.03f;
  int nx = 10, ny = 20, nz = 6;
  Vec3f tank{0.9f, 0.9f, 0.18f};
};

/// Frames of the dam break at t_first, t_first + frame_dt, …: positions and a "velocity"
/// attribute. WCSPH (Becker & Teschner 2007: Tait equation of state, γ = 7, speed of sound 10×
/// the largest free-fall speed), the poly6 density and spiky pressure kernels of Müller et al.
/// 2003 with support 2d, XSPH velocity smoothing, symplectic Euler at CFL number 0.4,
/// walls by clamping with damped reflection. Deterministic: every sum runs over the hash grid
/// in a fixed order, whatever the thread count. A test fixture, not a production solver.
std::vector<ParticleSet> simulate_dam_break(const DamBreakSetup& setup, float t_first, float frame_dt, int frames);

}  // namespace meniscus::test
