// meniscus — the kernel-sum field methods on the sparse block lattice (docs/fields.md): Blinn 1982
// metaballs, Müller, Charypar & Gross 2003 (SPH colour field), Zhu & Bridson 2005, Yu & Turk
// 2010 (anisotropic kernels). Each is stored in the form the extraction expects of the distance
// field — larger outside, the surface at the level 0 — so extract_surface(field, 0, …) works
// unchanged on any of them. The CPU's fast path of kernel_field of band_field.hpp (shared with
// the device, each sample gathering its particles): here each block scatters its particles;
// test_field_methods.cpp holds the two to the same bits.
#pragma once

#include <span>
#include <vector>

#include "field/kernel_impl.hpp"
#include "field/sparse_field.hpp"
#include "grid/hash_grid.hpp"
#include "meniscus/params.hpp"

namespace meniscus {

struct KernelFieldInput {
  const HashGrid* centres = nullptr;   ///< kernel centres (the field reads sorted_points())
  FieldMethod method = FieldMethod::metaball;  ///< metaball, sph, zhu_bridson or anisotropic
  float kernel_radius = 0;             ///< support R (anisotropic: the bulk support h)
  float iso = 0;                       ///< density threshold, or zhu-bridson's radius r̄
  /// Per sorted particle: the volume m/ρ (sph, anisotropic; empty: uniform d³).
  std::span<const float> volumes;
  float uniform_volume = 1;
  /// Per sorted particle: the ellipsoid (anisotropic only).
  std::span<const Ellipsoid> ellipsoids;
  /// Per sorted particle: the smoothing's constraint shell (anisotropic only; empty: none), and
  /// their outer radius r_outer: the field's inside includes every outer shell.
  std::span<const Ellipsoid> shells;
  float shell_radius = 0;
};

/// The support of the kernels: R, or R·max σ̃₁ for anisotropic ones (or the outer shells' reach,
/// r_outer·max σ̃₁ of the shells, where larger) — band_blocks(…, support) lists every block where
/// the field can differ from its background.
float kernel_support(const KernelFieldInput& in);
/// The field's value in unallocated space: iso, or R − r̄ for zhu-bridson.
float kernel_background(const KernelFieldInput& in);
/// The per-particle view kernel_impl.hpp reads (pointers into `in`).
KernelParticles kernel_particles(const KernelFieldInput& in);

/// The field over the blocks `block_keys`:
///   metaball:    iso − Σ W_blinn(x − x_i, R)
///   sph:         iso − Σ V_i W_poly6(x − x_i, R)
///   zhu-bridson: |x − x̄(x)| − r̄, x̄ = Σ k_i x_i / Σ k_i, k_i = (1 − |x − x_i|²/R²)³ (r̄ = iso,
///                every particle the same radius); R − r̄ where no particle is within R
///   anisotropic: iso − Σ V_i W(x − x_i, G_i)  (Yu & Turk, G_i = A_i / R); with shells, where
///                that is > 0 but x lies inside a particle's outer constraint shell,
///                m = min_i |S_i(x − x_i)| < r_outer, the shell's value iso·(m/r_outer − 1) instead.
///                The inside is then the kernels' level set united with the outer shells, which
///                is what Williams' constrained smoothing needs to keep every particle inside: a
///                surface that starts around every inner shell (the level set alone leaves out
///                sparse particles, cuts the thin inner shells of surface particles, and makes
///                one-particle sheets thinner than the lattice can sample, so they come out with
///                holes). Where the level set already holds a sample, its value is the kernels',
///                so the extracted surface follows the kernels wherever they enclose the shells.
/// Background (unallocated space): iso, or R − r̄ for zhu-bridson; > 0, i.e. outside. Parallel
/// over blocks, each block gathering the particles of the hash cells within the support.
SparseField kernel_field(const KernelFieldInput& in, const SampleLattice& lattice, std::vector<uint64_t> block_keys);

}  // namespace meniscus
