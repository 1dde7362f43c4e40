// meniscus — the driver: reconstruct() checks the inputs, resolves the parameters, makes the plan
// and runs its stages in one order (run_stages) on the CUDA device or the CPU, then the
// post-processing of the finished mesh on the host — every stage timed the same way.
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "post/available.hpp"
#include "post/clip.hpp"
#include "post/strays.hpp"
#include "post/decimate.hpp"
#include "grid/hash_grid.hpp"
#include "grid/pinholes.hpp"
#include "mesh/components.hpp"
#include "mesh/voids.hpp"
#include "meniscus/backend.hpp"
#include "meniscus/distributed.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/memory.hpp"
#include "meniscus/messages.hpp"
#include "meniscus/resources.hpp"
#include "pipeline/internal.hpp"
#include "pipeline/stages.hpp"

namespace meniscus {

const char* version() { return MENISCUS_VERSION; }

void run_stages(const StagePlan& plan, StageBackend& b, TriangleMesh& mesh) {
  b.prepare();
  if (plan.particles.run) b.timed("particles", [&] { b.particles(); });
  b.timed("grid", [&] { b.grid(); });
  b.timed("field", [&] { b.field(); });
  b.timed("extract", [&] { b.extract(); });
  if (plan.remove_voids) b.timed("voids", [&] { b.voids(); });
  if (plan.remove_blobs) b.timed("blobs", [&] { b.blobs(); });
  if (plan.close_handles) b.timed("handles", [&] { b.handles(); });
  if (plan.sweeps) b.timed("reorder", [&] { b.reorder(); });
  b.adjacency();
  b.timed("smooth", [&] { b.smooth(); });
  if (plan.erode) b.timed("erode", [&] { b.erode(); });
  if (!plan.transfer.empty()) b.timed("transfer", [&] { b.transfer(); });
  b.timed("normals", [&] { b.normals(); });
  b.finish(mesh);
}

std::size_t keep_particles_in_box(ParticleSet& particles, const std::vector<double>& box) {
  if (box.empty()) return 0;
  if (box.size() != 6) throw InvalidParameter(fmt::format("particle_box: {} numbers given, expected 6", box.size()));
  return particles.keep_if([&](Vec3f x) {
    return x.x >= box[0] && x.y >= box[1] && x.z >= box[2] && x.x <= box[3] && x.y <= box[4] && x.z <= box[5];
  });
}

namespace {

/// The input checks of reconstruct(); returns the particles' velocity attribute (or null).
const AttributeView* check_inputs(const ParticlesView& particles, const Params& params) {
  check_particles(particles);
  if (particles.size() == 0) throw InputError("no particles to surface");
  for (const std::string& name : params.transfer)
    if (!particles.find(name)) {
      std::string available;
      for (const AttributeView& a : particles.attributes) available += (available.empty() ? "" : ", ") + std::string(a.name);
      throw InvalidParameter(fmt::format("transfer: the particles have no attribute '{}' (they have: {})", name,
                                         available.empty() ? "none" : available));
    }
  // What an optional dependency does, refused before any work where this build has not got it.
  check_post_processing_available(params);
  const AttributeView* velocity = velocity_attribute(particles);
  if (params.velocity_weighted && !velocity)
    throw InvalidParameter("velocity_weighted: the particles have no velocity attribute (v, vel or velocity with 3 "
                           "components); surface without --velocity-weighted");
  return velocity;
}

/// The particles with a bridge across each pinhole of thin water (grid/pinholes.hpp); a bridge
/// takes the attribute values of the particle nearest to it. Empty when there is no pinhole.
ParticleSet with_pinhole_bridges(const ParticlesView& particles, const Params& p, Stats& stats) {
  const std::vector<Vec3f> bridges = pinhole_bridges(particles.positions, pinhole_settings(p.spacing, p.r_outer));
  stats.pinhole_bridges = bridges.size();
  if (bridges.empty()) return {};
  ParticleSet out = particles.copy();
  out.positions.insert(out.positions.end(), bridges.begin(), bridges.end());
  if (!particles.attributes.empty()) {
    const HashGrid grid(particles.positions, float(p.r_outer));
    for (const Vec3f& b : bridges) {
      const uint32_t nearest = grid.order()[grid_nearest(grid, b).index];
      for (Attribute& a : out.attributes) {
        const std::size_t c = std::size_t(a.components);
        for (std::size_t k = 0; k < c; ++k) a.values.push_back(a.values[nearest * c + k]);
      }
    }
  }
  return out;
}

/// The written surface's components and, when it is closed, its genus: a closed triangle mesh
/// has E = 3F/2, so χ = V − F/2 and genus = C − χ/2 summed over its components.
void count_handles(const TriangleMesh& mesh, const Params& p, Stats& stats) {
  const std::vector<uint32_t> root = component_roots(mesh.vertices.size(), mesh.triangles);
  std::vector<uint8_t> used(mesh.vertices.size(), 0);
  for (const Triangle& t : mesh.triangles) used[t[0]] = used[t[1]] = used[t[2]] = 1;
  long long v = 0, c = 0;
  for (std::size_t i = 0; i < root.size(); ++i)
    if (used[i]) ++v, c += root[i] == i ? 1 : 0;
  stats.components = std::size_t(c);
  const bool closed = p.clip_box.empty() || (p.clip_cap && stats.cap_open_edges == 0);
  const long long f = (long long)mesh.triangles.size();
  stats.genus = closed && f % 2 == 0 ? c - (v - f / 2) / 2 : -1;
}

/// Warnings about resolved parameters that will not give what the user expects.
void warn_about(const Params& p, Stats& stats) {
  const double d = p.spacing, h = p.voxel_size;
  if (p.r_outer * p.r_outer <= d * d / 2 + p.r_inner * p.r_inner)
    stats.warnings.push_back(fmt::format(
        "r_outer² ≤ d²/2 + r_inner² (Williams' flatness condition): flat fluid will not come out flat "
        "(r_outer {:g}, r_inner {:g}, spacing {:g})",
        p.r_outer, p.r_inner, d));
  if (p.erode > h / 2)
    stats.warnings.push_back(
        fmt::format("erode {:g} exceeds half a voxel ({:g}); large erosion can self-intersect", p.erode, h / 2));
}

/// The CUDA backend, when asked (refused without a device) or, for auto, when a real device is
/// there (never the emulated one of a MENISCUS_CUDA_EMULATION build, unless a test asks for it).
/// Returns whether it ran; a failure of auto's attempt leaves a warning and the CPU runs.
bool run_on_device(const PipelineInput& in, Result& result, const ProgressFn& progress) {
  Stats& stats = result.stats;
  const Params& p = in.params;
  if (p.backend == Backend::cpu) return false;
  if (p.close_handles && p.backend == Backend::cuda)  // a pass of the CPU's (mesh/handles.hpp)
    throw InvalidParameter("close_handles: the handles are closed by a pass of the CPU backend's, which the CUDA "
                           "backend does not have yet; use --backend cpu or auto");
  std::string why;
  const std::vector<CudaDeviceInfo> devices = cuda_devices(&why);
  const bool auto_takes_emulated = std::getenv("MENISCUS_EMULATED_DEVICE_FOR_AUTO") != nullptr;
  const bool have_device =
      p.backend == Backend::cuda
          ? !devices.empty()
          : std::any_of(devices.begin(), devices.end(),
                        [&](const CudaDeviceInfo& dev) { return !dev.emulated || auto_takes_emulated; });
  if (!devices.empty() && !have_device) why = "the CUDA device is emulated (a test build)";
  if (p.backend == Backend::cuda && !have_device)
    throw ResourceError(fmt::format("--backend cuda: no CUDA backend available ({}); use --backend cpu or auto", why));
  // No device: auto runs on the CPU without a word each run (`meniscus info` says why there is none).
  if (!have_device) return false;
  if (p.close_handles) {  // auto: the frame runs where the pass is, and says so
    stats.warnings.push_back("close_handles: the handles are closed by a pass of the CPU backend's; this frame ran on "
                             "the CPU, not the CUDA device");
    return false;
  }
  const std::size_t stages_before = stats.stages.size();
  try {
    run_stages(in.plan, *cuda::make_device_stages(in, stats, progress), result.mesh);
    stats.backend = "cuda";
    return true;
  } catch (const ResourceError& e) {
    if (p.backend == Backend::cuda) throw;
    stats.stages.resize(stages_before);
    stats.device_calls.clear();
    result.mesh = {};
    stats.warnings.push_back(fmt::format("CUDA backend failed, running on the CPU instead: {}", e.what()));
    return false;
  }
}

/// The finished mesh's post-processing on the host, whichever backend made it: the strays, the
/// clip (and its cap), then the simplification.
void post_process(const StagePlan& plan, const ParticlesView& particles, Result& result, const ProgressFn& progress) {
  TriangleMesh& mesh = result.mesh;
  Stats& stats = result.stats;
  StageTimer timer(stats, progress);
  if (plan.min_particles > 0) {
    stats.removed_strays = timer.run("strays", [&] {
      return remove_components_enclosing_few(mesh, particles.positions, plan.stray_reach,
                                             std::size_t(plan.min_particles));
    });
    if (mesh.triangles.empty() && stats.removed_strays > 0)
      stats.warnings.push_back(fmt::format("{} dropped every piece of the surface ({} of them, each enclosing fewer "
                                           "particles): the mesh is empty",
                                           spelled_setting("min_particles", std::to_string(plan.min_particles)),
                                           stats.removed_strays));
  }
  if (!plan.clip_box.empty()) {
    const std::vector<double>& b = plan.clip_box;
    const ClipBox box{float(b[0]), float(b[1]), float(b[2]), float(b[3]), float(b[4]), float(b[5])};
    Vec3f lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
    for (const Vec3f& v : mesh.vertices) lo = min(lo, v), hi = max(hi, v);
    const ClipOutcome clip = timer.run("clip", [&] { return clip_to_box(mesh, box, plan.clip_cap); });
    stats.clipped_triangles = clip.removed_triangles;
    stats.cut_triangles = clip.cut_triangles;
    stats.cap_triangles = clip.cap_triangles;
    stats.cap_open_edges = clip.cap_defects;
    if (clip.cap_defects > 0)
      stats.warnings.push_back(fmt::format(
          "{}: {} edges left open where the cut's curves cross on a box face (the surface intersects itself "
          "there); the mesh is not watertight",
          spelled("clip_cap"), clip.cap_defects));
    if (mesh.triangles.empty() && clip.removed_triangles > 0)
      stats.warnings.push_back(fmt::format(
          "{} holds none of the surface: the mesh is empty (the surface spans {:g},{:g},{:g} to {:g},{:g},{:g})",
          spelled_setting("clip_box", fmt::format("{:g}", fmt::join(b, ","))), lo.x, lo.y, lo.z, hi.x, hi.y, hi.z));
  }
  if (plan.decimate_bound > 0) {
    const DecimateOutcome d =
        timer.run("decimate", [&] { return decimate(mesh, plan.decimate_bound, plan.decimate_cell); });
    stats.decimated_triangles = d.triangles_before - d.triangles_after;
    stats.decimate_error = d.max_error;
    stats.decimate_rounds = d.rounds;
  }
}

/// The bounding box of the particles (empty: lo > hi).
std::pair<std::array<double, 3>, std::array<double, 3>> bounds_of(const ParticlesView& particles) {
  std::array<double, 3> lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
  for (const Vec3f& p : particles.positions)
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], double(p[a])), hi[a] = std::max(hi[a], double(p[a]));
  return {lo, hi};
}

}  // namespace

std::array<double, 3> local_origin(const std::array<double, 3>& lo, const std::array<double, 3>& hi) {
  // Far from the origin, single precision has too few bits left for the surface's detail and the
  // grids' axes too little range; about a point in the frame's middle it keeps the precision of
  // its own size. The point sits on a grid of a power of two at least the frame's extent, so that
  // the frames of a sequence share it unless the fluid crosses a cell.
  constexpr double kFarExtents = 16;
  double extent = 0, farthest = 0;
  for (int a = 0; a < 3; ++a) {
    if (!(lo[a] <= hi[a])) return {};  // no particles
    extent = std::max(extent, hi[a] - lo[a]);
    farthest = std::max({farthest, std::abs(lo[a]), std::abs(hi[a])});
  }
  if (!(farthest > kFarExtents * extent) || !std::isfinite(farthest)) return {};
  const double cell = std::exp2(std::ceil(std::log2(std::max(extent, 1e-30))));
  std::array<double, 3> origin{};
  for (int a = 0; a < 3; ++a) origin[a] = std::round((lo[a] + hi[a]) / 2 / cell) * cell;
  return origin;
}

namespace {

/// The threads and the memory a run is granted: granted_threads() and memory_limit() unless the
/// parameters fix them. A Reconstructor asks once; reconstruct() asks every call.
struct RunGrants {
  Grant cpus, memory;
  explicit RunGrants(const Params& params)
      : cpus(params.threads > 0 ? Grant{double(params.threads), "--threads"} : granted_threads()),
        memory(memory_limit(params.max_memory_gb)) {}
};

/// reconstruct() about `o` (local_origin) with these grants; with `keys`, on the CPU's stages with
/// the vertices' order keys (reconstruct_ordered).
Result reconstruct_keyed(const ParticlesView& all_particles, const Params& params, const std::array<double, 3>& o,
                         const ProgressFn& progress, std::vector<VertexOrderKey>* keys, const RunGrants& grants) {
  // --particle-box: the particles outside are ignored before anything else.
  ParticleSet boxed;
  std::size_t outside = 0;
  if (!params.particle_box.empty()) {
    params.validate();
    boxed = all_particles.copy();
    outside = keep_particles_in_box(boxed, params.particle_box);
    if (boxed.size() == 0 && all_particles.size() > 0)
      throw InvalidParameter(fmt::format("particle_box: all {} particles are outside the box", all_particles.size()));
  }
  const ParticlesView given_particles = params.particle_box.empty() ? all_particles : ParticlesView(boxed);
  // A frame far from the origin is computed about a local one (and its clip box with it) and
  // written back where it was.
  const struct {
    double x, y, z;
    bool shifted() const { return x != 0 || y != 0 || z != 0; }
  } origin{o[0], o[1], o[2]};
  ParticleSet local;
  if (origin.shifted()) {
    local = given_particles.copy();
    for (Vec3f& x : local.positions)
      x = Vec3f{float(double(x.x) - origin.x), float(double(x.y) - origin.y), float(double(x.z) - origin.z)};
  }
  const ParticlesView particles = origin.shifted() ? ParticlesView(local) : given_particles;
  Result result;
  Stats& stats = result.stats;
  stats.particles_outside_box = outside;
  const AttributeView* velocity = check_inputs(particles, params);
  const Grant& cpus = grants.cpus;
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::size_t(cpus.amount));
  Params given = params;
  given.threads = int(cpus.amount);
  if (origin.shifted() && given.clip_box.size() == 6)
    for (int k = 0; k < 6; ++k) given.clip_box[std::size_t(k)] -= k % 3 == 0 ? origin.x : (k % 3 == 1 ? origin.y : origin.z);
  stats.threads_from = cpus.source;
  const Grant& memory = grants.memory;
  given.max_memory_gb = memory.amount / 1e9;
  stats.max_memory_from = memory.source;
  // The parameters, the bridges across pinholes (fill_pinholes), then the coincident particles (a
  // near-coincident pile made exact copies of its first particle, which the stages' queries skip).
  CoincidentParticles coincident;
  ParticleSet bridged;  // the particles and the bridges across pinholes, when there are any
  Params p = StageTimer(stats, progress).run("parameters", [&] {
    Params resolved = resolve_params(particles, given);
    if (resolved.fill_pinholes) bridged = with_pinhole_bridges(particles, resolved, stats);
    coincident = coincident_particles(bridged.positions.empty() ? particles : ParticlesView(bridged), resolved);
    return resolved;
  });
  const ParticlesView input = bridged.positions.empty() ? particles : ParticlesView(bridged);
  if (!bridged.positions.empty()) velocity = velocity_attribute(input);
  stats.spacing_estimated = params.spacing == 0;
  stats.particles = particles.size();
  stats.threads = p.threads;
  warn_about(p, stats);
  result.params = p;
  // SPH volumes per original particle for the sph and anisotropic fields (empty: uniform d³).
  const std::vector<float> volumes = p.field == FieldMethod::sph || p.field == FieldMethod::anisotropic
                                         ? particle_volumes(input, p.spacing, p.rest_density)
                                         : std::vector<float>{};
  const StagePlan plan = plan_stages(p);  // both backends run these stages, in run_stages' order
  const ParticlesView surfaced = coincident.moved ? ParticlesView(*coincident.moved) : input;
  const PipelineInput in{surfaced, p, plan, volumes, velocity, keys != nullptr, coincident.first};
  if (keys != nullptr || !run_on_device(in, result, progress)) {
    stats.backend = "cpu";
    run_stages(plan, *make_cpu_stages(in, stats, progress), result.mesh);
  }
  post_process(plan, surfaced, result, progress);
  if (keys != nullptr) *keys = take_order_keys(result.mesh);
  if (origin.shifted() && keys != nullptr) {
    result.params.clip_box = params.clip_box;  // the mesh stays local: ordered_part moves it back
  } else if (origin.shifted()) {
    for (Vec3f& v : result.mesh.vertices)
      v = Vec3f{float(double(v.x) + origin.x), float(double(v.y) + origin.y), float(double(v.z) + origin.z)};
    result.params.clip_box = params.clip_box;
    // Written back where it was, the mesh is rounded to the single-precision coordinates there:
    // said when they are coarse against the spacing, with the triangles the rounding flattened.
    const double farthest = std::max({std::abs(origin.x), std::abs(origin.y), std::abs(origin.z)});
    const double step = farthest * std::ldexp(1.0, -23);  // a float's spacing there, within a factor 2
    if (step > 0.005 * p.spacing) {
      std::size_t flat = 0;
      for (const Triangle& t : result.mesh.triangles) {
        const Vec3f a = result.mesh.vertices[t[0]], b = result.mesh.vertices[t[1]], c = result.mesh.vertices[t[2]];
        const Vec3f e0 = b - a, e1 = c - a;
        const double longest = std::max({double(length(e0)), double(length(e1)), double(length(c - b))});
        if (double(length(cross(e0, e1))) <= 1e-6 * longest * longest) ++flat;
      }
      stats.warnings.push_back(fmt::format(
          "the particles lie about {:.3g} from the origin, where single-precision coordinates are {:.2g} spacings "
          "apart: the frame was surfaced about a local origin, but the mesh is written back in single precision "
          "there{} (move the scene nearer the origin for full precision)",
          farthest, step / p.spacing,
          flat == 0 ? std::string() : fmt::format(", which flattens {} of its triangles", flat)));
    }
  }
  stats.vertices = result.mesh.vertices.size();
  stats.triangles = result.mesh.triangles.size();
  count_handles(result.mesh, p, stats);
  stats.peak_memory_bytes = peak_resident_bytes();
  return result;
}

}  // namespace

std::array<double, 3> frame_origin(const ParticlesView& particles, const Params& params) {
  if (params.particle_box.empty()) {
    const auto [lo, hi] = bounds_of(particles);
    return local_origin(lo, hi);
  }
  params.validate();
  ParticleSet boxed = particles.copy();
  keep_particles_in_box(boxed, params.particle_box);
  const auto [lo, hi] = bounds_of(boxed);
  return local_origin(lo, hi);
}

Result reconstruct(const ParticlesView& particles, const Params& params, const ProgressFn& progress) {
  return reconstruct_keyed(particles, params, frame_origin(particles, params), progress, nullptr, RunGrants(params));
}

Result reconstruct_about(const ParticlesView& particles, const Params& params, const std::array<double, 3>& origin,
                         const ProgressFn& progress) {
  return reconstruct_keyed(particles, params, origin, progress, nullptr, RunGrants(params));
}

Result reconstruct_ordered(const ParticleSet& particles, const Params& params, std::vector<VertexOrderKey>& keys,
                           const std::array<double, 3>& origin) {
  if (params.backend == Backend::cuda)
    throw InvalidParameter("backend cuda: a rank of an MPI job surfaces its slab on the CPU, whose extraction gives the "
                           "vertices' order keys (and the CUDA backend's positions agree with the CPU's to rounding, "
                           "not bit for bit); use --backend cpu or auto");
  if (params.steps_a + params.steps_b + params.steps_free == 0)
    throw InvalidParameter("steps_a, steps_b and steps_free all 0: without a sweep the triangles stay in the "
                           "extraction's block order, which the ranks' pieces cannot be gathered in; run at least "
                           "one sweep, or surface in one process");
  if (params.close_handles)
    throw InvalidParameter("close_handles: whether a handle's loop separates the surface is a question about the "
                           "whole of it, which a rank's slab cannot answer; surface in one process");
  if (params.erode > 0)
    throw InvalidParameter("erode: the erosion moves each vertex along a normal summed in the slab's triangle order, "
                           "which rounds differently from the whole frame's at a few vertices");
  Result result = reconstruct_keyed(particles, params, origin, {}, &keys, RunGrants(params));
  for (std::size_t v = 1; v < keys.size(); ++v)
    if (!(keys[v - 1] < keys[v]))
      throw std::logic_error(fmt::format("reconstruct_ordered: vertices {} and {} are not in their keys' order", v - 1, v));
  return result;
}

struct Reconstructor::State {
  Params params;
  RunGrants grants;
  std::mutex busy;
  std::size_t frames = 0;
  explicit State(const Params& p) : params(p), grants(p) {}
};

Reconstructor::Reconstructor(const Params& params) {
  params.validate();
  state_ = std::make_unique<State>(params);
}

Reconstructor::~Reconstructor() = default;
Reconstructor::Reconstructor(Reconstructor&&) noexcept = default;
Reconstructor& Reconstructor::operator=(Reconstructor&&) noexcept = default;

Result Reconstructor::operator()(const ParticlesView& particles, const ProgressFn& progress) {
  if (!state_) throw std::logic_error("Reconstructor: used after it was moved from");
  const std::unique_lock lock(state_->busy, std::try_to_lock);
  if (!lock.owns_lock())
    throw std::runtime_error("Reconstructor: it is surfacing a frame already (a call from another thread, or from "
                             "its own progress callback); make one Reconstructor per thread");
  Result result = reconstruct_keyed(particles, state_->params, frame_origin(particles, state_->params), progress,
                                    nullptr, state_->grants);
  ++state_->frames;
  return result;
}

const Params& Reconstructor::params() const { return state_->params; }
std::size_t Reconstructor::frames() const { return state_->frames; }

}  // namespace meniscus
