// meniscus — the smoothing schedule both backends run (Williams 2008 §4), and its values from the
// resolved parameters (one mapping for the CPU's SmoothOptions and the device's SmoothSettings).
#pragma once

#include "meniscus/params.hpp"
#include "meniscus/reconstruct.hpp"

namespace meniscus {

struct SmoothSchedule {
  int steps_a = 40, steps_b = 20, steps_free = 3;
  float relax_a = 1.0f;   ///< ω of the A sweeps
  float relax_b = 1.0f;   ///< initial ω of the B sweeps; halved whenever a sweep raises the energy
  SmoothingSolver solver = SmoothingSolver::gauss_seidel;
  int rebuild_b = 0;      ///< rebuild W and D every k B sweeps; 0: once, from the shrunk mesh
};

/// What the B sweeps did (both backends fill it in).
struct SmoothReport {
  double energy_after_a = 0;   ///< xᵀBx when the B sweeps start
  double energy_final = 0;     ///< xᵀBx at the end (same operator)
  int relax_halvings = 0;      ///< times the B damping was halved because the energy rose
  float relax_b_final = 0;
  std::size_t colors_a = 0, colors_b = 0;  ///< Gauss–Seidel colour classes
};

/// The report as the pipeline's Stats give it.
inline SmoothingStats smoothing_stats(const SmoothReport& r) {
  return {r.energy_after_a, r.energy_final, r.relax_halvings, double(r.relax_b_final)};
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
  s.rebuild_b = p.rebuild_b;
  return s;
}

}  // namespace meniscus
