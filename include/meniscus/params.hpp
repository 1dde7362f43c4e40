// meniscus — the parameters of a reconstruction. Lengths are in world units; a value of 0
// means "derive it" (from the particle spacing d) and is replaced by the value actually used
// in Result::params.
#pragma once

#include <string>
#include <vector>

namespace meniscus {

enum class Extractor { tiles, cubes, tetrahedra };
/// The smoothing sweeps (smooth/schedule.hpp): Jacobi sweeps, the A sweeps accelerated by
/// Chebyshev's method (the default) or plain. Both are local: a vertex reads only its rings.
enum class SmoothingSolver { chebyshev, jacobi };
/// Where the pipeline runs: `automatic` uses the CUDA backend when it is built and a device is
/// there (else the CPU, with a warning in Stats when CUDA was built but no device is usable).
enum class Backend { automatic, cpu, cuda };
/// The scalar field whose level set is the initial surface (docs/fields.md).
enum class FieldMethod { distance, metaball, sph, zhu_bridson, anisotropic };

const char* to_string(Extractor e);
const char* to_string(SmoothingSolver s);
const char* to_string(FieldMethod f);
/// Parses "distance" | "metaball" | "sph" | "zhu-bridson" | "anisotropic"; throws InvalidParameter.
FieldMethod parse_field(const std::string& name);
/// Parses "tiles" | "cubes" | "tetrahedra"; throws InvalidParameter otherwise.
Extractor parse_extractor(const std::string& name);
/// Parses "chebyshev" | "jacobi"; throws InvalidParameter otherwise ("gauss-seidel", the former
/// default, with a message naming its replacement).
SmoothingSolver parse_solver(const std::string& name);
const char* to_string(Backend b);
/// Parses "auto" | "cpu" | "cuda"; throws InvalidParameter otherwise.
Backend parse_backend(const std::string& name);

struct Params {
  // --- geometry -------------------------------------------------------------------------------
  double spacing = 0;          ///< particle separation d; 0: estimated (estimate_spacing in reconstruct.hpp)
  double voxel_size = 0;       ///< field resolution h; 0: d / (2 · detail)
  /// Resolution multiplier when voxel_size is 0, in (0, 8]: 2 halves the voxel size (about 4×
  /// the triangles, 8× the field memory), 0.5 doubles it. Ignored when voxel_size is given.
  double detail = 1;
  double r_outer = 0;          ///< initial surface = union of spheres of this radius; 0: r_outer_factor · d
  /// r_outer in spacings when r_outer is 0, in (0, 4]. The "droplets" preset raises it to 1.25 so
  /// that stretched sheets (particles up to 2.5 d apart) stay closed.
  double r_outer_factor = 1.0;
  double r_inner = 0;          ///< vertices are kept at least this far from particles; 0: 0.5 d
  Extractor extract = Extractor::tiles;

  // --- field method (docs/fields.md) ---------------------------------------
  FieldMethod field = FieldMethod::distance;
  /// Level of the field that is the surface; 0: derive. metaball, sph, anisotropic: a density
  /// threshold, default half the field's value inside a uniform fluid of spacing d (metaball
  /// 0.1197 (R/d)³, sph and anisotropic 0.5); zhu-bridson: the particle radius r̄, default r_outer.
  /// The distance field's level is always r_outer (iso must stay 0 there).
  double iso = 0;
  /// Support radius R of the kernels (metaball, sph, zhu-bridson; for anisotropic the bulk
  /// support, the PCA neighbourhood being 2R as Yu & Turk's 2h); 0: 2 d. Unused by distance.
  double kernel_radius = 0;
  /// The fluid's rest density ρ₀ for the SPH volumes of particles that carry a density but no
  /// mass (sph and anisotropic fields): V_i = d³·ρ₀/ρ_i. 0: the median of the frame's densities,
  /// a frame-wide estimate (a sequence takes it from its first frame, like the spacing).
  double rest_density = 0;
  /// Laplacian smoothing of the particle positions before the field, x ← (1−λ)x + λ·(weighted
  /// mean of the neighbours within 2d, weights 1 − (r/2d)³); the constraints use the smoothed
  /// positions. −1: derive (0.3 for anisotropic, where it smooths Yu & Turk's kernel centres; 0 otherwise).
  double smooth_particles = -1;
  /// Keep interior voids smaller than (2d)³ (closed inward-facing components: gaps in the
  /// particle sampling, which the smoothing would collapse); by default they are removed.
  bool keep_voids = false;
  /// Bridge the pinholes of thin water: a particle added in the middle of each hole through the
  /// outer balls that a ring of touching particles encloses in a plane, no wider than 1.2 d from
  /// its middle to the ring (docs/method.md "Pinholes"). Never joins what was apart.
  bool fill_pinholes = false;
  /// Cut the small handles of the extracted surface that enclose air (pinholes through sheets,
  /// tunnels through thin water) and cap them, before the sweeps (docs/method.md "Handles"). The
  /// CPU backend's; never cuts water nor joins what was apart.
  bool close_handles = false;

  // --- smoothing schedule (Williams 2008) -------------------------------------------------------
  int steps_a = 20;            ///< constrained graph-Laplacian (A) sweeps
  int steps_b = 10;            ///< constrained bilaplacian (B) sweeps
  int steps_free = 3;          ///< unconstrained B sweeps at the end
  /// Relaxation ω of the A sweeps, in (0, 1] (Jacobi sweeps diverge above 1); 0: derive (1).
  double relax = 0;
  double relax_b = 1.0;        ///< the largest damping of the B sweeps, in (0, 1]; each vertex's is at most its stable one
  SmoothingSolver solver = SmoothingSolver::chebyshev;
  int rebuild_b = 0;           ///< rebuild the B operator every k sweeps; 0: build once after A
  /// Per-vertex smoothing strength from the particle speed (needs a velocity attribute: v, vel
  /// or velocity): vertex i's damping is ω·clamp(1 − speed_i / velocity_reference, velocity_min_weight, 1)
  /// with speed_i the transferred particle speed — calm water is smoothed fully, splashes less.
  bool velocity_weighted = false;
  double velocity_reference = 0;     ///< v_ref; 0: the 95th percentile of the particle speeds
  double velocity_min_weight = 0.2;  ///< w_min, in (0, 1]
  /// A sequence's frames (the CLI's `surface` of a pattern): each particle's position becomes
  /// (1 − 2w)·x + w·(x₋ + x₊) with its positions x₋, x₊ in the frames either side, matched by the
  /// "id" attribute, the shift at most r_inner / 2 (meniscus/temporal.hpp): the frame-to-frame
  /// noise that makes calm water shimmer is filtered, steady motion kept. 0: off; a frame without
  /// ids or without both neighbours on disk is surfaced from its own positions.
  double temporal_smoothing = 0.25;

  /// xmin, ymin, zmin, xmax, ymax, zmax: only the particles inside this box (faces included) are
  /// surfaced, the others ignored before anything else (particles stuck in a tank wall, or a
  /// region of a large domain); empty: every particle.
  std::vector<double> particle_box;

  // --- post-processing ------------------------------------------------------------------------
  double erode = 0;                    ///< move vertices inwards along the normal by this much
  /// Drop the surface's closed components that enclose fewer particles than this (lone
  /// particles, particles stuck in a wall); 0 keeps every droplet.
  int min_particles = 0;
  /// xmin, ymin, zmin, xmax, ymax, zmax: the finished (smoothed) surface is cut by this box —
  /// triangles crossing a face split on it, nothing outside kept, the mesh open along the cut
  /// (the tank's walls and floor go, the water's top stays); empty: no cut.
  std::vector<double> clip_box;
  /// Close the clip_box cut with the box's faces, so the mesh stays watertight.
  bool clip_cap = false;
  /// Simplify the finished mesh (edge collapses and flips that keep valence 5-9 and no new angle
  /// under 15°) while the simplified surface stays within this many spacings of the full one
  /// (post/decimate.hpp); 0: no simplification. 0.02 keeps flat water to a fiftieth of a spacing.
  double decimate = 0;
  std::vector<std::string> transfer;   ///< particle attributes to carry onto the vertices
  double transfer_radius = 0;          ///< 0: 2 d

  // --- execution ------------------------------------------------------------------------------
  Backend backend = Backend::automatic;  ///< cpu, cuda, or auto (cuda when a device is there)
  int threads = 0;                     ///< 0: all hardware threads
  double max_memory_gb = 0;            ///< refuse jobs estimated above this; 0: 90 % of RAM

  /// Throws InvalidParameter naming the first parameter that is out of range or inconsistent.
  /// Zero ("derive") values are accepted; call after resolve() to check the derived ones too.
  void validate() const;

  friend bool operator==(const Params&, const Params&) = default;
};

}  // namespace meniscus
