// meniscus — the one entry point every front end calls.
#pragma once

#include <array>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "meniscus/mesh.hpp"
#include "meniscus/params.hpp"
#include "meniscus/particles.hpp"
#include "meniscus/temporal.hpp"

namespace meniscus {

struct StageTime {
  std::string name;
  double seconds = 0;
};

/// What the bilaplacian (B) sweeps of the smoothing did; all zero when none ran.
struct SmoothingStats {
  double energy_start = 0;   ///< xᵀBx, the surface's bending energy, when the B sweeps start
  double energy_final = 0;   ///< and after the last one (same operator)
  std::size_t damped_vertices = 0;  ///< vertices whose B damping the stability bound set below relax_b
  double relax_b_min = 0;           ///< the smallest damping of any vertex's B sweeps
  std::size_t batches = 0;   ///< groups of whole components smoothed one after another (CPU backend)
  // Where the smoothing stage's time went (CPU backend; the CUDA backend reports 0 and times its
  // set-up as stages of its own):
  double setup_seconds = 0;     ///< adjacency, corner lists, particle lists, B operator
  double a_sweeps_seconds = 0;  ///< the constrained graph-Laplacian sweeps
  double b_sweeps_seconds = 0;  ///< the B sweeps, constrained and free (redone ones included)
};

/// What one stage of the CUDA backend asked of the device: kernel launches, copies to the device,
/// to the host and within it, memsets, and waits (the host waiting for the device: a copy to the
/// host, an event synchronisation) — the costs that decide a small frame's time on a GPU.
struct DeviceStageCalls {
  std::string name;
  std::uint64_t launches = 0, uploads = 0, downloads = 0, device_copies = 0, memsets = 0, waits = 0;
};

struct Stats {
  std::size_t particles = 0;
  std::size_t vertices = 0;
  std::size_t triangles = 0;
  std::size_t field_blocks = 0;        ///< allocated 512-sample blocks of the sparse field
  std::size_t dropped_triangles = 0;   ///< zero-area triangles removed by the weld
  std::size_t removed_voids = 0;       ///< small interior voids removed after extraction
  std::size_t removed_blobs = 0;       ///< kernel fields: blobs enclosing no particle or smaller than an inner shell
  std::size_t flipped_triangles = 0;   ///< triangles whose normal reversed during erosion
  std::size_t removed_strays = 0;      ///< components enclosing fewer than min_particles particles
  std::size_t pinhole_bridges = 0;     ///< particles added across pinholes of thin water
  std::size_t closed_handles = 0;      ///< handles cut and capped (close_handles)
  std::size_t components = 0;          ///< connected pieces of the written surface
  /// Handles of the written surface (holes and tunnels through it: components − χ/2, χ = V − E + F);
  /// −1 when it is not closed (a clip without a cap, or a cap with open edges).
  long long genus = -1;
  std::size_t particles_outside_box = 0;  ///< particles ignored by particle_box
  std::size_t clipped_triangles = 0;   ///< clip_box: triangles wholly outside the box, removed
  std::size_t cut_triangles = 0;       ///< clip_box: triangles crossing a face, replaced by their part inside
  std::size_t cap_triangles = 0;       ///< clip_cap: triangles added on the box's faces
  std::size_t cap_open_edges = 0;      ///< clip_cap: edges left open (0: watertight; see warnings)
  std::size_t decimated_triangles = 0; ///< decimate: triangles the simplification removed
  double decimate_error = 0;           ///< decimate: the largest distance of the full surface's points from the simplified one
  int decimate_rounds = 0;             ///< decimate: passes over shifted patch grids (post/decimate.hpp)
  std::size_t peak_memory_bytes = 0;   ///< peak resident set size of the process
  int threads = 0;
  std::string threads_from;            ///< where the thread count came from: --threads, the CPU affinity, Slurm
  std::string max_memory_from;         ///< where the memory limit came from: --max-memory, RAM, a cgroup, Slurm
  std::string backend = "cpu";         ///< the backend that ran the stages: "cpu" or "cuda"
  bool spacing_estimated = false;
  /// A sequence's frame: the file its frame-wide estimates (spacing, rest density, reference
  /// speed) were made on, when they were not given; empty otherwise.
  std::string estimated_on;
  /// A sequence's frame: what its temporal smoothing with the frames either side did (the CLI's
  /// `surface` of a pattern, meniscus/temporal.hpp); reconstruct() alone leaves it not applied.
  TemporalReport temporal;
  SmoothingStats smoothing;
  std::vector<StageTime> stages;       ///< in pipeline order
  std::vector<DeviceStageCalls> device_calls;  ///< per stage, with the CUDA backend only
  std::vector<std::string> warnings;
  double total_seconds() const;
};

/// Called with the name of the running stage and its completion in [0, 1]. Must be cheap and
/// thread-safe; it is called from the pipeline's thread only.
using ProgressFn = std::function<void(std::string_view stage, double fraction)>;

struct Result {
  TriangleMesh mesh;
  Params params;  ///< the parameters actually used (every derived value filled in)
  Stats stats;
};

/// Surfaces the particles: hash grid → sparse distance field → extraction → weld → constrained
/// smoothing → erosion → attribute transfer → normals. Throws InvalidParameter for bad
/// parameters, ResourceError when the job would not fit in memory.
/// A frame far from the origin (its farthest coordinate more than 16 times its extent away) is
/// computed about local_origin(particles) and its mesh written back where it was (docs/cli.md
/// "Far from the origin").
Result reconstruct(const ParticlesView& particles, const Params& params, const ProgressFn& progress = {});

/// reconstruct() made once and called per frame, as a simulator's loop calls it:
///
///     meniscus::Reconstructor surface(params);   // checks the parameters, asks for threads and memory
///     for (...) { Result r = surface(particles); ... }   // particles: a ParticleSet or a ParticlesView
///
/// Each call gives what reconstruct(particles, params) gives, bit for bit (the same stages on the
/// same parameters), and reads the particles in place. What it does once instead of every call:
/// checking the parameters (InvalidParameter at construction, before any frame) and asking the
/// system for the threads and memory granted (granted_threads(), memory_limit(): the CPU affinity,
/// cgroup and Slurm limits, read when it is made). Every frame's parameters derived from its
/// particles (spacing when 0, radii, grid) are that frame's, as reconstruct()'s are: a frame's mesh
/// never depends on an earlier one.
/// One call at a time: a call while another runs (from a second thread, or from the first one's
/// progress callback) throws std::runtime_error rather than wait; use one Reconstructor per thread.
class Reconstructor {
 public:
  explicit Reconstructor(const Params& params);
  ~Reconstructor();
  Reconstructor(Reconstructor&&) noexcept;
  Reconstructor& operator=(Reconstructor&&) noexcept;
  Reconstructor(const Reconstructor&) = delete;
  Reconstructor& operator=(const Reconstructor&) = delete;

  Result operator()(const ParticlesView& particles, const ProgressFn& progress = {});
  /// The parameters as given (each frame's Result::params has them resolved for its particles).
  const Params& params() const;
  /// Frames surfaced so far.
  std::size_t frames() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

/// The point reconstruct() computes a frame about: {0, 0, 0} for a frame near the origin (its
/// farthest coordinate within 16 times its extent), else the middle of its bounding box rounded
/// to a grid of the power of two at least its extent. `lo`, `hi`: the frame's bounding box.
std::array<double, 3> local_origin(const std::array<double, 3>& lo, const std::array<double, 3>& hi);

/// local_origin() of the particles reconstruct() surfaces (those in params.particle_box, if one
/// is given).
std::array<double, 3> frame_origin(const ParticlesView& particles, const Params& params);

/// reconstruct() about a given origin: a part of a frame (an MPI rank's slab) is computed about
/// the whole frame's local_origin, so that every part rounds as the whole frame would.
Result reconstruct_about(const ParticlesView& particles, const Params& params, const std::array<double, 3>& origin,
                         const ProgressFn& progress = {});

/// Fills in every derived (zero) parameter of `params` for these particles: spacing
/// (estimate_spacing), voxel size, radii, transfer radius, threads; then validates.
Params resolve_params(const ParticlesView& particles, const Params& params);

/// R_local for resolved parameters `p`: every vertex's final position is a function of the
/// particles within this distance of it, bit for bit (README "A local surface"). The smoothing
/// sweeps are Jacobi sweeps: a vertex's final position depends on the extracted vertices within
/// smoothing_rings() rings (one an A sweep, two a B sweep: 46 for the default schedule), each
/// ring at most one triangle edge further (0.61 d for the tiles, 0.87 d for cubes); each of
/// those vertices on the particles its field samples and its constraint projections read, and on
/// nothing else (no colouring, no order, no sum over the frame). With the defaults 33.2 d; with
/// decimate, 4·√3·8 d = 55.4 d more (the simplification's patches, post/decimate.hpp).
/// Frame-wide estimates (spacing, rest density, reference speed) must be given, as a sequence
/// does after its first frame (resolve_frame_estimates).
double local_reach(const Params& p);

/// The frame-wide estimates among the derived parameters, resolved on these particles and the
/// rest of `params` left as it is: the spacing, the rest density (sph and anisotropic fields with
/// a density but no mass) and the velocity weighting's reference speed. Everything else the
/// pipeline derives is local. A sequence resolves these on its first frame and uses them for
/// every frame, so that a droplet appearing in one frame changes nothing far from it.
Params resolve_frame_estimates(const ParticlesView& particles, const Params& params);

/// The particle spacing: the larger of the median nearest-neighbour distance (exact for
/// lattice-like sets) and the first quartile of the local density spacing
/// (volume of a ball of 2.5 NN-distances / particles in it)^(1/3) — the nearest-neighbour
/// distance alone underestimates the rest spacing of disordered SPH fluid (docs/cli.md "Spacing"), which
/// leaves holes in the surface. Coincident particles (copies, or within 1e-4 of the search cells,
/// about 1e-4 d, of one another) are one position in the nearest-neighbour distances, count in
/// the density round the samples near them and are never samples themselves (unless every sample
/// falls in a pile): a pile has no spacing of its own, and costs no more than one particle.
/// Estimated from a deterministic sample of at most `max_samples` particles.
double estimate_spacing(const ParticlesView& particles, std::size_t max_samples = 50000);

/// Keeps the particles inside `box` (xmin, ymin, zmin, xmax, ymax, zmax; faces included) with
/// their attributes, in order; returns how many were dropped. An empty box keeps all.
std::size_t keep_particles_in_box(ParticleSet& particles, const std::vector<double>& box);

/// The stats and parameters as a JSON document (the format of `--stats FILE.json`).
std::string stats_to_json(const Result& result);

/// Version and build information.
const char* version();

}  // namespace meniscus
