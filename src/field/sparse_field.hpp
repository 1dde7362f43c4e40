// meniscus — block-sparse scalar field over a sample lattice (Museth 2013, "VDB", for the idea
// of allocating only blocks near the surface). Blocks hold 512 samples: 8³ cells of a cubic
// lattice (one sample per cell) or 4³ cells of the A15 lattice (8 samples per cell).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "common/huge_pages.hpp"
#include "grid/key_index.hpp"
#include "meniscus/vec.hpp"

namespace meniscus {

/// Where a lattice sample lies: (cell + offset) · cell_size, the world origin at 0 (both backends:
/// SampleLattice::sample_position, and the device with the offsets passed by value).
MENISCUS_HD inline Vec3f lattice_point(Vec3i cell, Vec3f offset, float cell_size) {
  return Vec3f{float(cell.x) + offset.x, float(cell.y) + offset.y, float(cell.z) + offset.z} * cell_size;
}

/// Sample positions: sample s of cell c is at (c + offset(s)) · cell_size (world origin at 0).
struct SampleLattice {
  enum class Kind { cubic, a15 };
  Kind kind = Kind::cubic;
  float cell_size = 1;  ///< cubic: the voxel size h; a15: the tile period a = 2h

  int samples_per_cell() const { return kind == Kind::cubic ? 1 : 8; }
  int block_cells() const { return 1 << block_shift(); }           ///< cells per block edge
  int block_shift() const { return kind == Kind::cubic ? 3 : 2; }  ///< log2 of block_cells()
  Vec3f sample_offset(int s) const;                                 ///< in units of cell_size
  Vec3f sample_position(Vec3i cell, int s) const { return lattice_point(cell, sample_offset(s), cell_size); }
};

/// The A15 sub-cell sample offsets (marching-tiles.md), in units of the cell size.
inline constexpr Vec3f kA15Samples[8] = {{0, 0, 0},     {0.5f, 0.5f, 0.5f}, {0.25f, 0.5f, 0},  {0.75f, 0.5f, 0},
                                         {0, 0.25f, 0.5f}, {0, 0.75f, 0.5f},  {0.5f, 0, 0.25f}, {0.5f, 0, 0.75f}};

inline Vec3f SampleLattice::sample_offset(int s) const {
  return kind == Kind::cubic ? Vec3f{0, 0, 0} : kA15Samples[s];
}

inline constexpr int kBlockSamples = 512;

/// A scalar field stored in 512-sample blocks. Block b covers cells
/// [key_coords(b) · block_cells, key_coords(b) · block_cells + block_cells) on each axis; its
/// samples are at values()[b·512 + local_index(cell - block origin, s)]. Samples in blocks that
/// are not allocated read as `background()`.
class SparseField {
 public:
  SparseField() = default;
  /// Allocates the blocks with the given (sorted, unique) block coordinate keys (pack_coords),
  /// every sample set to `background`.
  SparseField(SampleLattice lattice, std::vector<uint64_t> block_keys, float background);
  struct Unwritten {};
  /// The same, leaving the samples unwritten, for a builder that writes every one of them (in
  /// parallel, so that each thread faults in its own pages): a fill before it, all overwritten,
  /// would cost one thread a pass over hundreds of MB on a large frame.
  SparseField(SampleLattice lattice, std::vector<uint64_t> block_keys, float background, Unwritten);

  const SampleLattice& lattice() const { return lattice_; }
  float background() const { return background_; }
  std::size_t block_count() const { return block_keys_.size(); }
  std::span<const uint64_t> block_keys() const { return block_keys_; }
  Vec3i block_coords(std::size_t b) const { return unpack_coords(block_keys_[b]); }
  /// First cell of block b.
  Vec3i block_origin(std::size_t b) const {
    const Vec3i c = block_coords(b);
    const int n = lattice_.block_cells();
    return {c.x * n, c.y * n, c.z * n};
  }
  std::span<float> block_values(std::size_t b) { return {values_.data() + b * kBlockSamples, kBlockSamples}; }
  std::span<const float> block_values(std::size_t b) const {
    return {values_.data() + b * kBlockSamples, kBlockSamples};
  }
  /// Index of a sample inside its block: cell-major, samples of one cell adjacent.
  int local_index(Vec3i local_cell, int s) const {
    const int n = lattice_.block_cells();
    return ((local_cell.z * n + local_cell.y) * n + local_cell.x) * lattice_.samples_per_cell() + s;
  }
  /// Block index of the block with these block coordinates, or kNotFound.
  uint32_t find_block(Vec3i block) const { return index_.find(block); }
  /// Block coordinates of the block that holds `cell`.
  Vec3i block_of(Vec3i cell) const {
    // Floor division by the block edge (4 or 8 cells, a power of two): an arithmetic shift, which
    // C++20 defines on negative values as rounding down — no integer division on this hot path.
    const int shift = lattice_.block_shift();
    return {cell.x >> shift, cell.y >> shift, cell.z >> shift};
  }
  /// The field value at sample s of `cell` (background when its block is not allocated).
  float value(Vec3i cell, int s) const {
    const Vec3i b = block_of(cell);
    return value_in(find_block(b), b, cell, s);
  }
  /// value() once the block is known: `index` = find_block(block), block = block_of(cell).
  float value_in(uint32_t index, Vec3i block, Vec3i cell, int s) const { return *address_in(index, block, cell, s); }
  /// Where value_in reads (the background's own storage when the block is not allocated).
  const float* address_in(uint32_t index, Vec3i block, Vec3i cell, int s) const {
    if (index == kNotFound) return &background_;
    const int n = lattice_.block_cells();
    return values_.data() + std::size_t(index) * kBlockSamples +
           local_index({cell.x - block.x * n, cell.y - block.y * n, cell.z - block.z * n}, s);
  }

  std::size_t memory_bytes() const { return values_.size() * 4 + block_keys_.size() * 8 + index_.memory_bytes(); }

 private:
  SampleLattice lattice_;
  std::vector<uint64_t> block_keys_;
  UninitVector<float> values_;
  CellIndex index_;  ///< dense over the blocks' box where that is no larger than a hash
  float background_ = 0;
};

}  // namespace meniscus
