// meniscus — the per-particle kernels of the field methods (docs/fields.md), shared by the CPU and
// CUDA backends: Blinn 1982 (metaballs, with a polynomial kernel), Müller, Charypar &
// Gross 2003 (SPH, poly6), Zhu & Bridson 2005, Yu & Turk 2010 (anisotropic kernels).
#pragma once

#include <algorithm>
#include <cmath>

#include "field/distance_field_impl.hpp"
#include "field/eigen_sym3_impl.hpp"
#include "grid/hash_grid_impl.hpp"
#include "meniscus/params.hpp"
#include "meniscus/vec.hpp"

namespace meniscus {

/// Blinn's metaball kernel in its polynomial form, W = (r/√2R)⁴ − (r/√2R)² + 0.25 for r < R:
/// 0.25 at the centre, 0 (with zero slope) at r = R.
MENISCUS_HD inline float metaball_kernel(float r2, float R) {
  if (r2 >= R * R) return 0.0f;
  const float s = r2 / (2.0f * R * R);
  return (s - 0.5f) * (s - 0.5f);
}
/// Σ W over a cubic lattice of spacing d filling space, (1/d³)∫W dV = π R³/d³ · (1/3 − 2/5 + 1/7).
inline double metaball_bulk_value(double R, double d) { return 3.14159265358979323846 * (R * R * R) / (d * d * d) * (8.0 / 105.0); }

/// The unit-integral poly6 kernel of Müller et al. 2003 with support R: 315/(64π R³)·(1 − r²/R²)³.
MENISCUS_HD inline float poly6_kernel(float r2, float R) {
  if (r2 >= R * R) return 0.0f;
  const float t = 1.0f - r2 / (R * R);
  return 1.5666814f / (R * R * R) * t * t * t;  // 315 / (64π)
}

/// Zhu & Bridson's weight k(r/R) = (1 − (r/R)²)³ (also the attribute-transfer weight).
MENISCUS_HD inline float zhu_bridson_weight(float r2, float R) {
  if (r2 >= R * R) return 0.0f;
  const float t = 1.0f - r2 / (R * R);
  return t * t * t;
}

/// Yu & Turk's neighbourhood weight w = 1 − (r/R)³ for r < R.
MENISCUS_HD inline float yu_turk_weight(float r, float R) {
  if (r >= R) return 0.0f;
  const float t = r / R;
  return 1.0f - t * t * t;
}

/// Yu & Turk 2010 §4 constants. Their k_s = 1400 scales covariances in the units of their scenes;
/// here the covariance is divided by `bulk_variance` (the per-axis weighted variance of a
/// uniformly filled neighbourhood, 0.15 (2h)² for the weight above) so a particle inside a
/// uniform fluid gets the unit (isotropic) kernel whatever the units. `k_max` bounds the longest
/// axis (not in the paper) so the kernel support — and the constraint search — stays bounded.
struct AnisotropyConstants {
  float k_r = 4.0f;    ///< largest / smallest axis at most k_r
  float k_n = 0.5f;    ///< axes of a particle with too few neighbours (isotropic, relative to bulk)
  int n_eps = 25;      ///< fewer neighbours than this: isotropic k_n kernel
  float k_max = 2.0f;  ///< longest axis at most k_max (relative to bulk)
  float bulk_variance = 1.0f;
};

/// The per-axis weighted variance of a ball of radius Rn filled uniformly, weights 1 − (r/Rn)³:
/// ∫w r² dV / (3∫w dV) = 0.15 Rn².
inline float yu_turk_bulk_variance(float Rn) { return 0.15f * Rn * Rn; }

/// How far (in its constraint shell's metric, as a share of r_inner) the centre smoothing may take
/// an anisotropic kernel centre from its particle (centre_holding_particle). The smoothing holds
/// the surface outside every inner shell, which keeps a particle inside only if it lies inside
/// its own; a surface particle's shell is thin along the normal (0.2–0.3 d at r_inner) and λ = 0.3
/// pulls its centre up to 0.27 d inwards, which can leave a particle farther from its centre than
/// r_inner, outside its shell, just outside the surface. 0.75 leaves a quarter of the shell,
/// 0.03–0.06 d along the normal, between a particle and the wall the surface rests on, more than
/// the surface's triangles stray from it (a full shell, 1.0, still let a particle out on some
/// bundled frames; 0.75 lets none out on any).
inline constexpr float kCentreInShell = 0.75f;

/// Yu & Turk's pass over the raw particles (centre smoothing, ellipsoids) for resolved parameters
/// `p`, as both backends run it: PCA over 2R (their 2h), centre smoothing over 2d, and a grid of
/// the raw particles with cells large enough for either search.
struct ParticlePass {
  bool run = false;  ///< centre smoothing or anisotropic kernels asked for
  bool anisotropic = false;
  float lambda = 0;  ///< centre smoothing λ (0: the centres are the particles)
  float pca_radius = 0, smooth_radius = 0, raw_cell = 0;
  /// Anisotropic: each centre within this distance of its particle in its shell's metric
  /// (kCentreInShell · r_inner, centre_holding_particle); 0: no bound.
  float centre_reach = 0;
  AnisotropyConstants constants;
};

inline ParticlePass particle_pass(const Params& p) {
  ParticlePass s;
  s.anisotropic = p.field == FieldMethod::anisotropic;
  s.lambda = float(p.smooth_particles);
  s.run = p.smooth_particles > 0 || s.anisotropic;
  s.pca_radius = float(2 * p.kernel_radius);
  s.smooth_radius = float(2 * p.spacing);
  s.raw_cell = float(std::max(2 * p.spacing, s.anisotropic ? double(s.pca_radius) : 0.0));
  s.constants.bulk_variance = yu_turk_bulk_variance(s.pca_radius);
  s.centre_reach = s.anisotropic ? float(kCentreInShell * p.r_inner) : 0.0f;
  return s;
}

/// A particle's ellipsoid: the dimensionless metric A = R diag(1/σ̃) Rᵀ (so |A(x − c)| is the
/// distance "in the particle's ellipsoid metric": the identity in a uniform fluid), its
/// determinant and the longest axis σ̃₁. Yu & Turk's kernel matrix is G = A / h.
struct Ellipsoid {
  SymMat3 metric;
  float det = 1;       ///< det A = 1/(σ̃₁σ̃₂σ̃₃)
  float max_axis = 1;  ///< σ̃₁
  float min_axis = 1;  ///< σ̃₃ (1/min_axis = ‖A‖₂, the Lipschitz constant of the metric distance)
};

/// Yu & Turk's clamped ellipsoid from a weighted covariance `cov` of `neighbours` particles.
MENISCUS_HD inline Ellipsoid yu_turk_ellipsoid(const float (&cov)[3][3], int neighbours, const AnisotropyConstants& k) {
  Ellipsoid e;
  if (neighbours < k.n_eps) {
    const float a = 1.0f / k.k_n;
    e.metric = SymMat3{a, 0, 0, a, 0, a};
    e.det = a * a * a;
    e.max_axis = k.k_n;
    e.min_axis = k.k_n;
    return e;
  }
  const Eigen3<float> eig = eigen_sym3(cov);
  float s[3];
  const float s1 = fminf(fmaxf(eig.values[0] / k.bulk_variance, 1e-6f), k.k_max);
  s[0] = s1;
  for (int i = 1; i < 3; ++i) s[i] = fminf(fmaxf(eig.values[i] / k.bulk_variance, s1 / k.k_r), s1);
  SymMat3 m;
  for (int i = 0; i < 3; ++i) {
    const float inv = 1.0f / s[i];
    const float* v = eig.vectors[i];
    m.xx += inv * v[0] * v[0], m.xy += inv * v[0] * v[1], m.xz += inv * v[0] * v[2];
    m.yy += inv * v[1] * v[1], m.yz += inv * v[1] * v[2], m.zz += inv * v[2] * v[2];
  }
  e.metric = m;
  e.det = 1.0f / (s[0] * s[1] * s[2]);
  e.max_axis = s1;
  e.min_axis = fminf(s[1], s[2]);
  return e;
}

/// The cube root of x > 0, with the same bits on the host and the device: cbrtf is not correctly
/// rounded, and glibc's and CUDA's differ in the last bit, which the smoothing's 60 sweeps grow
/// into visible differences. Newton's iterations in double from an exponent-only guess (within a
/// factor 2): only correctly rounded operations, so both backends compute the same value (the
/// correctly rounded cube root: checked against cbrtl on 2 million floats from 1e-40 to 1e40).
MENISCUS_HD inline float cube_root(float x) {
  if (!(x > 0.0f) || !(x <= 3.4028235e38f)) return x;  // 0, negatives, inf, NaN: not reached from a kernel
  const double v = x;
  int e = 0;
  double m = v;  // v = m · 2^e, m in [1, 2)
  while (m >= 2.0) m *= 0.5, ++e;
  while (m < 1.0) m *= 2.0, --e;
  const int q = e >= 0 ? e / 3 : -((-e + 2) / 3);  // floor(e / 3)
  double y = 1.0;
  for (int i = 0; i < (q >= 0 ? q : -q); ++i) y = q >= 0 ? y * 2.0 : y * 0.5;
  y *= 1.3;  // cbrt(m · 2^(e − 3q)) lies in [1, 2^(5/3)) ≈ [1, 3.17)
  for (int i = 0; i < 8; ++i) y -= (y * y * y - v) / (3.0 * y * y);
  return float(y);
}

/// The ellipsoid of the smoothing's constraint shells for a kernel ellipsoid: the same shape and
/// orientation scaled to unit volume (det A = 1), so the shells of every particle hold the volume
/// of Williams' spheres. The kernel's own scale is a density device — Yu & Turk shrink a particle
/// with few neighbours to k_n = 0.5 of the bulk — and shells that small would pull the surface
/// inside the sparse particles they should enclose (docs/fields.md, "Keeping every particle
/// inside").
MENISCUS_HD inline Ellipsoid unit_volume_shell(const Ellipsoid& e) {
  const float k = cube_root(e.det);  // det A = 1/(σ̃₁σ̃₂σ̃₃): A/k has determinant 1
  Ellipsoid s;
  s.metric = SymMat3{e.metric.xx / k, e.metric.xy / k, e.metric.xz / k, e.metric.yy / k, e.metric.yz / k, e.metric.zz / k};
  s.det = 1;
  s.max_axis = e.max_axis * k;
  s.min_axis = e.min_axis * k;
  return s;
}

/// Yu & Turk's kernel W(r, G) = σ det(G) P(|G r|), G = A/h, P the poly6 profile with unit support:
/// the poly6 kernel of support h, stretched into the ellipsoid (unit integral for any A).
MENISCUS_HD inline float anisotropic_kernel(const Ellipsoid& e, Vec3f r, float h) {
  const Vec3f g = e.metric * r;
  const float s2 = length2(g) / (h * h);
  if (s2 >= 1.0f) return 0.0f;
  const float t = 1.0f - s2;
  return 1.5666814f * e.det / (h * h * h) * t * t * t;
}

// --- the kernel-sum field, per sample (kernel_field.cpp scatters, the CUDA backend gathers) ---------

/// The kernel centres' data a kernel field reads, per sorted particle (host or device pointers).
struct KernelParticles {
  FieldMethod method = FieldMethod::metaball;
  float radius = 0;                      ///< support R (anisotropic: the bulk support h)
  const float* volumes = nullptr;        ///< m/ρ (sph, anisotropic); null: uniform_volume
  float uniform_volume = 1;
  const Ellipsoid* ellipsoids = nullptr; ///< anisotropic only
  /// Anisotropic only: the constraint shells (unit_volume_shell), whose outer shells
  /// |S_i(x − x̄_i)| < shell_radius the field's inside includes (kernel_value); null: none.
  const Ellipsoid* shells = nullptr;
  float shell_radius = 0;                ///< r_outer
};

/// A sample's running sums: Σ (volume ×) kernel, for zhu-bridson Σ k_i x_i, and with shells the
/// least squared shell distance |S_i(q − x̄_i)|² of the particles that reach the sample.
struct KernelSum {
  float sum = 0;
  Vec3f weighted{0, 0, 0};
  float shell2 = INFINITY;
};

/// The field's value where no kernel reaches (unallocated space): iso, or R − r̄ for zhu-bridson.
MENISCUS_HD inline float kernel_field_background(FieldMethod method, float radius, float iso) {
  return method == FieldMethod::zhu_bridson ? radius - iso : iso;
}

/// How far an outer shell of radius r and longest axis σ̃₁ reaches: r·σ̃₁, with an allowance for
/// the rounding of the shell distance (a sample the scatter skips must measure ≥ r).
MENISCUS_HD inline float shell_reach(float r, float max_axis) { return r * max_axis * 1.0001f; }

/// The kernels' support: R, or R·max σ̃₁ over the particles for anisotropic ones — or the outer
/// shells' reach `shells` (shell_reach of the largest shell axis; 0: no shells) where larger.
MENISCUS_HD inline float kernel_field_support(FieldMethod method, float radius, float max_axis, float shells = 0) {
  if (method != FieldMethod::anisotropic) return radius;
  const float kernels = radius * (max_axis < 1e-3f ? 1e-3f : max_axis);  // std::max(max_axis, 1e-3f)
  return shells > kernels ? shells : kernels;
}

/// How far particle i reaches: R, or R·σ̃₁ for an anisotropic kernel (or its outer shell's reach,
/// where larger).
MENISCUS_HD inline float kernel_reach(const KernelParticles& k, uint32_t i) {
  if (k.method != FieldMethod::anisotropic) return k.radius;
  const float kernel = k.radius * k.ellipsoids[i].max_axis;
  if (k.shells == nullptr) return kernel;
  const float shell = shell_reach(k.shell_radius, k.shells[i].max_axis);
  return shell > kernel ? shell : kernel;
}

/// Adds particle i (at p) to the sums of the sample at q.
MENISCUS_HD inline void kernel_add(const KernelParticles& k, uint32_t i, Vec3f p, Vec3f q, KernelSum& s) {
  const float v = k.volumes != nullptr ? k.volumes[i] : k.uniform_volume;
  switch (k.method) {
    case FieldMethod::metaball: s.sum += metaball_kernel(length2(q - p), k.radius); break;
    case FieldMethod::sph: s.sum += v * poly6_kernel(length2(q - p), k.radius); break;
    case FieldMethod::zhu_bridson: {
      const float w = zhu_bridson_weight(length2(q - p), k.radius);
      s.sum += w;
      s.weighted += p * w;
      break;
    }
    case FieldMethod::anisotropic: {
      s.sum += v * anisotropic_kernel(k.ellipsoids[i], q - p, k.radius);  // + 0 beyond the kernel's support
      if (k.shells != nullptr) {
        const float m2 = length2(k.shells[i].metric * (q - p));
        s.shell2 = m2 < s.shell2 ? m2 : s.shell2;  // a minimum: the same whatever the order
      }
      break;
    }
    case FieldMethod::distance: break;
  }
}

/// The field's value at the sample q from its sums (kernel_field.hpp): iso − Σ, or for zhu-bridson
/// min(|q − x̄| − r̄, background) with r̄ = iso (background where no particle reaches q). With
/// shells (anisotropic), a sample outside the kernels' level set but inside a particle's outer
/// shell takes the shell's value iso·(m/r_outer − 1) < 0 (m = the least shell distance), so the
/// inside is the union of the level set and the outer shells; elsewhere the value is the kernels'
/// (kernel_field.hpp says why).
MENISCUS_HD inline float kernel_value(const KernelParticles& k, const KernelSum& s, Vec3f q, float iso, float background) {
  if (k.method == FieldMethod::anisotropic && k.shells != nullptr) {
    const float kernels = iso - s.sum, r = k.shell_radius;
    if (kernels > 0.0f && s.shell2 < r * r) return iso * (std::sqrt(s.shell2) / r - 1.0f);
    return kernels;
  }
  if (k.method != FieldMethod::zhu_bridson) return iso - s.sum;
  if (!(s.sum > 0)) return background;
  const float d = length(q - s.weighted / s.sum) - iso;
  return d < background ? d : background;
}

/// The position of sample (cell, offset) on a lattice of spacing a, as the scatter computes it.
MENISCUS_HD inline Vec3f kernel_sample_point(Vec3i cell, const float (&off)[3], float a) {
  return Vec3f{(float(cell.x) + off[0]) * a, (float(cell.y) + off[1]) * a, (float(cell.z) + off[2]) * a};
}

/// The field at one sample by gathering: the particles of the hash cells touching the box of the
/// sample's block (cells [block_origin, block_origin + n)) grown by `support`, in the scatter's
/// order, each added where its scatter would reach the sample — the same terms in the same order,
/// so the same float sums as kernel_field()'s scatter.
template <class Grid>
MENISCUS_HD float kernel_field_sample(const Grid& g, const KernelParticles& k, float support, float iso,
                                      float background, Vec3i block_origin, int n, float a, Vec3i cell,
                                      const float (&off)[3]) {
  const Vec3f box_lo = Vec3f{float(block_origin.x), float(block_origin.y), float(block_origin.z)} * a;
  const Vec3f box_hi = box_lo + Vec3f{1, 1, 1} * (a * float(n));
  const float inv_a = 1.0f / a;
  const Vec3f q = kernel_sample_point(cell, off, a);
  KernelSum s;
  grid_for_each_in_cells_of_box(g, box_lo - Vec3f{support, support, support}, box_hi + Vec3f{support, support, support},
                                [&](uint32_t i) {
                                  const Vec3f p = g.point(i);
                                  if (sample_in_reach(p, kernel_reach(k, i), inv_a, off, cell)) kernel_add(k, i, p, q, s);
                                });
  return kernel_value(k, s, q, iso, background);
}

}  // namespace meniscus
