// meniscus — the pipeline: runs the stages in order, times them, reports progress
// (docs/method.md: hash grid → sparse distance field → extraction → weld → constrained smoothing →
// erosion → attribute transfer → normals).
#include <unistd.h>

#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <span>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <optional>

#include "common/clock.hpp"
#include "cuda/pipeline_cuda.hpp"
#include "stage_plan.hpp"
#include "extract/extract.hpp"
#include "field/anisotropy.hpp"
#include "field/distance_field.hpp"
#include "field/kernel_field.hpp"
#include "field/kernel_impl.hpp"
#include "grid/hash_grid.hpp"
#include "grid/key_index.hpp"
#include "memory_scope.hpp"
#include "mesh/clip.hpp"
#include "mesh/decimate.hpp"
#include "mesh/voids.hpp"
#include "meniscus/backend.hpp"
#include "meniscus/distributed.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/messages.hpp"
#include "meniscus/memory.hpp"
#include "meniscus/reconstruct.hpp"
#include "meniscus/resources.hpp"
#include "extract/field_band.hpp"
#include "mesh/vertex_order.hpp"
#include "smooth/schedule.hpp"
#include "smooth/smooth.hpp"
#include "transfer/attribute_transfer.hpp"
#include "transfer/normals.hpp"
#include "transfer/velocity_weight_impl.hpp"

namespace meniscus {

const char* version() { return MENISCUS_VERSION; }

double Stats::total_seconds() const {
  double t = 0;
  for (const StageTime& s : stages) t += s.seconds;
  return t;
}

namespace {

/// The finest cell or voxel surfaced: single precision squares distances, and below this their
/// squares come near the smallest normal float (1e-38).
constexpr double kMinSpacing = 1e-12;

/// Refuses (InputError) a cell of `cell` below kMinSpacing, and a particle farther from the
/// origin than a grid axis of such cells holds (kMaxCoord), naming it: a stray far from the fluid.
/// `first`: the index of positions[0] in the frame; `what`: the cells, for the message.
void check_coordinates(std::span<const Vec3f> positions, std::size_t first, double cell, std::string_view what) {
  const double limit = double(kMaxCoord) * cell;
  if (!(cell >= kMinSpacing))
    throw InputError(fmt::format("{} would be {:.3g} wide: particles this close cannot be surfaced in single precision "
                                 "(their squared distances underflow); scale the scene up, e.g. to metres",
                                 what, cell));
  for (std::size_t i = 0; i < positions.size(); ++i) {
    const Vec3f p = positions[i];
    if (std::abs(double(p.x)) < limit && std::abs(double(p.y)) < limit && std::abs(double(p.z)) < limit) continue;
    throw InputError(fmt::format("particle {} lies at ({:g}, {:g}, {:g}), more than {} of {} ({:.3g}) from the "
                                 "origin, which a grid axis cannot hold: a stray or corrupt value far from the fluid "
                                 "(leave it out with {}), or a scene to move nearer the origin",
                                 first + i, p.x, p.y, p.z, kMaxCoord, what, cell, spelled("particle_box")));
  }
}

class StageTimer {
 public:
  StageTimer(Stats& stats, const ProgressFn& progress) : stats_(stats), progress_(progress) {}
  template <class F>
  auto run(const char* name, F&& f) {
    if (progress_) progress_(name, 0.0);
    const auto t0 = std::chrono::steady_clock::now();
    if constexpr (std::is_void_v<decltype(f())>) {
      f();
      finish(name, t0);
    } else {
      auto result = f();
      finish(name, t0);
      return result;
    }
  }

 private:
  void finish(const char* name, std::chrono::steady_clock::time_point t0) {
    const double s = seconds_since(t0);
    stats_.stages.push_back({name, s});
    if (progress_) progress_(name, 1.0);
  }
  Stats& stats_;
  const ProgressFn& progress_;
};

void check_particles(const ParticleSet& particles) {
  particles.validate();
  for (std::size_t i = 0; i < particles.size(); ++i) {
    const Vec3f p = particles.positions[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw InputError(fmt::format("particle {} has a non-finite coordinate ({}, {}, {})", i, p.x, p.y, p.z));
  }
}

/// The process's resident memory now (0 where /proc is not there).
double resident_bytes() {
  std::ifstream statm("/proc/self/statm");
  double pages = 0, resident = 0;
  return statm >> pages >> resident ? resident * double(sysconf(_SC_PAGE_SIZE)) : 0.0;
}

/// What a run needs per block of the field band, through the smoothing: the block's samples, the
/// mesh extracted in it and that mesh's smoothing arrays. Measured on the bundled real frames
/// (peak RSS over the baseline / field blocks, default field): 16-27 KB; 24 KB is the estimate,
/// the 90 % default share of the grant the margin.
constexpr double kRunBytesPerBandBlock = 24e3;

/// Refuses, before allocating, a field that would not fit in `max_bytes`, and a run whose field,
/// mesh and smoothing would not (`limit_from`: where the limit comes from, for the message).
std::vector<uint64_t> checked_band_blocks(const HashGrid& grid, const SampleLattice& lattice, float band,
                                          double max_bytes, const Params& p, const std::string& limit_from) {
  // Upper bound on the keys band_blocks() would list (each occupied hash cell's box expanded by
  // the band, in blocks), so an absurd voxel size is refused before the key list is built.
  const double block_size = double(lattice.cell_size) * lattice.block_cells();
  const double span = (double(grid.cell_size()) + 2.0 * band) / block_size + 1.0;
  const double bound = double(grid.cell_keys().size()) * span * span * span;
  const auto refuse = [&](double blocks) {
    throw ResourceError(fmt::format(
        "the distance field would need about {} ({:.3g} blocks of {} samples at voxel size {:g}), more than "
        "the {} allowed ({}); use a larger {} or raise {}",
        human_bytes(blocks * kBlockSamples * 4), blocks, kBlockSamples, p.voxel_size, human_bytes(max_bytes), limit_from,
        spelled("voxel_size"), spelled("max_memory_gb")));
  };
  if (bound * 8.0 > max_bytes) refuse(bound);
  std::vector<uint64_t> keys = band_blocks(grid, lattice, band);
  if (double(keys.size()) * (kBlockSamples * 4 + 20) > max_bytes) refuse(double(keys.size()));
  const double resident = resident_bytes(), need = resident + double(keys.size()) * kRunBytesPerBandBlock;
  if (need > max_bytes)
    throw ResourceError(fmt::format(
        "this frame would need about {} ({} in use, {} field blocks at voxel size {:g} for the field, the mesh and its "
        "smoothing), more than the {} allowed ({}); use a larger {}, or give the job more memory ({}, Slurm's --mem)",
        human_bytes(need), human_bytes(resident), keys.size(), p.voxel_size, human_bytes(max_bytes), limit_from,
        spelled("voxel_size"), spelled("max_memory_gb")));
  return keys;
}

/// The particles' attribute with one of these names and this many components, or nullptr.
const Attribute* find_attribute(const ParticleSet& particles, std::initializer_list<const char*> names, int components) {
  for (const char* name : names)
    if (const Attribute* a = particles.find(name); a && a->components == components) return a;
  return nullptr;
}

const Attribute* density_attribute(const ParticleSet& particles) {
  return find_attribute(particles, {"density", "rho", "dens"}, 1);
}
const Attribute* mass_attribute(const ParticleSet& particles) { return find_attribute(particles, {"mass", "m"}, 1); }
const Attribute* velocity_attribute(const ParticleSet& particles) {
  return find_attribute(particles, {"v", "vel", "velocity"}, 3);
}

/// The median of the particles' positive densities (0 when none is positive).
double median_density(const Attribute& density) {
  std::vector<float> rho;
  rho.reserve(density.values.size());
  for (float r : density.values)
    if (r > 0) rho.push_back(r);
  if (rho.empty()) return 0;
  auto mid = rho.begin() + std::ptrdiff_t(rho.size() / 2);
  std::nth_element(rho.begin(), mid, rho.end());
  return double(*mid);
}

/// SPH volumes m_i/ρ_i per original particle (Müller et al. 2003): mass/density when the particles
/// carry both, d³·ρ₀/ρ_i with a density only (uniform mass; ρ₀ = rest_density, resolved), empty
/// (uniform d³) otherwise. Each volume is the particle's own: nothing frame-wide but ρ₀.
std::vector<float> particle_volumes(const ParticleSet& particles, double d, double rho0) {
  const Attribute* density = density_attribute(particles);
  if (!density) return {};
  const Attribute* mass = mass_attribute(particles);
  if (!mass && !(rho0 > 0)) return {};
  std::vector<float> v(particles.size());
  for (std::size_t i = 0; i < v.size(); ++i) {
    const double r = double(density->values[i]);
    if (mass && mass->values[i] > 0 && r > 0)
      v[i] = float(double(mass->values[i]) / r);
    else  // no mass, or a particle without a density: its volume at the rest density
      v[i] = float(d * d * d * (rho0 > 0 && r > 0 ? rho0 / r : 1.0));
  }
  return v;
}

template <class T>
std::vector<T> to_sorted_order(const HashGrid& grid, const std::vector<T>& original) {
  std::vector<T> out(original.size());
  const auto order = grid.order();
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = original[order[i]];
  return out;
}

/// The velocity weighting's reference speed when not given: the particles' 95th-percentile speed.
double velocity_reference(const Attribute& velocity) {
  std::vector<float> speed(velocity.size());
  for (std::size_t i = 0; i < speed.size(); ++i)
    speed[i] = length(Vec3f{velocity.values[3 * i], velocity.values[3 * i + 1], velocity.values[3 * i + 2]});
  if (speed.empty()) return 0.0;
  auto q = speed.begin() + std::ptrdiff_t(double(speed.size() - 1) * 0.95);
  std::nth_element(speed.begin(), q, speed.end());
  return double(*q);
}

/// Per-vertex damping factors of the velocity weighting (velocity_weight_impl.hpp).
std::vector<float> velocity_weights(const Attribute& velocity, const HashGrid& grid, std::span<const Vec3f> vertices,
                                    const Params& p) {
  std::vector<float> w(vertices.size(), 1.0f);
  if (!(p.velocity_reference > 0)) return w;  // nothing moves: smooth everywhere
  const Attribute v = transfer_attribute(velocity, grid, vertices, float(p.transfer_radius));
  for (std::size_t i = 0; i < w.size(); ++i)
    w[i] = velocity_weight(Vec3f{v.values[3 * i], v.values[3 * i + 1], v.values[3 * i + 2]},
                           float(p.velocity_reference), float(p.velocity_min_weight));
  return w;
}

}  // namespace

double estimate_spacing(const ParticleSet& particles, std::size_t max_samples) {
  return estimate_spacing_parts(particles, 0, particles.size(), local_reduce(), max_samples);
}

double estimate_spacing_parts(const ParticleSet& part, std::size_t first, std::size_t n, const Reduce& reduce,
                              std::size_t max_samples) {
  if (n < 2)
    throw InputError(fmt::format("cannot estimate the particle spacing from fewer than 2 particles; give {}",
                                 spelled("spacing")));
  // The box of the bulk of the frame: each axis without its extreme half-percent (of a sample of
  // each part), so that one stray far away (a corrupt value, a particle flung out) neither makes
  // the search cells huge nor hides the spacing. −hi is reduced by min with lo.
  std::vector<float> box(6, INFINITY);
  {
    const std::size_t held = part.positions.size(), step = std::max<std::size_t>(1, held / 20000);
    std::array<std::vector<float>, 3> axis;
    for (std::size_t i = 0; i < held; i += step)
      for (int c = 0; c < 3; ++c) axis[std::size_t(c)].push_back(part.positions[i][c]);
    for (std::size_t c = 0; c < 3 && held > 0; ++c) {
      std::vector<float>& v = axis[c];
      const std::size_t cut = v.size() / 200;
      std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(cut), v.end());
      box[c] = v[cut];
      std::nth_element(v.begin(), v.end() - 1 - std::ptrdiff_t(cut), v.end());
      box[c + 3] = -v[v.size() - 1 - cut];
    }
  }
  reduce.min(box);
  const Vec3f lo{box[0], box[1], box[2]}, hi{-box[3], -box[4], -box[5]};
  const double ex = double(hi.x) - double(lo.x), ey = double(hi.y) - double(lo.y), ez = double(hi.z) - double(lo.z);
  const double diag = std::sqrt(ex * ex + ey * ey + ez * ez);
  if (!(diag > 0))
    throw InputError(fmt::format("all particles are at one position ({:g}, {:g}, {:g}): there is no spacing to "
                                 "estimate nor a volume to surface",
                                 lo.x, lo.y, lo.z));
  // A cell size of about one particle per cell if they filled their bounding box (a lower
  // bound on the volume: flat sets use the area instead).
  const double volume = std::max(ex, 1e-6 * diag) * std::max(ey, 1e-6 * diag) * std::max(ez, 1e-6 * diag);
  const float cell = float(std::max(std::cbrt(volume / double(n)), diag * 1e-5));
  check_coordinates(part.positions, first, cell, "the cells of the spacing's estimate");
  const HashGrid grid(part.positions, cell);
  const std::size_t samples = std::min(n, max_samples);
  const std::size_t stride = n / samples;
  const std::size_t held = part.positions.size();
  auto held_index = [&](std::size_t s) { return s * stride >= first && s * stride < first + held; };
  // Every sample's position, from the part that holds it.
  std::vector<float> at(3 * samples, INFINITY);
  for (std::size_t s = 0; s < samples; ++s)
    if (held_index(s))
      for (int c = 0; c < 3; ++c) at[3 * s + std::size_t(c)] = part.positions[s * stride - first][c];
  reduce.min(at);
  auto sample = [&](std::size_t s) { return Vec3f{at[3 * s], at[3 * s + 1], at[3 * s + 2]}; };

  // The nearest other particle of each sample (squared distance > 0): a bound from the part that
  // holds the sample (the nearest within it, by growing spheres), then the minimum over every
  // part within that bound. One part holding all: the nearest of the whole frame at once.
  std::vector<float> nearest(samples, INFINITY);
  const float widest = 2.0f * float(diag) + cell;
  tbb::parallel_for(std::size_t(0), samples, [&](std::size_t s) {
    if (!held_index(s)) return;
    const Vec3f p = sample(s);
    for (float r = cell; r <= widest; r *= 2.0f) {
      float best = INFINITY;
      grid.for_each_within(p, r, [&](uint32_t, float d2) {
        if (d2 > 0 && d2 < best) best = d2;
      });
      if (best <= r * r) {
        nearest[s] = best;
        return;
      }
    }
  });
  reduce.min(nearest);
  if (n > held) {  // the other parts, within each sample's bound
    tbb::parallel_for(std::size_t(0), samples, [&](std::size_t s) {
      const float bound = nearest[s];
      const float r = std::isfinite(bound) ? std::sqrt(bound) * (1 + 1e-5f) : widest;
      float best = bound;
      grid.for_each_within(sample(s), r, [&](uint32_t, float d2) {
        if (d2 > 0 && d2 < best) best = d2;
      });
      nearest[s] = best;
    });
    reduce.min(nearest);
  }
  std::vector<float> nn;
  nn.reserve(samples);
  for (float d2 : nearest)
    if (std::isfinite(d2)) nn.push_back(std::sqrt(d2));
  if (nn.empty()) throw InputError("cannot estimate the particle spacing: no two distinct particles");
  auto mid = nn.begin() + std::ptrdiff_t(nn.size() / 2);
  std::nth_element(nn.begin(), mid, nn.end());
  const float median_nn = *mid;

  // Local density spacing: (ball volume / particles in the ball)^(1/3).
  const float radius = 2.5f * median_nn;
  const HashGrid density_grid(part.positions, radius);
  std::vector<uint64_t> counts(samples, 0);
  tbb::parallel_for(std::size_t(0), samples, [&](std::size_t s) {
    std::size_t count = 0;
    density_grid.for_each_within(sample(s), radius, [&](uint32_t, float) { ++count; });
    counts[s] = count;
  });
  reduce.sum(counts);
  std::vector<float> local(samples);
  for (std::size_t s = 0; s < samples; ++s)
    local[s] = std::cbrt(4.18879f * radius * radius * radius / float(std::max<uint64_t>(counts[s], 1)));
  auto quartile = local.begin() + std::ptrdiff_t(local.size() / 4);
  std::nth_element(local.begin(), quartile, local.end());
  return double(std::max(median_nn, *quartile));
}

Params resolve_params(const ParticleSet& particles, const Params& in) {
  in.validate();
  Params p = in;
  if (p.spacing == 0) p.spacing = estimate_spacing(particles);
  const double d = p.spacing;
  if (p.voxel_size == 0) p.voxel_size = d / (2 * p.detail);
  check_coordinates(particles.positions, 0, p.voxel_size, "the field's voxels");
  if (p.r_outer == 0) p.r_outer = std::max(p.r_outer_factor * d, in.r_inner > 0 ? in.r_inner * 2 : 0.0);
  if (p.r_inner == 0) p.r_inner = 0.5 * p.r_outer;
  if (p.transfer_radius == 0) p.transfer_radius = 2 * d;
  if (p.relax == 0) p.relax = 1.0;  // Jacobi sweeps diverge above 1; Chebyshev's weights accelerate them
  if (p.kernel_radius == 0 && p.field != FieldMethod::distance) p.kernel_radius = 2 * d;
  // Anisotropic: λ = 0.3, not Yu & Turk's 0.9. Their centre smoothing removes the bumps of the
  // raw positions, which the constrained smoothing does here anyway; 0.9 pulls the surface
  // particles' centres so far in that 12-16 % of the particles end up outside the surface (dam
  // break 23, double dam break 26), while a thin sheet still needs some (λ = 0 tears it).
  if (p.smooth_particles == -1) p.smooth_particles = p.field == FieldMethod::anisotropic ? 0.3 : 0.0;
  if (p.iso == 0) switch (p.field) {
      case FieldMethod::distance: break;
      case FieldMethod::metaball: p.iso = 0.5 * metaball_bulk_value(p.kernel_radius, d); break;
      case FieldMethod::sph:
      case FieldMethod::anisotropic: p.iso = 0.5; break;
      case FieldMethod::zhu_bridson: p.iso = p.r_outer; break;
    }
  if (p.field == FieldMethod::zhu_bridson && p.iso >= p.kernel_radius)
    throw InvalidParameter(fmt::format("iso = {:g}: the zhu-bridson radius must be smaller than kernel_radius ({:g})",
                                       p.iso, p.kernel_radius));
  // The frame-wide estimates besides the spacing (resolve_frame_estimates).
  if (p.rest_density == 0 && (p.field == FieldMethod::sph || p.field == FieldMethod::anisotropic) &&
      !mass_attribute(particles))
    if (const Attribute* density = density_attribute(particles)) p.rest_density = median_density(*density);
  if (p.velocity_weighted && p.velocity_reference == 0)
    if (const Attribute* velocity = velocity_attribute(particles))
      p.velocity_reference = velocity_reference(*velocity);
  if (p.threads == 0) p.threads = int(granted_threads().amount);
  if (p.max_memory_gb == 0) p.max_memory_gb = memory_limit(0).amount / 1e9;
  p.validate();
  return p;
}

double local_reach(const Params& p) {
  const double d = p.spacing, edge = longest_triangle_edge(p.extract, p.voxel_size);
  const ParticlePass pass = particle_pass(p);  // the centre smoothing's and the PCA's radii
  const bool anisotropic = pass.anisotropic;
  const AnisotropyConstants& k = pass.constants;
  // What an extracted vertex's position reads: the two samples of its lattice edge (within one
  // edge of it), each the particles within r_outer or the kernels' support (anisotropic: R·σ̃₁ ≤
  // R·k_max, or the outer constraint shells, r_outer·σ̃₁ ≤ r_outer·k_r^(2/3), each ellipsoid from
  // its particle's neighbours within 2R), the centres smoothed over 2d.
  double field = p.field == FieldMethod::distance ? p.r_outer : p.kernel_radius * (anisotropic ? k.k_max : 1.0);
  if (anisotropic) field = std::max(field, p.r_outer * std::cbrt(double(k.k_r) * k.k_r)) + pass.pca_radius;
  if (pass.run) field += pass.smooth_radius;
  field += 2 * edge;
  // What a projection reads: the (metric-)nearest particle, within r_outer (an ellipsoid's
  // longest axis at most k_r^(2/3) times that) of where the vertex is, plus that ellipsoid's
  // own reach; the velocity weights, the particles within the transfer radius. A vertex moves
  // during the sweeps: kDrift allows 4 d (measured at most 2.9 d on every bundled frame with the
  // default schedule, --field anisotropic and --extract cubes).
  constexpr double kDrift = 4;
  double projection = p.r_outer;
  if (anisotropic) projection = p.r_outer * std::cbrt(double(k.k_r) * k.k_r) + pass.pca_radius;
  if (pass.run) projection += pass.smooth_radius;
  if (p.velocity_weighted) projection = std::max(projection, p.transfer_radius);
  projection += kDrift * d;
  const int rings = smoothing_rings(smooth_schedule(p)) + (p.erode > 0 ? 1 : 0);
  return rings * edge + std::max(field, projection);
}

Params resolve_frame_estimates(const ParticleSet& particles, const Params& params) {
  if (params.particle_box.empty())
    return resolve_frame_estimates_parts(particles, 0, particles.size(), params, local_reduce());
  params.validate();
  ParticleSet boxed = particles;  // the estimates of the particles reconstruct() surfaces
  keep_particles_in_box(boxed, params.particle_box);
  return resolve_frame_estimates_parts(boxed, 0, boxed.size(), params, local_reduce());
}

Params resolve_frame_estimates_parts(const ParticleSet& part, std::size_t first, std::size_t total,
                                     const Params& params, const Reduce& reduce) {
  params.validate();
  Params p = params;
  if (p.spacing == 0) p.spacing = estimate_spacing_parts(part, first, total, reduce);
  // The median positive density and the 95th percentile speed of the whole frame (resolve_params'
  // median_density and velocity_reference), selected over the parts.
  std::vector<uint64_t> count(1, 0);
  if (p.rest_density == 0 && (p.field == FieldMethod::sph || p.field == FieldMethod::anisotropic) &&
      !mass_attribute(part)) {
    std::vector<float> rho;
    if (const Attribute* density = density_attribute(part))
      for (float r : density->values)
        if (r > 0) rho.push_back(r);
    count[0] = rho.size();
    reduce.sum(count);
    if (count[0] > 0) p.rest_density = double(select_parts(rho, {count[0] / 2}, reduce)[0]);
  }
  if (p.velocity_weighted && p.velocity_reference == 0) {
    std::vector<float> speed;
    if (const Attribute* velocity = velocity_attribute(part))
      for (std::size_t i = 0; i < velocity->size(); ++i)
        speed.push_back(length(Vec3f{velocity->values[3 * i], velocity->values[3 * i + 1], velocity->values[3 * i + 2]}));
    count[0] = speed.size();
    reduce.sum(count);
    if (count[0] > 0)
      p.velocity_reference = double(select_parts(speed, {uint64_t(double(count[0] - 1) * 0.95)}, reduce)[0]);
  }
  return p;
}

namespace {

/// The input checks of reconstruct(); returns the particles' velocity attribute (or null).
const Attribute* check_inputs(const ParticleSet& particles, const Params& params) {
  check_particles(particles);
  if (particles.size() == 0) throw InputError("no particles to surface");
  for (const std::string& name : params.transfer)
    if (!particles.find(name)) {
      std::string available;
      for (const Attribute& a : particles.attributes) available += (available.empty() ? "" : ", ") + a.name;
      throw InvalidParameter(fmt::format("transfer: the particles have no attribute '{}' (they have: {})", name,
                                         available.empty() ? "none" : available));
    }
  const Attribute* velocity = velocity_attribute(particles);
  if (params.velocity_weighted && !velocity)
    throw InvalidParameter("velocity_weighted: the particles have no velocity attribute (v, vel or velocity with 3 "
                           "components); surface without --velocity-weighted");
  return velocity;
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
  const std::size_t stages_before = stats.stages.size();
  try {
    cuda::reconstruct(in, stats, result.mesh, progress);
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

/// The CPU pipeline: the stages of `plan`, in order, each timed.
class CpuPipeline {
 public:
  CpuPipeline(const PipelineInput& in, Result& result, const ProgressFn& progress)
      : particles_(in.particles), p_(in.params), plan_(in.plan), volumes_(in.volumes), velocity_(in.velocity),
        stats_(result.stats), mesh_(result.mesh), progress_(progress), timer_(result.stats, progress) {}

  void run() {
    particle_frames();
    build_grid();
    field_and_extract();
    remove_small_components();
    reorder();
    smooth();
    if (plan_.erode)
      stats_.flipped_triangles =
          timer_.run("erode", [&] { return erode(mesh_.vertices, mesh_.triangles, plan_.erode_distance); });
    transfer();
    timer_.run("normals", [&] { mesh_.normals = vertex_normals(mesh_.vertices, mesh_.triangles); });
  }

 private:
  /// Kernel centres: the particles, Laplacian-smoothed when asked (Yu & Turk §5), and the
  /// anisotropic ellipsoids, each centre held close enough to keep its particle inside its shell;
  /// the constraints use the centres too.
  void particle_frames() {
    const ParticlePass& pass = plan_.particles;
    if (!pass.run) return;
    centres_ = timer_.run("particles", [&] {
      const HashGrid raw(particles_.positions, pass.raw_cell);
      if (pass.anisotropic) ellipsoids_ = yu_turk_ellipsoids(raw, pass.pca_radius, pass.constants);
      if (!(pass.lambda > 0)) return particles_.positions;
      std::vector<Vec3f> centres = smooth_positions(raw, pass.smooth_radius, pass.lambda);
      if (pass.anisotropic) hold_particles_in_shells(particles_.positions, ellipsoids_, pass.centre_reach, centres);
      return centres;
    });
  }

  void build_grid() {
    const std::span<const Vec3f> positions =
        centres_.empty() ? std::span<const Vec3f>(particles_.positions) : std::span<const Vec3f>(centres_);
    grid_ = timer_.run("grid", [&] { return HashGrid(positions, plan_.grid_cell); });
    sorted_ellipsoids_ = to_sorted_order(*grid_, ellipsoids_);
    if (plan_.ellipsoid_shells) {  // the constraint shells, which the field's inside includes too
      shells_.resize(sorted_ellipsoids_.size());
      for (std::size_t i = 0; i < shells_.size(); ++i) {
        shells_[i] = unit_volume_shell(sorted_ellipsoids_[i]);
        shell_axis_ = std::max(shell_axis_, shells_[i].max_axis);
      }
    }
  }

  void field_and_extract() {
    const double max_bytes = p_.max_memory_gb * 1e9;
    const double d = p_.spacing;
    ExtractResult extracted;
    if (!plan_.kernel_field) {
      const SparseField field = timer_.run("field", [&] {
        return distance_field(*grid_, plan_.lattice, plan_.distance_band,
                              checked_band_blocks(*grid_, plan_.lattice, plan_.distance_band, max_bytes, p_,
                                                  stats_.max_memory_from));
      });
      stats_.field_blocks = field.block_count();
      extracted = timer_.run("extract", [&] { return extract_surface(field, plan_.iso, plan_.extractor); });
    } else {
      KernelFieldInput in;
      in.centres = &*grid_;
      in.method = plan_.field;
      in.kernel_radius = float(p_.kernel_radius);
      in.iso = float(p_.iso);
      in.uniform_volume = float(d * d * d);
      const std::vector<float> sorted_volumes = to_sorted_order(*grid_, volumes_);
      in.volumes = sorted_volumes;
      in.ellipsoids = sorted_ellipsoids_;
      in.shells = shells_;
      in.shell_radius = plan_.r_outer;
      const SparseField field = timer_.run("field", [&] {
        const float band = kernel_support(in) + float(p_.voxel_size);
        return kernel_field(in, plan_.lattice, checked_band_blocks(*grid_, plan_.lattice, band, max_bytes, p_, stats_.max_memory_from));
      });
      stats_.field_blocks = field.block_count();
      extracted = timer_.run("extract", [&] { return extract_surface(field, plan_.iso, plan_.extractor); });
    }
    stats_.dropped_triangles = extracted.dropped_triangles;
    mesh_ = std::move(extracted.mesh);
  }

  void remove_small_components() {
    if (plan_.remove_voids)
      stats_.removed_voids = timer_.run("voids", [&] { return remove_small_voids(mesh_, plan_.void_volume); });
    if (plan_.remove_blobs)
      stats_.removed_blobs = timer_.run("blobs", [&] {
        return remove_unsupported_blobs(mesh_, *grid_, plan_.void_volume, plan_.blob_min_volume);
      });
  }

  /// The extraction numbers vertices in edge-key (row-major) order; the sweeps run 2-4x faster on a
  /// Z-ordered mesh, where a vertex's ring and particle list sit near it in memory.
  void reorder() {
    if (!plan_.sweeps) return;
    reuse_.end();  // the reordered mesh, which lives through the smoothing, gets its own mappings
    timer_.run("reorder", [&] { reorder_vertices_spatially(mesh_, plan_.lattice.cell_size); });
    reuse_.end();  // and the heap gives back the old mesh the reorder freed
  }

  void smooth() {
    timer_.run("smooth", [&] {
      SmoothOptions o;
      static_cast<SmoothSchedule&>(o) = plan_.schedule;
      std::vector<float> weights;
      if (plan_.velocity_weights) {
        weights = velocity_weights(*velocity_, *grid_, mesh_.vertices, p_);
        o.vertex_relax = weights;
      }
      // The particles' original indices serve only the attribute transfer from here on: without
      // one, 4 bytes a particle less through the sweeps (4 MB of a 1M-particle block's peak).
      if (plan_.transfer.empty()) grid_->release_order();
      const auto tick = [&](double f) { if (progress_) progress_("smooth", f); };
      if (plan_.ellipsoid_shells) {
        const EllipsoidConstraint constraint{&*grid_, shells_, plan_.r_inner, plan_.r_outer, shell_axis_};
        stats_.smoothing = smooth_surface(mesh_.vertices, mesh_.triangles, &constraint, o, tick);
      } else {
        const ShellConstraint constraint{&*grid_, plan_.r_inner, plan_.r_outer};
        stats_.smoothing = smooth_surface(mesh_.vertices, mesh_.triangles, &constraint, o, tick);
      }
    });
  }

  void transfer() {
    if (plan_.transfer.empty()) return;
    timer_.run("transfer", [&] {
      for (const std::string& name : plan_.transfer)
        mesh_.attributes.push_back(transfer_attribute(*particles_.find(name), *grid_, mesh_.vertices, plan_.transfer_radius));
    });
  }

  const ParticleSet& particles_;
  const Params& p_;
  const StagePlan& plan_;
  const std::vector<float>& volumes_;
  const Attribute* velocity_;
  Stats& stats_;
  TriangleMesh& mesh_;
  const ProgressFn& progress_;
  StageTimer timer_;
  HeapReuseScope reuse_;  // up to the smoothing, where the CLI asks for it (meniscus/memory.hpp)
  std::vector<Vec3f> centres_;
  std::vector<Ellipsoid> ellipsoids_, sorted_ellipsoids_;  // original order; the grid's
  std::vector<Ellipsoid> shells_;                         // the constraint shells, the grid's order
  float shell_axis_ = 0;                                  // their longest axis
  std::optional<HashGrid> grid_;
};

}  // namespace

std::size_t keep_particles_in_box(ParticleSet& particles, const std::vector<double>& box) {
  if (box.empty()) return 0;
  if (box.size() != 6) throw InvalidParameter(fmt::format("particle_box: {} numbers given, expected 6", box.size()));
  return particles.keep_if([&](Vec3f x) {
    return x.x >= box[0] && x.y >= box[1] && x.z >= box[2] && x.x <= box[3] && x.y <= box[4] && x.z <= box[5];
  });
}

namespace {

/// The finished mesh's post-processing, whichever backend made it: the clip (and its cap), then
/// the simplification.
void finish_mesh(TriangleMesh& mesh, const Params& p, Stats& stats, const ProgressFn& progress) {
  if (!p.clip_box.empty()) {
    const ClipBox box{float(p.clip_box[0]), float(p.clip_box[1]), float(p.clip_box[2]),
                      float(p.clip_box[3]), float(p.clip_box[4]), float(p.clip_box[5])};
    Vec3f lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
    for (const Vec3f& v : mesh.vertices) lo = min(lo, v), hi = max(hi, v);
    const ClipOutcome clip = StageTimer(stats, progress).run("clip", [&] { return clip_to_box(mesh, box, p.clip_cap); });
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
          spelled_setting("clip_box", fmt::format("{:g}", fmt::join(p.clip_box, ","))), lo.x, lo.y, lo.z, hi.x, hi.y,
          hi.z));
  }
  if (p.decimate > 0) {
    const DecimateOutcome d = StageTimer(stats, progress).run("decimate", [&] { return decimate(mesh, p.decimate * p.spacing); });
    stats.decimated_triangles = d.triangles_before - d.triangles_after;
    stats.decimate_error = d.max_error;
    stats.decimate_kept_whole = d.kept_whole;
    stats.decimate_rounds = d.rounds;
  }
}

}  // namespace

Result reconstruct(const ParticleSet& all_particles, const Params& params, const ProgressFn& progress) {
  // --particle-box: the particles outside are ignored before anything else.
  ParticleSet boxed;
  std::size_t outside = 0;
  if (!params.particle_box.empty()) {
    params.validate();
    boxed = all_particles;
    outside = keep_particles_in_box(boxed, params.particle_box);
    if (boxed.size() == 0 && all_particles.size() > 0)
      throw InvalidParameter(fmt::format("particle_box: all {} particles are outside the box", all_particles.size()));
  }
  const ParticleSet& particles = params.particle_box.empty() ? all_particles : boxed;
  Result result;
  Stats& stats = result.stats;
  stats.particles_outside_box = outside;
  const Attribute* velocity = check_inputs(particles, params);
  const Grant cpus = params.threads > 0 ? Grant{double(params.threads), "--threads"} : granted_threads();
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::size_t(cpus.amount));
  Params given = params;
  given.threads = int(cpus.amount);
  stats.threads_from = cpus.source;
  const Grant memory = memory_limit(given.max_memory_gb);
  given.max_memory_gb = memory.amount / 1e9;
  stats.max_memory_from = memory.source;
  Params p = StageTimer(stats, progress).run("parameters", [&] { return resolve_params(particles, given); });
  stats.spacing_estimated = params.spacing == 0;
  stats.particles = particles.size();
  stats.threads = p.threads;
  warn_about(p, stats);
  result.params = p;
  // SPH volumes per original particle for the sph and anisotropic fields (empty: uniform d³).
  const std::vector<float> volumes = p.field == FieldMethod::sph || p.field == FieldMethod::anisotropic
                                         ? particle_volumes(particles, p.spacing, p.rest_density)
                                         : std::vector<float>{};
  const StagePlan plan = plan_stages(p);  // both backends run these stages
  const PipelineInput in{particles, p, plan, volumes, velocity};
  if (!run_on_device(in, result, progress)) {
    stats.backend = "cpu";
    CpuPipeline(in, result, progress).run();
  }
  if (p.min_particles > 0) {  // on the finished mesh, whichever backend made it
    stats.removed_strays = StageTimer(stats, progress).run("strays", [&] {
      return remove_components_enclosing_few(result.mesh, particles.positions, float(std::max(p.r_outer, 2 * p.spacing)),
                                             std::size_t(p.min_particles));
    });
    if (result.mesh.triangles.empty() && stats.removed_strays > 0)
      stats.warnings.push_back(fmt::format("{} dropped every piece of the surface ({} of them, each enclosing fewer "
                                           "particles): the mesh is empty",
                                           spelled_setting("min_particles", std::to_string(p.min_particles)),
                                           stats.removed_strays));
  }
  finish_mesh(result.mesh, p, stats, progress);
  stats.vertices = result.mesh.vertices.size();
  stats.triangles = result.mesh.triangles.size();
  stats.peak_memory_bytes = peak_resident_bytes();
  return result;
}

std::string stats_to_json(const Result& result) {
  const Stats& s = result.stats;
  const Params& p = result.params;
  nlohmann::ordered_json j;
  j["meniscus"] = version();
  j["particles"] = s.particles;
  j["vertices"] = s.vertices;
  j["triangles"] = s.triangles;
  j["field_blocks"] = s.field_blocks;
  j["dropped_triangles"] = s.dropped_triangles;
  j["removed_voids"] = s.removed_voids;
  j["removed_blobs"] = s.removed_blobs;
  j["removed_strays"] = s.removed_strays;
  j["particles_outside_box"] = s.particles_outside_box;
  j["clipped_triangles"] = s.clipped_triangles;
  j["cut_triangles"] = s.cut_triangles;
  j["cap_triangles"] = s.cap_triangles;
  j["cap_open_edges"] = s.cap_open_edges;
  j["decimated_triangles"] = s.decimated_triangles;
  j["decimate_error"] = s.decimate_error;
  j["decimate_kept_whole"] = s.decimate_kept_whole;
  j["decimate_rounds"] = s.decimate_rounds;
  j["flipped_triangles"] = s.flipped_triangles;
  j["ranks"] = 1;  // one process (an MPI run over K ranks says K: docs/cluster.md)
  j["threads"] = s.threads;
  j["threads_from"] = s.threads_from;
  j["max_memory_from"] = s.max_memory_from;
  j["backend"] = s.backend;
  j["peak_memory_bytes"] = s.peak_memory_bytes;
  j["total_seconds"] = s.total_seconds();
  nlohmann::ordered_json stages = nlohmann::ordered_json::object();
  for (const StageTime& t : s.stages) stages[t.name] = t.seconds;
  j["stages"] = stages;
  if (!s.device_calls.empty()) {  // the CUDA backend: what each stage asked of the device, and in all
    nlohmann::ordered_json calls = nlohmann::ordered_json::object();
    DeviceStageCalls total{"total"};
    for (const DeviceStageCalls& c : s.device_calls) {
      calls[c.name] = {{"launches", c.launches}, {"uploads", c.uploads}, {"downloads", c.downloads},
                       {"device_copies", c.device_copies}, {"memsets", c.memsets}, {"waits", c.waits}};
      total.launches += c.launches, total.uploads += c.uploads, total.downloads += c.downloads;
      total.device_copies += c.device_copies, total.memsets += c.memsets, total.waits += c.waits;
    }
    calls["total"] = {{"launches", total.launches}, {"uploads", total.uploads}, {"downloads", total.downloads},
                      {"device_copies", total.device_copies}, {"memsets", total.memsets}, {"waits", total.waits}};
    j["device_calls"] = calls;
  }
  j["smoothing"] = {{"energy_start", s.smoothing.energy_start},
                    {"energy_final", s.smoothing.energy_final},
                    {"damped_vertices", s.smoothing.damped_vertices},
                    {"relax_b_min", s.smoothing.relax_b_min},
                    {"batches", s.smoothing.batches},
                    {"setup_seconds", s.smoothing.setup_seconds},
                    {"a_sweeps_seconds", s.smoothing.a_sweeps_seconds},
                    {"b_sweeps_seconds", s.smoothing.b_sweeps_seconds}};
  nlohmann::ordered_json q;
  q["spacing"] = p.spacing;
  q["spacing_estimated"] = s.spacing_estimated;
  if (!s.estimated_on.empty()) q["estimated_on"] = s.estimated_on;
  q["voxel_size"] = p.voxel_size;
  q["detail"] = p.detail;
  q["r_inner"] = p.r_inner;
  q["r_outer"] = p.r_outer;
  q["r_outer_factor"] = p.r_outer_factor;
  q["extract"] = to_string(p.extract);
  q["keep_voids"] = p.keep_voids;
  q["field"] = to_string(p.field);
  q["iso"] = p.iso;
  q["kernel_radius"] = p.kernel_radius;
  q["rest_density"] = p.rest_density;
  q["smooth_particles"] = p.smooth_particles;
  q["steps_a"] = p.steps_a;
  q["steps_b"] = p.steps_b;
  q["steps_free"] = p.steps_free;
  q["relax"] = p.relax;
  q["relax_b"] = p.relax_b;
  q["solver"] = to_string(p.solver);
  q["rebuild_b"] = p.rebuild_b;
  q["velocity_weighted"] = p.velocity_weighted;
  q["velocity_reference"] = p.velocity_reference;
  q["velocity_min_weight"] = p.velocity_min_weight;
  q["erode"] = p.erode;
  q["min_particles"] = p.min_particles;
  if (!p.particle_box.empty()) q["particle_box"] = p.particle_box;
  if (!p.clip_box.empty()) q["clip_box"] = p.clip_box;
  q["clip_cap"] = p.clip_cap;
  q["decimate"] = p.decimate;
  q["transfer"] = p.transfer;
  q["transfer_radius"] = p.transfer_radius;
  q["threads"] = p.threads;
  q["backend"] = to_string(p.backend);
  q["max_memory_gb"] = p.max_memory_gb;
  j["parameters"] = q;
  j["warnings"] = s.warnings;
  return j.dump(2);
}

}  // namespace meniscus
