// meniscus — which stages a reconstruction runs, with which options (docs/method.md): one description,
// made once from the resolved parameters, that the driver (pipeline/driver.cpp) runs in its one
// order on either backend — the CPU's stages (pipeline/cpu_stages.cpp) or the device's
// (cuda/pipeline_cuda.cpp) — then the post-processing of the finished mesh on the host. A stage's
// own arithmetic lives in the stage; what runs and with which values lives here.
#pragma once

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "extract/field_band.hpp"
#include "field/kernel_impl.hpp"
#include "field/sparse_field.hpp"
#include "meniscus/params.hpp"
#include "meniscus/particles.hpp"
#include "mesh/voids.hpp"
#include "smooth/schedule.hpp"

namespace meniscus {

/// The decimation's patches, in spacings: 8 d holds about 2,000 triangles of flat water; smaller
/// patches leave more seams to later passes and keep more triangles, larger ones keep hardly fewer
/// in about the same time and only spread a change farther (post/decimate.hpp).
inline constexpr double kDecimateCell = 8;

/// The patches for the bound `e` (in spacings): kDecimateCell up to e = 0.02, growing as
/// √(e / 0.02) above. A coarser bound makes larger triangles, which small patches leave at their
/// seams: growing the patches with the bound keeps markedly fewer triangles on the bundled frames
/// for a little more of the stage's time.
inline double decimate_cell_spacings(double e) { return kDecimateCell * std::max(1.0, std::sqrt(e / 0.02)); }

struct StagePlan {
  /// `particles`: Yu & Turk's pass over the raw particles (smoothed centres, ellipsoids).
  ParticlePass particles;
  /// `grid`: the hash grid of the centres; cells of 2·r_outer, so a vertex's nearest-particle
  /// query touches about 8 cells.
  float grid_cell = 0;
  /// `field`: the distance field (band `distance_band`), or a kernel field.
  FieldMethod field = FieldMethod::distance;
  bool kernel_field = false;
  float distance_band = 0;
  SampleLattice lattice;
  /// `extract`: the level the extractor takes (r_outer for the distance field; 0 for the kernel
  /// fields, whose samples are stored relative to their iso level).
  Extractor extractor = Extractor::tiles;
  float iso = 0;
  /// `voids`, `blobs`: small closed components the smoothing would crush (mesh/voids.hpp).
  bool remove_voids = false, remove_blobs = false;
  bool close_handles = false;  ///< `handles`: small handles round air cut and capped (mesh/handles.hpp)
  double void_volume = 0, blob_min_volume = 0;
  /// `reorder`: when any sweep runs (the sweeps are much faster on a Z-ordered mesh); `smooth`.
  bool sweeps = false;
  SmoothSchedule schedule;
  bool ellipsoid_shells = false;  ///< anisotropic: the constraint shells are the particles' ellipsoids
  bool velocity_weights = false;  ///< per-vertex damping from the transferred velocity
  float r_inner = 0, r_outer = 0;
  /// `erode`, `transfer`, `normals`.
  bool erode = false;
  float erode_distance = 0;
  std::vector<std::string> transfer;
  float transfer_radius = 0;
  /// The finished mesh's post-processing, on the host whichever backend made it: `strays`
  /// (components enclosing fewer than `min_particles` particles, each counted within
  /// `stray_reach` of a vertex), then `clip` by `clip_box` (capped when `clip_cap`), then
  /// `decimate` within `decimate_bound` (a length; 0: none) in patches `decimate_cell` wide
  /// (decimate_cell_spacings).
  int min_particles = 0;
  float stray_reach = 0;
  std::vector<double> clip_box;
  bool clip_cap = false;
  double decimate_bound = 0, decimate_cell = 0;
};

/// The plan of resolved parameters `p` (resolve_params).
inline StagePlan plan_stages(const Params& p) {
  StagePlan s;
  s.particles = particle_pass(p);
  s.grid_cell = float(2 * p.r_outer);
  s.field = p.field;
  s.kernel_field = p.field != FieldMethod::distance;
  s.distance_band = field_band(p);
  s.lattice.kind = p.extract == Extractor::tiles ? SampleLattice::Kind::a15 : SampleLattice::Kind::cubic;
  s.lattice.cell_size = float(p.extract == Extractor::tiles ? 2 * p.voxel_size : p.voxel_size);
  s.extractor = p.extract;
  s.iso = s.kernel_field ? 0.0f : float(p.r_outer);
  s.remove_voids = !p.keep_voids;
  s.close_handles = p.close_handles;
  s.remove_blobs = s.kernel_field;
  s.void_volume = small_component_volume(p.spacing);
  s.blob_min_volume = inner_ball_volume(p.r_inner);
  s.sweeps = p.steps_a + p.steps_b + p.steps_free > 0;
  s.schedule = smooth_schedule(p);
  s.ellipsoid_shells = p.field == FieldMethod::anisotropic;
  s.velocity_weights = p.velocity_weighted;
  s.r_inner = float(p.r_inner);
  s.r_outer = float(p.r_outer);
  s.erode = p.erode > 0;
  s.erode_distance = float(p.erode);
  s.transfer = p.transfer;
  s.transfer_radius = float(p.transfer_radius);
  s.min_particles = p.min_particles;
  s.stray_reach = float(std::max(p.r_outer, 2 * p.spacing));
  s.clip_box = p.clip_box;
  s.clip_cap = p.clip_cap;
  s.decimate_bound = p.decimate * p.spacing;
  s.decimate_cell = decimate_cell_spacings(p.decimate) * p.spacing;
  return s;
}

}  // namespace meniscus
