// meniscus — the inputs checked and the parameters resolved: the spacing estimate, the other
// frame-wide estimates (rest density, reference speed), what 0 derives, R_local, and the
// coincident particles the stages treat as copies.

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <span>

#include <fmt/format.h>

#include "common/for_each.hpp"
#include "field/anisotropy.hpp"
#include "field/kernel_impl.hpp"
#include "grid/coincident.hpp"
#include "grid/key_index.hpp"
#include "grid/pinholes.hpp"
#include "mesh/handles.hpp"
#include "extract/field_band.hpp"
#include "meniscus/distributed.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/messages.hpp"
#include "meniscus/resources.hpp"
#include "pipeline/internal.hpp"
#include "pipeline/stage_plan.hpp"
#include "post/decimate.hpp"
#include "smooth/schedule.hpp"

namespace meniscus {

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

void check_particles(const ParticlesView& particles) {
  particles.validate();
  for (std::size_t i = 0; i < particles.size(); ++i) {
    const Vec3f p = particles.positions[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw InputError(fmt::format("particle {} has a non-finite coordinate ({}, {}, {})", i, p.x, p.y, p.z));
  }
}

CoincidentParticles coincident_particles(const ParticlesView& particles, const Params& resolved) {
  CoincidentParticles out;
  const HashGrid grid(particles.positions, float(std::max(resolved.spacing, resolved.voxel_size)));
  CoincidentPoints groups = coincident_points(grid, kCoincidentSpacings * resolved.spacing);
  if (groups.copies == 0) return out;
  const std::span<const Vec3f> x = particles.positions;
  bool apart = false;
  for (std::size_t i = 0; i < x.size() && !apart; ++i) apart = !(x[i] == x[groups.first[i]]);
  if (apart) {
    out.moved = particles.copy();
    std::vector<Vec3f>& y = out.moved->positions;
    for (std::size_t i = 0; i < y.size(); ++i) y[i] = y[groups.first[i]];  // a first precedes its copies
  }
  out.first = std::move(groups.first);
  return out;
}

const AttributeView* find_attribute(const ParticlesView& particles, std::initializer_list<const char*> names,
                                    int components) {
  for (const char* name : names)
    if (const AttributeView* a = particles.find(name); a && a->components == components) return a;
  return nullptr;
}

const AttributeView* density_attribute(const ParticlesView& particles) {
  return find_attribute(particles, {"density", "rho", "dens"}, 1);
}
const AttributeView* mass_attribute(const ParticlesView& particles) { return find_attribute(particles, {"mass", "m"}, 1); }
const AttributeView* velocity_attribute(const ParticlesView& particles) {
  return find_attribute(particles, {"v", "vel", "velocity"}, 3);
}

double median_density(const AttributeView& density) {
  std::vector<float> rho;
  rho.reserve(density.values.size());
  for (float r : density.values)
    if (r > 0) rho.push_back(r);
  if (rho.empty()) return 0;
  auto mid = rho.begin() + std::ptrdiff_t(rho.size() / 2);
  std::nth_element(rho.begin(), mid, rho.end());
  return double(*mid);
}

std::vector<float> particle_volumes(const ParticlesView& particles, double d, double rho0) {
  const AttributeView* density = density_attribute(particles);
  if (!density) return {};
  const AttributeView* mass = mass_attribute(particles);
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

double velocity_reference(const AttributeView& velocity) {
  std::vector<float> speed(velocity.size());
  for (std::size_t i = 0; i < speed.size(); ++i)
    speed[i] = length(Vec3f{velocity.values[3 * i], velocity.values[3 * i + 1], velocity.values[3 * i + 2]});
  if (speed.empty()) return 0.0;
  auto q = speed.begin() + std::ptrdiff_t(double(speed.size() - 1) * 0.95);
  std::nth_element(speed.begin(), q, speed.end());
  return double(*q);
}

double estimate_spacing(const ParticlesView& particles, std::size_t max_samples) {
  return estimate_spacing_parts(particles, 0, particles.size(), local_reduce(), max_samples);
}

double estimate_spacing_parts(const ParticlesView& part, std::size_t first, std::size_t n, const Reduce& reduce,
                              std::size_t max_samples) {
  if (n < 2)
    throw InputError(fmt::format("cannot estimate the particle spacing from fewer than 2 particles; give {}",
                                 spelled("spacing")));
  // The box of the bulk of the frame: each axis without its extreme half-percent (of a sample of
  // each part, each position once: a pile of copies is not the bulk), so that one stray far away
  // (a corrupt value, a particle flung out) neither makes the search cells huge nor hides the
  // spacing. −hi is reduced by min with lo.
  std::vector<float> box(6, INFINITY);
  {
    const std::size_t held = part.positions.size(), step = std::max<std::size_t>(1, held / 20000);
    std::vector<Vec3f> sampled;
    for (std::size_t i = 0; i < held; i += step) sampled.push_back(part.positions[i]);
    std::sort(sampled.begin(), sampled.end(), [](Vec3f a, Vec3f b) {
      return a.x != b.x ? a.x < b.x : (a.y != b.y ? a.y < b.y : a.z < b.z);
    });
    sampled.erase(std::unique(sampled.begin(), sampled.end()), sampled.end());
    std::array<std::vector<float>, 3> axis;
    for (const Vec3f& q : sampled)
      for (int c = 0; c < 3; ++c) axis[std::size_t(c)].push_back(q[c]);
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
  // The searches run over sites: the particles, except that a pile of coincident ones (copies,
  // or particles within a hair of one another: one cell of a lattice kCoincidentInCell times
  // finer than the search's) is one site, which counts the pile's particles. Every search then
  // costs what it costs without the pile: a sample in a pile of k would scan all k, and most
  // samples are in the pile when it is most of the frame (O(samples · k), quadratic). A sample's
  // nearest neighbour is the nearest site farther than `coincident` (twice the fine cell, more
  // than a pile narrower than it spans): exact copies change nothing in it, as they never did.
  // The sites' grid has about one site per cell, as the particles' has one particle: cells sized
  // for the particles of a frame that is mostly piles would leave the sites thousands of empty
  // cells apart, each visited by the growing spheres. The distances found do not depend on the
  // cells, only the time to find them. O(n) to group, O(k log k) more for a pile of k.
  const double tolerance = cell * kCoincidentInCell;
  const float coincident2 = float(4 * tolerance * tolerance);
  const std::size_t held = part.positions.size();
  const CoincidentPoints groups = coincident_points(grid, tolerance);
  std::vector<uint64_t> site_total(1, held - groups.copies);
  reduce.sum(site_total);
  const float search_cell =
      site_total[0] >= n ? cell
                         : float(std::max(std::cbrt(volume / double(std::max<uint64_t>(site_total[0], 1))), diag * 1e-5));
  std::vector<Vec3f> site_positions;
  std::vector<uint32_t> site_count;  // per site (in part order); empty: every site one particle
  if (groups.copies > 0) {
    GroupHeads heads = group_heads(groups, held);
    site_positions.resize(heads.index.size());
    for (std::size_t k = 0; k < heads.index.size(); ++k) site_positions[k] = part.positions[heads.index[k]];
    site_count = std::move(heads.count);
  }
  const std::span<const Vec3f> sites = groups.copies > 0 ? std::span<const Vec3f>(site_positions) : part.positions;
  std::optional<HashGrid> site_grid;
  if (groups.copies > 0 || search_cell != cell) site_grid.emplace(sites, search_cell);
  const HashGrid& search = site_grid ? *site_grid : grid;
  const std::size_t samples = std::min(n, max_samples);
  // Sample s is particle s·n/samples: spread over the whole frame (a pile at its start or end is
  // one stretch of the indices, not all of the samples).
  auto index_of = [&](std::size_t s) { return std::size_t(uint64_t(s) * uint64_t(n) / uint64_t(samples)); };
  auto held_index = [&](std::size_t s) { return index_of(s) >= first && index_of(s) < first + held; };
  // Every sample's position, from the part that holds it.
  std::vector<float> at(3 * samples, INFINITY);
  for (std::size_t s = 0; s < samples; ++s)
    if (held_index(s))
      for (int c = 0; c < 3; ++c) at[3 * s + std::size_t(c)] = part.positions[index_of(s) - first][c];
  reduce.min(at);
  auto sample = [&](std::size_t s) { return Vec3f{at[3 * s], at[3 * s + 1], at[3 * s + 2]}; };
  // A sample that is a copy in a pile (not the first of its group) stands for no site of its own:
  // it is left out of both statistics, so a pile that is most of the frame does not make most of
  // the samples (its first particle is one sample, as any particle).
  std::vector<uint64_t> copy(samples, 0);
  if (groups.copies > 0)
    for (std::size_t s = 0; s < samples; ++s)
      if (held_index(s) && groups.first[index_of(s) - first] != index_of(s) - first) copy[s] = 1;
  reduce.sum(copy);

  // The nearest other site of each sample (squared distance > coincident2): a bound from the
  // part that holds the sample (the nearest within it, by growing spheres), then the minimum over
  // every part within that bound. One part holding all: the nearest of the whole frame at once.
  std::vector<float> nearest(samples, INFINITY);
  const float widest = 2.0f * float(diag) + cell;
  for_each_index(samples, [&](std::size_t s) {
    if (!held_index(s)) return;
    const Vec3f p = sample(s);
    for (float r = search_cell; r <= widest; r *= 2.0f) {
      float best = INFINITY;
      search.for_each_within(p, r, [&](uint32_t, float d2) {
        if (d2 > coincident2 && d2 < best) best = d2;
      });
      if (best <= r * r) {
        nearest[s] = best;
        return;
      }
    }
  });
  reduce.min(nearest);
  if (n > held) {  // the other parts, within each sample's bound
    for_each_index(samples, [&](std::size_t s) {
      const float bound = nearest[s];
      const float r = std::isfinite(bound) ? std::sqrt(bound) * (1 + 1e-5f) : widest;
      float best = bound;
      search.for_each_within(sample(s), r, [&](uint32_t, float d2) {
        if (d2 > coincident2 && d2 < best) best = d2;
      });
      nearest[s] = best;
    });
    reduce.min(nearest);
  }
  std::vector<float> nn;
  nn.reserve(samples);
  for (std::size_t s = 0; s < samples; ++s)
    if (std::isfinite(nearest[s]) && copy[s] == 0) nn.push_back(std::sqrt(nearest[s]));
  if (nn.empty()) {  // every sample fell in a pile: the copies' distances are the pile's first's
    std::fill(copy.begin(), copy.end(), 0);
    for (float d2 : nearest)
      if (std::isfinite(d2)) nn.push_back(std::sqrt(d2));
  }
  if (nn.empty()) throw InputError("cannot estimate the particle spacing: no two distinct particles");
  auto mid = nn.begin() + std::ptrdiff_t(nn.size() / 2);
  std::nth_element(nn.begin(), mid, nn.end());
  const float median_nn = *mid;

  // Local density spacing: (ball volume / particles in the ball)^(1/3), the particles counted by
  // site (a site counts its pile).
  const float radius = 2.5f * median_nn;
  const HashGrid density_grid(sites, radius);
  const auto density_order = density_grid.order();
  std::vector<uint64_t> counts(samples, 0);
  for_each_index(samples, [&](std::size_t s) {
    std::size_t count = 0;
    if (site_count.empty())
      density_grid.for_each_within(sample(s), radius, [&](uint32_t, float) { ++count; });
    else
      density_grid.for_each_within(sample(s), radius, [&](uint32_t i, float) { count += site_count[density_order[i]]; });
    counts[s] = count;
  });
  reduce.sum(counts);
  std::vector<float> local;
  local.reserve(samples);
  for (std::size_t s = 0; s < samples; ++s)
    if (copy[s] == 0)
      local.push_back(std::cbrt(4.18879f * radius * radius * radius / float(std::max<uint64_t>(counts[s], 1))));
  auto quartile = local.begin() + std::ptrdiff_t(local.size() / 4);
  std::nth_element(local.begin(), quartile, local.end());
  return double(std::max(median_nn, *quartile));
}

Params resolve_params(const ParticlesView& particles, const Params& in) {
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
  // particles' centres so far in that many particles end up outside the surface (docs/fields.md),
  // while a thin sheet still needs some (λ = 0 tears it).
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
    if (const AttributeView* density = density_attribute(particles)) p.rest_density = median_density(*density);
  if (p.velocity_weighted && p.velocity_reference == 0)
    if (const AttributeView* velocity = velocity_attribute(particles))
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
  // during the sweeps: kDrift allows 4 d, with room above the largest move measured on the
  // bundled frames with the default schedule, --field anisotropic and --extract cubes
  // (docs/method.md#smooth--srcsmooth).
  constexpr double kDrift = 4;
  double projection = p.r_outer;
  if (anisotropic) projection = p.r_outer * std::cbrt(double(k.k_r) * k.k_r) + pass.pca_radius;
  if (pass.run) projection += pass.smooth_radius;
  if (p.velocity_weighted) projection = std::max(projection, p.transfer_radius);
  projection += kDrift * d;
  const int rings = smoothing_rings(smooth_schedule(p)) + (p.erode > 0 ? 1 : 0);
  // The simplification reads the finished mesh around a triangle (post/decimate.hpp).
  const double simplified = p.decimate > 0 ? decimate_reach(decimate_cell_spacings(p.decimate) * d) : 0;
  // A bridge across a pinhole is a particle like the others, made from the particles near it.
  const double bridges = p.fill_pinholes ? pinhole_reach(pinhole_settings(d, p.r_outer)) : 0;
  // A handle's cut reads the mesh within its rings + 2 edges of its seed (the pockets), and
  // changes it within rings + 1, the valence flips round its caps a few edges further; whether its
  // loop separates the surface is a question about the whole (mesh/handles.hpp).
  const double handles = p.close_handles ? (2 * HandleSettings{}.rings + 6) * edge : 0;
  return rings * edge + std::max(field, projection) + simplified + bridges + handles;
}

Params resolve_frame_estimates(const ParticlesView& particles, const Params& params) {
  if (params.particle_box.empty())
    return resolve_frame_estimates_parts(particles, 0, particles.size(), params, local_reduce());
  params.validate();
  ParticleSet boxed = particles.copy();  // the estimates of the particles reconstruct() surfaces
  keep_particles_in_box(boxed, params.particle_box);
  if (boxed.size() == 0 && particles.size() > 0)  // as reconstruct() says it
    throw InvalidParameter(fmt::format("particle_box: all {} particles are outside the box", particles.size()));
  return resolve_frame_estimates_parts(boxed, 0, boxed.size(), params, local_reduce());
}

Params resolve_frame_estimates_parts(const ParticlesView& part, std::size_t first, std::size_t total,
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
    if (const AttributeView* density = density_attribute(part))
      for (float r : density->values)
        if (r > 0) rho.push_back(r);
    count[0] = rho.size();
    reduce.sum(count);
    if (count[0] > 0) p.rest_density = double(select_parts(rho, {count[0] / 2}, reduce)[0]);
  }
  if (p.velocity_weighted && p.velocity_reference == 0) {
    std::vector<float> speed;
    if (const AttributeView* velocity = velocity_attribute(part))
      for (std::size_t i = 0; i < velocity->size(); ++i)
        speed.push_back(length(Vec3f{velocity->values[3 * i], velocity->values[3 * i + 1], velocity->values[3 * i + 2]}));
    count[0] = speed.size();
    reduce.sum(count);
    if (count[0] > 0)
      p.velocity_reference = double(select_parts(speed, {uint64_t(double(count[0] - 1) * 0.95)}, reduce)[0]);
  }
  return p;
}

}  // namespace meniscus
