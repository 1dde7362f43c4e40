// meniscus — sparse distance field (Williams 2008; Edespong 2010 §3.2).
#include "field/distance_field.hpp"
#include "field/distance_field_impl.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <cmath>

namespace meniscus {

std::vector<uint64_t> band_blocks(const HashGrid& grid, const SampleLattice& lattice, float band) {
  const auto cells = grid.cell_keys();
  const float block_size = lattice.cell_size * float(lattice.block_cells());
  const float c = grid.cell_size();
  tbb::enumerable_thread_specific<std::vector<uint64_t>> local;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cells.size(), 256), [&](const auto& r) {
    auto& out = local.local();
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      const Vec3i cell = unpack_coords(cells[i]);
      // The hash cell's box expanded by the band, in block coordinates.
      int32_t lo[3], hi[3];
      for (int a = 0; a < 3; ++a) band_block_range(cell[a], c, band, block_size, &lo[a], &hi[a]);
      for (int32_t z = lo[2]; z <= hi[2]; ++z)
        for (int32_t y = lo[1]; y <= hi[1]; ++y)
          for (int32_t x = lo[0]; x <= hi[0]; ++x) out.push_back(pack_coords(x, y, z));
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
  });
  std::vector<uint64_t> keys;
  for (auto& v : local) keys.insert(keys.end(), v.begin(), v.end());
  tbb::parallel_sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  return keys;
}

SparseField distance_field(const HashGrid& grid, const SampleLattice& lattice, float band,
                           std::vector<uint64_t> block_keys) {
  SparseField field(lattice, std::move(block_keys), band);
  const int n = lattice.block_cells();
  const int spc = lattice.samples_per_cell();
  const float a = lattice.cell_size;
  const float inv_a = 1.0f / a;
  const float band2 = band * band;
  const auto points = grid.sorted_points();

  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, field.block_count(), 4), [&](const auto& r) {
    std::array<float, kBlockSamples> d2;
    for (std::size_t b = r.begin(); b != r.end(); ++b) {
      d2.fill(band2);
      const Vec3i origin = field.block_origin(b);
      const Vec3f box_lo = Vec3f{float(origin.x), float(origin.y), float(origin.z)} * a;
      const Vec3f box_hi = box_lo + Vec3f{1, 1, 1} * (a * float(n));
      const Vec3i clo = grid.cell_of(box_lo - Vec3f{band, band, band});
      const Vec3i chi = grid.cell_of(box_hi + Vec3f{band, band, band});
      for (int32_t cz = clo.z; cz <= chi.z; ++cz)
        for (int32_t cy = clo.y; cy <= chi.y; ++cy)
          for (int32_t cx = clo.x; cx <= chi.x; ++cx) {
            const auto [pb, pe] = grid.cell_range({cx, cy, cz});
            for (uint32_t pi = pb; pi < pe; ++pi) {
              const Vec3f p = points[pi];
              // Every sample of the block lies in [box_lo, box_hi]: a particle whose band sphere
              // misses that box touches none of them (most of the particles of the hash cells
              // around a block), so skip it before the per-offset ranges. The margin keeps the
              // test conservative under rounding.
              float gap2 = 0;
              for (int ax = 0; ax < 3; ++ax) {
                const float g = std::max({box_lo[ax] - p[ax], p[ax] - box_hi[ax], 0.0f});
                gap2 += g * g;
              }
              if (gap2 > band2 * (1.0f + 1e-4f)) continue;
              for (int s = 0; s < spc; ++s) {
                const Vec3f off = lattice.sample_offset(s);
                // Cells whose sample s lies within the band of p, clipped to this block.
                int32_t lo[3], hi[3];
                bool empty = false;
                for (int ax = 0; ax < 3; ++ax) {
                  particle_cell_range(p[ax], band, inv_a, off[ax], &lo[ax], &hi[ax]);
                  lo[ax] = std::max(lo[ax], origin[ax]) - origin[ax];
                  hi[ax] = std::min(hi[ax], origin[ax] + n - 1) - origin[ax];
                  empty |= lo[ax] > hi[ax];
                }
                if (empty) continue;
                for (int32_t z = lo[2]; z <= hi[2]; ++z) {
                  const float dz = sample_delta(origin.z + z, off.z, a, p.z);
                  for (int32_t y = lo[1]; y <= hi[1]; ++y) {
                    const float dy = sample_delta(origin.y + y, off.y, a, p.y);
                    const float dyz = dy * dy + dz * dz;
                    if (dyz > band2 * (1.0f + 1e-5f)) continue;
                    // Only the row's samples inside the band sphere (half the box's volume). The
                    // range is widened by a rounding allowance: a sample it adds reads ≥ band², which
                    // the final clamp discards, so the field is the same as over the whole box.
                    const float half = std::sqrt(std::max(band2 - dyz, 0.0f)) * (1.0f + 1e-5f) + 1e-6f * a;
                    const int32_t x0 = std::max(ceil_to_int((p.x - half) * inv_a - off.x) - origin.x, lo[0]);
                    const int32_t x1 = std::min(floor_to_int((p.x + half) * inv_a - off.x) - origin.x, hi[0]);
                    for (int32_t x = x0; x <= x1; ++x) {
                      const float dx = sample_delta(origin.x + x, off.x, a, p.x);
                      float& slot = d2[std::size_t(((z * n + y) * n + x) * spc + s)];
                      slot = std::min(slot, sample_dist2(dx, dy, dz));
                    }
                  }
                }
              }
            }
          }
      auto values = field.block_values(b);
      for (int i = 0; i < kBlockSamples; ++i) values[std::size_t(i)] = std::sqrt(std::min(d2[std::size_t(i)], band2));
    }
  });
  return field;
}

}  // namespace meniscus
