// meniscus — the smoothing schedule both backends run (Williams 2008 §4), and its values from the
// resolved parameters (one mapping for the CPU's SmoothOptions and the device's SmoothSettings).
#pragma once

#include "meniscus/params.hpp"
#include "meniscus/reconstruct.hpp"

namespace meniscus {

/// The sweeps as the smoothing functions take them. The initialisers serve the unit tests that call
/// those functions directly: the pipeline fills every field from the resolved Params
/// (smooth_schedule), whose ω of the A sweeps is 1.3 with Gauss-Seidel (resolve_params), not 1.
struct SmoothSchedule {
  int steps_a = 20, steps_b = 15, steps_free = 3;
  float relax_a = 1.0f;   ///< ω of the A sweeps (1: plain sweeps; see above)
  float relax_b = 1.0f;   ///< initial ω of the B sweeps; halved whenever a sweep raises the energy
  SmoothingSolver solver = SmoothingSolver::gauss_seidel;
  int rebuild_b = 0;      ///< rebuild W and D every k B sweeps; 0: once, from the shrunk mesh
};

/// What the B sweeps did, as both backends return it and the pipeline's Stats carry it.
using SmoothReport = SmoothingStats;

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
