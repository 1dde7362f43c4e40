// meniscus — kernel-sum fields (Blinn 1982; Müller et al. 2003; Zhu & Bridson 2005; Yu & Turk 2010).
#include "field/kernel_field.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include "common/for_each.hpp"

namespace meniscus {

float kernel_support(const KernelFieldInput& in) {
  float axis = 0, shell_axis = 0;
  if (in.method == FieldMethod::anisotropic) {
    for (const Ellipsoid& e : in.ellipsoids) axis = std::max(axis, e.max_axis);
    for (const Ellipsoid& e : in.shells) shell_axis = std::max(shell_axis, e.max_axis);
  }
  return kernel_field_support(in.method, in.kernel_radius, axis,
                              in.shells.empty() ? 0.0f : shell_reach(in.shell_radius, shell_axis));
}

namespace {

/// Calls f(sample index in block, sample position) for every sample of the block the particle at
/// p reaches with `radius` (sample_in_reach's box, clipped to the block).
template <class F>
void for_samples_near(const SampleLattice& lattice, Vec3i origin, Vec3f p, float radius, F&& f) {
  const int n = lattice.block_cells(), spc = lattice.samples_per_cell();
  const float a = lattice.cell_size, inv_a = 1.0f / a;
  for (int s = 0; s < spc; ++s) {
    const Vec3f o = lattice.sample_offset(s);
    const float off[3] = {o.x, o.y, o.z};
    int32_t lo[3], hi[3];
    bool empty = false;
    for (int ax = 0; ax < 3; ++ax) {
      particle_cell_range(p[ax], radius, inv_a, off[ax], &lo[ax], &hi[ax]);
      lo[ax] = std::max(lo[ax], origin[ax]) - origin[ax];
      hi[ax] = std::min(hi[ax], origin[ax] + n - 1) - origin[ax];
      empty |= lo[ax] > hi[ax];
    }
    if (empty) continue;
    for (int32_t z = lo[2]; z <= hi[2]; ++z)
      for (int32_t y = lo[1]; y <= hi[1]; ++y)
        for (int32_t x = lo[0]; x <= hi[0]; ++x)
          f(std::size_t(((z * n + y) * n + x) * spc + s), kernel_sample_point({origin.x + x, origin.y + y, origin.z + z}, off, a));
  }
}

/// Calls f(sorted index) for every particle of the hash cells that touch the block's box grown
/// by `support`.
template <class F>
void for_particles_near_block(const HashGrid& grid, const SampleLattice& lattice, Vec3i origin, float support, F&& f) {
  const float a = lattice.cell_size;
  const Vec3f box_lo = Vec3f{float(origin.x), float(origin.y), float(origin.z)} * a;
  const Vec3f box_hi = box_lo + Vec3f{1, 1, 1} * (a * float(lattice.block_cells()));
  grid.for_each_in_cells_of_box(box_lo - Vec3f{support, support, support}, box_hi + Vec3f{support, support, support},
                                std::forward<F>(f));
}

}  // namespace

KernelParticles kernel_particles(const KernelFieldInput& in) {
  KernelParticles k;
  k.method = in.method;
  k.radius = in.kernel_radius;
  k.volumes = in.volumes.empty() ? nullptr : in.volumes.data();
  k.uniform_volume = in.uniform_volume;
  k.ellipsoids = in.ellipsoids.empty() ? nullptr : in.ellipsoids.data();
  k.shells = in.shells.empty() ? nullptr : in.shells.data();
  k.shell_radius = in.shell_radius;
  return k;
}

float kernel_background(const KernelFieldInput& in) {
  return kernel_field_background(in.method, in.kernel_radius, in.iso);
}

SparseField kernel_field(const KernelFieldInput& in, const SampleLattice& lattice, std::vector<uint64_t> block_keys) {
  const float background = kernel_background(in);
  SparseField field(lattice, std::move(block_keys), background, SparseField::Unwritten{});  // all written below
  const HashGrid& grid = *in.centres;
  const auto points = grid.sorted_points();
  const float support = kernel_support(in);
  const KernelParticles k = kernel_particles(in);

  // Each block scatters its particles into its samples' sums (kernel_impl.hpp has the per-sample
  // arithmetic, which the CUDA backend gathers).
  for_each_chunk(field.block_count(), 2, [&](std::size_t begin, std::size_t end) {
    std::array<KernelSum, kBlockSamples> sums;
    for (std::size_t b = begin; b != end; ++b) {
      sums.fill(KernelSum{});
      const Vec3i origin = field.block_origin(b);
      for_particles_near_block(grid, lattice, origin, support, [&](uint32_t i) {
        const Vec3f p = points[i];
        for_samples_near(lattice, origin, p, kernel_reach(k, i),
                         [&](std::size_t s, Vec3f q) { kernel_add(k, i, p, q, sums[s]); });
      });
      auto values = field.block_values(b);
      const int n = lattice.block_cells(), spc = lattice.samples_per_cell();
      for (int s = 0; s < spc; ++s) {
        const Vec3f o = lattice.sample_offset(s);
        const float off[3] = {o.x, o.y, o.z};
        for (int z = 0; z < n; ++z)
          for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x) {
              const std::size_t j = std::size_t(((z * n + y) * n + x) * spc + s);
              const Vec3f q = kernel_sample_point({origin.x + x, origin.y + y, origin.z + z}, off, lattice.cell_size);
              values[j] = kernel_value(k, sums[j], q, in.iso, background);
            }
      }
    }
  });
  return field;
}

}  // namespace meniscus
