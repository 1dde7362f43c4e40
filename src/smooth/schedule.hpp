// meniscus — the smoothing schedule both backends run (Williams 2008 §4), and the per-sweep
// arithmetic they share: Jacobi sweeps, the A sweeps accelerated by Chebyshev's semi-iterative
// method (Golub & Varga 1961; Wang 2015, "A Chebyshev Semi-Iterative Approach for Accelerating
// Projective and Position-based Dynamics"), the B sweeps damped per vertex so that they cannot
// diverge (b_stable_damping in operators_impl.hpp).
//
// Locality. Every sweep reads only the previous iterate, so a vertex's position after a sweep
// depends on its ring (A) or its two rings (B) before it, on the particles near it, and on
// nothing else: no colouring, no ordering, no sum over the mesh decides anything. A vertex's final
// position is a function of the particles within R_local of it (local_reach).
#pragma once

#include <chrono>
#include <cmath>
#include <cstdint>

#include "common/clock.hpp"
#include "meniscus/params.hpp"
#include "meniscus/reconstruct.hpp"
#include "meniscus/vec.hpp"

namespace meniscus {

/// The sweeps as the smoothing functions take them. The initialisers serve the unit tests that call
/// those functions directly: the pipeline fills every field from the resolved Params
/// (smooth_schedule).
struct SmoothSchedule {
  int steps_a = 20, steps_b = 10, steps_free = 3;
  float relax_a = 1.0f;   ///< ω of the A sweeps
  float relax_b = 1.0f;   ///< the largest ω of the B sweeps; each vertex's is at most its stable one (b_stable_damping)
  SmoothingSolver solver = SmoothingSolver::chebyshev;
  float chebyshev_rho = 0.97f;  ///< ρ of the A sweeps' Chebyshev weights (chebyshev_rho_for)
  int rebuild_b = 0;      ///< rebuild W and D every k B sweeps; 0: once, from the shrunk mesh
  float area_floor = 0;   ///< the least vertex area D_i (collapsed vertices): from h, not the mesh
};

/// The spectral radius of the A sweeps' Jacobi iteration for which the Chebyshev weights are made.
/// The distance fields (distance, zhu-bridson: unions of spheres, bumpy as extracted): 0.97, which
/// flattens a jittered block's top face within the schedule's few A sweeps, with few thin
/// triangles once the tail below is plain (bench/RESULTS.md#how-good). The density fields
/// (metaball, sph, anisotropic: smooth as extracted): 0.9 — there 0.97 leaves more particles
/// outside and more thin triangles on the real frames than 0.9 does.
inline constexpr float kChebyshevRhoA = 0.97f;
inline constexpr float kChebyshevRhoDensity = 0.9f;

/// ρ for the field method.
inline float chebyshev_rho_for(FieldMethod field) {
  return field == FieldMethod::distance || field == FieldMethod::zhu_bridson ? kChebyshevRhoA : kChebyshevRhoDensity;
}

/// The last 3/10 of the A sweeps are plain Jacobi sweeps: the accelerated ones leave thin
/// triangles behind that plain ones even out.
MENISCUS_HD inline int chebyshev_plain_tail(int steps_a) { return (3 * steps_a + 9) / 10; }

/// Chebyshev's weight of A sweep s given the previous sweep's weight (`previous`; 1 for s = 0):
/// x⁽ˢ⁺¹⁾ = w (J x⁽ˢ⁾ − x⁽ˢ⁻¹⁾) + x⁽ˢ⁻¹⁾ with w₀ = 1, w₁ = 2/(2 − ρ²), wₛ = 4/(4 − ρ² wₛ₋₁); 1 in the
/// plain tail and for the plain Jacobi solver.
MENISCUS_HD inline float chebyshev_weight(int s, int steps_a, float previous, SmoothingSolver solver, float rho) {
  if (solver != SmoothingSolver::chebyshev || s == 0 || s >= steps_a - chebyshev_plain_tail(steps_a)) return 1.0f;
  const float r2 = rho * rho;
  return s == 1 ? 2.0f / (2.0f - r2) : 4.0f / (4.0f - r2 * previous);
}

/// An A sweep's move of vertex x (neighbour mean m, factor f of the velocity weighting), then
/// Chebyshev's combination with the vertex's position two sweeps back.
MENISCUS_HD inline Vec3f a_sweep_position(Vec3f x, Vec3f mean, Vec3f before, float relax, float factor, float weight) {
  const Vec3f y = x + (mean - x) * (relax * factor);
  return weight == 1.0f ? y : (y - before) * weight + before;
}

/// A B sweep's move of vertex x: (B x)_i = bx with diagonal B_ii, the vertex's stable damping ω_i
/// (b_stable_damping) and factor f of the velocity weighting.
MENISCUS_HD inline Vec3f b_sweep_position(Vec3f x, Vec3f bx, float b_ii, float omega, float factor) {
  return x - bx * (omega * factor / b_ii);
}

/// The schedule of resolved parameters `p`.
inline SmoothSchedule smooth_schedule(const Params& p) {
  SmoothSchedule s;
  s.steps_a = p.steps_a;
  s.steps_b = p.steps_b;
  s.steps_free = p.steps_free;
  s.relax_a = float(p.relax);
  s.relax_b = float(p.relax_b);
  s.solver = p.solver;
  s.chebyshev_rho = chebyshev_rho_for(p.field);
  s.rebuild_b = p.rebuild_b;
  s.area_floor = float(1e-6 * p.voxel_size * p.voxel_size);
  return s;
}

/// How far the schedule reaches, in rings of the mesh: a Jacobi A sweep one ring, a B sweep two
/// (B = W D⁻¹ W). A vertex's final position depends on the initial vertices within this many rings
/// of it and on the particles near them.
inline int smoothing_rings(const SmoothSchedule& s) { return s.steps_a + 2 * (s.steps_b + s.steps_free); }

/// The schedule, run by both backends over their sweeps `s` (smooth.cpp; sweeps_backend.hpp, which the device runs), which
/// provide: a_begin() / a_sweep(weight) / a_end() (the A sweeps' second iterate held between);
/// build_operator() (W and D from the current mesh); set_damping(), update_wx() and energy() (xᵀBx
/// from W x); b_sweep(constrained) (W x is updated after it); damped_vertices() and
/// least_damping() once the sweeps are done; swept() after every sweep (progress); and
/// kHostTimed: whether the host's clock measures the sweeps (the device's launches return at once).
template <class Sweeps>
SmoothingStats run_schedule(const SmoothSchedule& o, Sweeps& s) {
  SmoothingStats report;
  if (o.steps_a > 0) {
    const auto start = std::chrono::steady_clock::now();
    s.a_begin();
    float weight = 1.0f;
    for (int k = 0; k < o.steps_a; ++k) {
      weight = chebyshev_weight(k, o.steps_a, weight, o.solver, o.chebyshev_rho);
      s.a_sweep(weight);
      s.swept();
    }
    s.a_end();
    if constexpr (Sweeps::kHostTimed) report.a_sweeps_seconds = seconds_since(start);
  }
  const int steps_b = o.steps_b + o.steps_free;
  if (steps_b <= 0) return report;
  s.build_operator();
  const auto start = std::chrono::steady_clock::now();
  s.set_damping();
  s.update_wx();
  report.energy_start = s.energy();
  for (int k = 0; k < steps_b; ++k) {
    if (o.rebuild_b > 0 && k > 0 && k % o.rebuild_b == 0) {
      s.build_operator();
      s.set_damping();
      s.update_wx();
    }
    s.b_sweep(k < o.steps_b);  // the last steps_free sweeps unconstrained
    s.update_wx();
    s.swept();
  }
  report.energy_final = s.energy();
  report.damped_vertices = s.damped_vertices();
  report.relax_b_min = s.least_damping();
  if constexpr (Sweeps::kHostTimed) report.b_sweeps_seconds = seconds_since(start);
  return report;
}

}  // namespace meniscus
