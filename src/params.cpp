// meniscus — parameter names and validation.
#include "meniscus/params.hpp"

#include <cmath>
#include <fmt/format.h>

#include "meniscus/errors.hpp"

namespace meniscus {

const char* to_string(Extractor e) {
  switch (e) {
    case Extractor::tiles: return "tiles";
    case Extractor::cubes: return "cubes";
    case Extractor::tetrahedra: return "tetrahedra";
  }
  return "?";
}

const char* to_string(SmoothingSolver s) { return s == SmoothingSolver::jacobi ? "jacobi" : "chebyshev"; }

Extractor parse_extractor(const std::string& name) {
  if (name == "tiles") return Extractor::tiles;
  if (name == "cubes") return Extractor::cubes;
  if (name == "tetrahedra") return Extractor::tetrahedra;
  throw InvalidParameter(fmt::format("extract: unknown extractor '{}' (expected tiles, cubes or tetrahedra)", name));
}

SmoothingSolver parse_solver(const std::string& name) {
  if (name == "chebyshev") return SmoothingSolver::chebyshev;
  if (name == "jacobi") return SmoothingSolver::jacobi;
  if (name == "gauss-seidel")
    throw InvalidParameter("solver: gauss-seidel is gone: its colour order made every vertex depend on the whole frame; "
                           "use chebyshev (the default: Jacobi sweeps accelerated as far, and local)");
  throw InvalidParameter(fmt::format("solver: unknown solver '{}' (expected chebyshev or jacobi)", name));
}

const char* to_string(Backend b) {
  switch (b) {
    case Backend::automatic: return "auto";
    case Backend::cpu: return "cpu";
    case Backend::cuda: return "cuda";
  }
  return "?";
}

const char* to_string(FieldMethod f) {
  switch (f) {
    case FieldMethod::distance: return "distance";
    case FieldMethod::metaball: return "metaball";
    case FieldMethod::sph: return "sph";
    case FieldMethod::zhu_bridson: return "zhu-bridson";
    case FieldMethod::anisotropic: return "anisotropic";
  }
  return "?";
}

Backend parse_backend(const std::string& name) {
  if (name == "auto") return Backend::automatic;
  if (name == "cpu") return Backend::cpu;
  if (name == "cuda") return Backend::cuda;
  throw InvalidParameter(fmt::format("backend: unknown backend '{}' (expected auto, cpu or cuda)", name));
}

FieldMethod parse_field(const std::string& name) {
  for (FieldMethod f : {FieldMethod::distance, FieldMethod::metaball, FieldMethod::sph, FieldMethod::zhu_bridson,
                        FieldMethod::anisotropic})
    if (name == to_string(f)) return f;
  throw InvalidParameter(fmt::format(
      "field: unknown field method '{}' (expected distance, metaball, sph, zhu-bridson or anisotropic)", name));
}

namespace {
void require(bool ok, const char* name, double value, const char* expectation) {
  if (!ok) throw InvalidParameter(fmt::format("{} = {:g}: {}", name, value, expectation));
}
void length_param(const char* name, double value) {
  require(std::isfinite(value) && value >= 0, name, value, "must be a finite length ≥ 0 (0 = derive from the spacing)");
}
/// A box as xmin, ymin, zmin, xmax, ymax, zmax (or empty: none).
void check_box(const char* name, const std::vector<double>& box) {
  if (box.empty()) return;
  if (box.size() != 6)
    throw InvalidParameter(
        fmt::format("{}: {} numbers given, expected 6 (xmin, ymin, zmin, xmax, ymax, zmax)", name, box.size()));
  for (std::size_t c = 0; c < 3; ++c)
    if (!std::isfinite(box[c]) || !std::isfinite(box[c + 3]) || !(box[c] < box[c + 3]))
      throw InvalidParameter(fmt::format("{0}: {1}min must be below {1}max, both finite; found {2} and {3}", name,
                                         "xyz"[c], box[c], box[c + 3]));
}
}  // namespace

void Params::validate() const {
  length_param("spacing", spacing);
  length_param("voxel_size", voxel_size);
  require(std::isfinite(detail) && detail > 0 && detail <= 8, "detail", detail,
          "must be in (0, 8] (1 = default resolution, 2 = half the voxel size)");
  length_param("r_outer", r_outer);
  require(std::isfinite(r_outer_factor) && r_outer_factor > 0 && r_outer_factor <= 4, "r_outer_factor", r_outer_factor,
          "must be in (0, 4] (r_outer in particle spacings)");
  length_param("r_inner", r_inner);
  length_param("erode", erode);
  length_param("transfer_radius", transfer_radius);
  if (r_inner > 0 && r_outer > 0)
    require(r_inner < r_outer, "r_inner", r_inner, fmt::format("must be smaller than r_outer ({:g})", r_outer).c_str());
  if (voxel_size > 0 && r_outer > 0)
    require(voxel_size <= 2 * r_outer, "voxel_size", voxel_size,
            fmt::format("must be at most 2·r_outer ({:g}); the surface would not be resolved", 2 * r_outer).c_str());
  require(steps_a >= 0, "steps_a", steps_a, "must be ≥ 0");
  check_box("particle_box", particle_box);
  require(min_particles >= 0, "min_particles", min_particles, "must be ≥ 0 (0 keeps every component)");
  check_box("clip_box", clip_box);
  if (clip_cap && clip_box.empty())
    throw InvalidParameter("clip_cap: there is no clip_box to cap (give clip_box, or drop clip_cap)");
  require(std::isfinite(decimate) && decimate >= 0 && decimate <= 1, "decimate", decimate,
          "must be in [0, 1] spacings (0 = no simplification; 0.02 is typical)");
  require(steps_b >= 0, "steps_b", steps_b, "must be ≥ 0");
  require(steps_free >= 0, "steps_free", steps_free, "must be ≥ 0");
  require(std::isfinite(relax) && relax >= 0 && relax <= 1, "relax", relax,
          "must be in (0, 1] (Jacobi sweeps diverge when over-relaxed; 0 = derive)");
  require(std::isfinite(relax_b) && relax_b > 0 && relax_b <= 1, "relax_b", relax_b, "must be in (0, 1]");
  require(std::isfinite(iso) && iso >= 0, "iso", iso, "must be finite and ≥ 0 (0 = derive)");
  require(iso == 0 || field != FieldMethod::distance, "iso", iso,
          "applies to --field metaball, sph, zhu-bridson and anisotropic; the distance field's level is r_outer");
  length_param("kernel_radius", kernel_radius);
  require(std::isfinite(rest_density) && rest_density >= 0, "rest_density", rest_density,
          "must be finite and ≥ 0 (0 = the median of the frame's densities)");
  require(std::isfinite(smooth_particles) && (smooth_particles == -1 || (smooth_particles >= 0 && smooth_particles <= 1)),
          "smooth_particles", smooth_particles, "must be in [0, 1] (−1 = derive)");
  require(std::isfinite(velocity_reference) && velocity_reference >= 0, "velocity_reference", velocity_reference,
          "must be ≥ 0 (0 = the 95th percentile of the particle speeds)");
  require(std::isfinite(velocity_min_weight) && velocity_min_weight > 0 && velocity_min_weight <= 1,
          "velocity_min_weight", velocity_min_weight, "must be in (0, 1]");
  require(rebuild_b >= 0, "rebuild_b", rebuild_b, "must be ≥ 0");
  require(threads >= 0, "threads", threads, "must be ≥ 0 (0 = all cores)");
  require(std::isfinite(max_memory_gb) && max_memory_gb >= 0, "max_memory_gb", max_memory_gb, "must be ≥ 0");
}

}  // namespace meniscus
