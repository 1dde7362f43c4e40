// meniscus — kernel-sum fields (Blinn 1982; Müller et al. 2003; Zhu & Bridson 2005; Yu & Turk 2010).
#include "field/kernel_field.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

namespace meniscus {

float kernel_support(const KernelFieldInput& in) {
  if (in.method != FieldMethod::anisotropic) return in.kernel_radius;
  float axis = 0;
  for (const Ellipsoid& e : in.ellipsoids) axis = std::max(axis, e.max_axis);
  return in.kernel_radius * std::max(axis, 1e-3f);
}

namespace {

/// Calls f(sample index in block, sample position) for every sample of the block within
/// `radius` of p (a box clip, as in distance_field).
template <class F>
void for_samples_near(const SampleLattice& lattice, Vec3i origin, Vec3f p, float radius, F&& f) {
  const int n = lattice.block_cells(), spc = lattice.samples_per_cell();
  const float a = lattice.cell_size, inv_a = 1.0f / a;
  for (int s = 0; s < spc; ++s) {
    const Vec3f off = lattice.sample_offset(s);
    int32_t lo[3], hi[3];
    bool empty = false;
    for (int ax = 0; ax < 3; ++ax) {
      lo[ax] = std::max(int32_t(std::ceil((p[ax] - radius) * inv_a - off[ax])), origin[ax]) - origin[ax];
      hi[ax] = std::min(int32_t(std::floor((p[ax] + radius) * inv_a - off[ax])), origin[ax] + n - 1) - origin[ax];
      empty |= lo[ax] > hi[ax];
    }
    if (empty) continue;
    for (int32_t z = lo[2]; z <= hi[2]; ++z)
      for (int32_t y = lo[1]; y <= hi[1]; ++y)
        for (int32_t x = lo[0]; x <= hi[0]; ++x) {
          const Vec3f q{(float(origin.x + x) + off.x) * a, (float(origin.y + y) + off.y) * a,
                        (float(origin.z + z) + off.z) * a};
          f(std::size_t(((z * n + y) * n + x) * spc + s), q);
        }
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

SparseField kernel_field(const KernelFieldInput& in, const SampleLattice& lattice, std::vector<uint64_t> block_keys) {
  const float R = in.kernel_radius, iso = in.iso;
  const bool zb = in.method == FieldMethod::zhu_bridson;
  const float background = zb ? R - iso : iso;
  SparseField field(lattice, std::move(block_keys), background);
  const HashGrid& grid = *in.centres;
  const auto points = grid.sorted_points();
  const float support = kernel_support(in);
  auto volume = [&](uint32_t i) { return in.volumes.empty() ? in.uniform_volume : in.volumes[i]; };

  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, field.block_count(), 2), [&](const auto& r) {
    std::array<float, kBlockSamples> sum;
    std::array<Vec3f, kBlockSamples> weighted;  // zhu-bridson: Σ k_i x_i
    for (std::size_t b = r.begin(); b != r.end(); ++b) {
      sum.fill(0.0f);
      if (zb) weighted.fill(Vec3f{0, 0, 0});
      const Vec3i origin = field.block_origin(b);
      for_particles_near_block(grid, lattice, origin, support, [&](uint32_t i) {
        const Vec3f p = points[i];
        switch (in.method) {
          case FieldMethod::metaball:
            for_samples_near(lattice, origin, p, R, [&](std::size_t k, Vec3f q) { sum[k] += metaball_kernel(length2(q - p), R); });
            break;
          case FieldMethod::sph: {
            const float v = volume(i);
            for_samples_near(lattice, origin, p, R, [&](std::size_t k, Vec3f q) { sum[k] += v * poly6_kernel(length2(q - p), R); });
            break;
          }
          case FieldMethod::zhu_bridson:
            for_samples_near(lattice, origin, p, R, [&](std::size_t k, Vec3f q) {
              const float w = zhu_bridson_weight(length2(q - p), R);
              sum[k] += w;
              weighted[k] += p * w;
            });
            break;
          case FieldMethod::anisotropic: {
            const float v = volume(i);
            const Ellipsoid& e = in.ellipsoids[i];
            for_samples_near(lattice, origin, p, R * e.max_axis,
                             [&](std::size_t k, Vec3f q) { sum[k] += v * anisotropic_kernel(e, q - p, R); });
            break;
          }
          case FieldMethod::distance: break;
        }
      });
      auto values = field.block_values(b);
      if (zb) {
        const int n = lattice.block_cells(), spc = lattice.samples_per_cell();
        for (int z = 0; z < n; ++z)
          for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x)
              for (int s = 0; s < spc; ++s) {
                const std::size_t k = std::size_t(((z * n + y) * n + x) * spc + s);
                if (!(sum[k] > 0)) {
                  values[k] = background;
                  continue;
                }
                const Vec3f q = lattice.sample_position({origin.x + x, origin.y + y, origin.z + z}, s);
                values[k] = std::min(length(q - weighted[k] / sum[k]) - iso, background);
              }
      } else {
        for (int k = 0; k < kBlockSamples; ++k) values[std::size_t(k)] = iso - sum[std::size_t(k)];
      }
    }
  });
  return field;
}

}  // namespace meniscus
