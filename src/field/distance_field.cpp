// meniscus — sparse distance field (Williams 2008; Edespong 2010 §3.2).
#include "field/distance_field.hpp"
#include "common/for_each.hpp"
#include "common/primitives.hpp"
#include "field/distance_field_impl.hpp"


#include <algorithm>
#include <atomic>
#include <array>
#include <cmath>
#include <limits>
#include <span>

namespace meniscus {

namespace {

/// The blocks [lo, hi] (inclusive, per axis) that the box of hash cell `cell` (edge `cell_size`),
/// widened by `band`, touches.
struct BlockBox {
  int32_t lo[3], hi[3];
};
BlockBox band_block_box(Vec3i cell, float cell_size, float band, float block_size) {
  BlockBox box;
  for (int a = 0; a < 3; ++a) band_block_range(cell[a], cell_size, band, block_size, &box.lo[a], &box.hi[a]);
  return box;
}

/// band_blocks over a byte per block of the blocks' box, where that box is small (a frame's
/// fluid fills much of its box): each hash cell marks its blocks, then one scan in (z, y, x)
/// order lists the marked ones — already sorted, no key list of every cell's blocks to sort and
/// deduplicate. Returns false, doing nothing, where
/// the box is too large for the map (particles in far-apart clusters).
bool band_blocks_dense(const HashGrid& grid, float band, float block_size, std::vector<uint64_t>& keys) {
  const auto cells = grid.cell_keys();
  const float c = grid.cell_size();
  if (cells.empty()) return false;
  // band_block_range rises with the cell, so the grid's cell box gives the blocks' box.
  const BlockBox first = band_block_box(grid.cell_min(), c, band, block_size);
  const BlockBox last = band_block_box(grid.cell_max(), c, band, block_size);
  const int32_t* lo = first.lo;
  const std::size_t nx = std::size_t(last.hi[0] - lo[0]) + 1, ny = std::size_t(last.hi[1] - lo[1]) + 1,
                    nz = std::size_t(last.hi[2] - lo[2]) + 1;
  // A byte a box block, at most 64 per hash cell (the sorted key list takes 8 bytes for each of
  // a cell's blocks, 8 to 27 of them).
  if (double(nx) * double(ny) * double(nz) > 64.0 * double(cells.size())) return false;
  std::vector<uint8_t> marked(nx * ny * nz, 0);
  for_each_index(cells.size(), 1024, [&](std::size_t i) {
    const BlockBox b = band_block_box(unpack_coords(cells[i]), c, band, block_size);
    for (int32_t z = b.lo[2]; z <= b.hi[2]; ++z)
      for (int32_t y = b.lo[1]; y <= b.hi[1]; ++y) {
        uint8_t* row = marked.data() + (std::size_t(z - lo[2]) * ny + std::size_t(y - lo[1])) * nx;
        // Neighbouring cells mark the same blocks from both threads: relaxed atomic stores of
        // the same value (a plain store on x86), not a data race.
        for (int32_t x = b.lo[0]; x <= b.hi[0]; ++x)
          std::atomic_ref<uint8_t>(row[x - lo[0]]).store(1, std::memory_order_relaxed);
      }
  });
  // Count per z-slab, then list each slab's marked blocks in (y, x) order at its offset.
  std::vector<std::size_t> offset(nz + 1, 0);
  const std::size_t slab = nx * ny;
  for_each_index(nz, [&](std::size_t z) {
    std::size_t count = 0;
    for (std::size_t i = z * slab; i < (z + 1) * slab; ++i) count += marked[i];
    offset[z + 1] = count;
  });
  for (std::size_t z = 0; z < nz; ++z) offset[z + 1] += offset[z];
  keys.resize(offset[nz]);
  for_each_index(nz, [&](std::size_t z) {
    std::size_t k = offset[z];
    for (std::size_t y = 0; y < ny; ++y)
      for (std::size_t x = 0; x < nx; ++x)
        if (marked[(z * ny + y) * nx + x])
          keys[k++] = pack_coords(lo[0] + int32_t(x), lo[1] + int32_t(y), lo[2] + int32_t(z));
  });
  return true;
}

}  // namespace

std::vector<uint64_t> band_blocks(const HashGrid& grid, const SampleLattice& lattice, float band) {
  const auto cells = grid.cell_keys();
  const float block_size = lattice.cell_size * float(lattice.block_cells());
  const float c = grid.cell_size();
  if (std::vector<uint64_t> dense; band_blocks_dense(grid, band, block_size, dense)) return dense;
  PerThread<std::vector<uint64_t>> local;
  for_each_chunk(cells.size(), 256, [&](std::size_t begin, std::size_t end) {
    auto& out = local.local();
    for (std::size_t i = begin; i != end; ++i) {
      const BlockBox b = band_block_box(unpack_coords(cells[i]), c, band, block_size);
      for (int32_t z = b.lo[2]; z <= b.hi[2]; ++z)
        for (int32_t y = b.lo[1]; y <= b.hi[1]; ++y)
          for (int32_t x = b.lo[0]; x <= b.hi[0]; ++x) out.push_back(pack_coords(x, y, z));
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
  });
  std::vector<uint64_t> keys;
  for (auto& v : local) keys.insert(keys.end(), v.begin(), v.end());
  sort(Host{}, keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  return keys;
}

namespace {

/// The distinct sample offsets of a lattice on each axis (A15: 0, 1/4, 1/2, 3/4 of a cell; cubic:
/// 0) and which of them each sub-lattice uses: a particle's ranges and squared deltas depend on
/// the axis offset only, so they are computed once per distinct offset instead of once per
/// sub-lattice (8 on the A15 lattice, 4 distinct values per axis).
struct AxisOffsets {
  int count[3] = {0, 0, 0};
  float value[3][8] = {};
  int of_sample[8][3] = {};
  explicit AxisOffsets(const SampleLattice& lattice) {
    for (int s = 0; s < lattice.samples_per_cell(); ++s) {
      const Vec3f off = lattice.sample_offset(s);
      for (int ax = 0; ax < 3; ++ax) {
        int k = 0;
        while (k < count[ax] && value[ax][k] != off[ax]) ++k;
        if (k == count[ax]) value[ax][count[ax]++] = off[ax];
        of_sample[s][ax] = k;
      }
    }
  }
};

/// row[x] = min(row[x], dx2[x] + dyz) over a row of N samples: kept apart, with restrict, so the
/// compiler emits one vector add and min per four samples.
template <int N>
inline void min_row(float* __restrict row, const float* __restrict dx2, float dyz) {
  for (int x = 0; x < N; ++x) row[x] = std::min(row[x], dx2[x] + dyz);
}

/// The scatter of one block, rows of N samples (N = the block's cells per edge) kept as
/// contiguous vectors: scratch layout [s][z][y][x], so the innermost update is one short vector
/// min (a row of the A15 block is exactly four floats). A particle reaches the samples of its
/// band box (the same test as the CUDA gather, so both backends get the same samples). Rows of
/// the box whose (y, z) part already exceeds the band are updated too: the scratch starts at
/// band², so they change nothing, and a test per row cost more than it saved.
template <int N>
void scatter_block(const HashGrid& grid, const SampleLattice& lattice, const AxisOffsets& offsets, float band,
                   std::span<const Vec3f> points, Vec3i origin, float* d2) {
  const int spc = lattice.samples_per_cell();
  const float a = lattice.cell_size;
  const float inv_a = 1.0f / a;
  const float band2 = band * band;
  constexpr float kInf = std::numeric_limits<float>::infinity();
  const Vec3f box_lo = Vec3f{float(origin.x), float(origin.y), float(origin.z)} * a;
  const Vec3f box_hi = box_lo + Vec3f{1, 1, 1} * (a * float(N));
  // Per axis and distinct offset: the clipped cell range of the particle's band box and the
  // squared deltas of its cells (x: +inf outside the range, so the row min leaves those samples).
  struct Axis {
    int32_t lo, hi;
    alignas(16) float d2[N];
  };
  Axis axes[3][8];
  grid.for_each_in_cells_of_box(box_lo - Vec3f{band, band, band}, box_hi + Vec3f{band, band, band}, [&](uint32_t pi) {
    const Vec3f p = points[pi];
    // Every sample of the block lies in [box_lo, box_hi]: a particle whose band sphere misses
    // that box touches none of them (most of the particles of the hash cells around a block), so
    // skip it before the per-offset ranges. The margin keeps the test conservative under rounding.
    float gap2 = 0;
    for (int ax = 0; ax < 3; ++ax) {
      const float g = std::max({box_lo[ax] - p[ax], p[ax] - box_hi[ax], 0.0f});
      gap2 += g * g;
    }
    if (gap2 > band2 * (1.0f + 1e-4f)) return;
    for (int ax = 0; ax < 3; ++ax)
      for (int k = 0; k < offsets.count[ax]; ++k) {
        Axis& e = axes[ax][k];
        const float off = offsets.value[ax][k];
        particle_cell_range(p[ax], band, inv_a, off, &e.lo, &e.hi);
        e.lo = std::max(e.lo, origin[ax]) - origin[ax];
        e.hi = std::min(e.hi, origin[ax] + N - 1) - origin[ax];
        for (int x = 0; x < N; ++x) {
          const float d = sample_delta(origin[ax] + x, off, a, p[ax]);
          e.d2[x] = ax == 0 && (x < e.lo || x > e.hi) ? kInf : d * d;
        }
      }
    for (int s = 0; s < spc; ++s) {
      const Axis& ex = axes[0][offsets.of_sample[s][0]];
      const Axis& ey = axes[1][offsets.of_sample[s][1]];
      const Axis& ez = axes[2][offsets.of_sample[s][2]];
      if (ex.lo > ex.hi || ey.lo > ey.hi || ez.lo > ez.hi) continue;
      float* plane = d2 + std::size_t(s) * N * N * N;
      // Rows whose (y, z) part alone exceeds band² change nothing (the scratch starts at band²).
      for (int32_t z = ez.lo; z <= ez.hi; ++z)
        for (int32_t y = ey.lo; y <= ey.hi; ++y)  // sample_dist2's order: dx² added onto the (y, z) part
          min_row<N>(plane + (z * N + y) * N, ex.d2, ey.d2[y] + ez.d2[z]);
    }
  });
}

}  // namespace

SparseField distance_field(const HashGrid& grid, const SampleLattice& lattice, float band,
                           std::vector<uint64_t> block_keys) {
  SparseField field(lattice, std::move(block_keys), band, SparseField::Unwritten{});  // every sample written below
  const int n = lattice.block_cells();
  const int spc = lattice.samples_per_cell();
  const float band2 = band * band;
  const auto points = grid.sorted_points();
  const AxisOffsets offsets(lattice);

  for_each_chunk(field.block_count(), 4, [&](std::size_t begin, std::size_t end) {
    alignas(64) std::array<float, kBlockSamples> d2;
    for (std::size_t b = begin; b != end; ++b) {
      d2.fill(band2);
      const Vec3i origin = field.block_origin(b);
      if (n == 4)
        scatter_block<4>(grid, lattice, offsets, band, points, origin, d2.data());
      else
        scatter_block<8>(grid, lattice, offsets, band, points, origin, d2.data());
      // Transpose [s][z][y][x] into the field's cell-major layout, clamped to the band.
      auto values = field.block_values(b);
      const int cells = n * n * n;
      for (int s = 0; s < spc; ++s)
        for (int c = 0; c < cells; ++c)
          values[std::size_t(c * spc + s)] = std::sqrt(std::min(d2[std::size_t(s * cells + c)], band2));
    }
  });
  return field;
}

}  // namespace meniscus
