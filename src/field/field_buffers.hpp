// meniscus — the sparse field as arrays of either backend (BufferOf<B, T>): sorted block keys and
// kBlockSamples values a block, with FieldView, its lookup over plain pointers. The CPU's own
// SparseField (sparse_field.hpp) holds the same blocks with its KeyIndex.
#pragma once

#include <cstddef>
#include <cstdint>

#include "common/buffer.hpp"
#include "field/sparse_field.hpp"
#include "grid/grid_buffers.hpp"

namespace meniscus {

/// The lattice's sample offsets (in cells), passed to the kernels by value: no per-process device
/// state, so concurrent reconstructions on different lattices stay apart.
struct SampleOffsets {
  float o[8][3] = {};
  SampleOffsets() = default;
  explicit SampleOffsets(const SampleLattice& lattice) {
    for (int s = 0; s < lattice.samples_per_cell(); ++s)
      for (int a = 0; a < 3; ++a) o[s][a] = lattice.sample_offset(s)[a];
  }
};

/// The sparse field over plain pointers.
struct FieldView {
  const uint64_t* keys = nullptr;
  const float* values = nullptr;
  uint32_t blocks = 0;
  int n = 8, spc = 1;  ///< cells per block edge, samples per cell
  float background = 0;

  MENISCUS_HD float value(Vec3i cell, int s) const {
    auto div = [this](int32_t v) { return v >= 0 ? v / n : -((-v + n - 1) / n); };
    const Vec3i b{div(cell.x), div(cell.y), div(cell.z)};
    const uint32_t i = find_sorted(keys, blocks, pack_coords(b.x, b.y, b.z));
    if (i == kNotFound) return background;
    const Vec3i l{cell.x - b.x * n, cell.y - b.y * n, cell.z - b.z * n};
    return values[std::size_t(i) * kBlockSamples + std::size_t(((l.z * n + l.y) * n + l.x) * spc + s)];
  }
};

/// The field's arrays on backend B.
template <class B>
struct FieldBuffers {
  SampleLattice lattice;
  BufferOf<B, uint64_t> keys;
  BufferOf<B, float> values;
  uint32_t blocks = 0;
  float background = 0;
  FieldView view() const {
    return {keys.data(), values.data(), blocks, lattice.block_cells(), lattice.samples_per_cell(), background};
  }
};

}  // namespace meniscus
