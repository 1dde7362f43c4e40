// meniscus — a triangle list packed into variable-length integers while it is not needed (the
// smoothing sweeps never read the triangles once the operator's corner lists are built).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "common/huge_pages.hpp"
#include "meniscus/mesh.hpp"

namespace meniscus {

/// The triangles of a mesh in blocks of kBlock, each triangle as three zigzag LEB128 integers: its
/// first corner less the previous triangle's first corner (0 before a block's first), and its
/// other two corners less its first. On a mesh numbered in space (reorder_vertices_spatially)
/// the differences are small: about 3.5 bytes a triangle on the splash scenes instead of 12.
/// Packed and unpacked in parallel, block by block.
class PackedTriangles {
 public:
  static constexpr std::size_t kBlock = 8192;

  /// Packs `triangles` and empties the vector, handing its storage back.
  void pack(std::vector<Triangle>& triangles);
  /// Unpacks into `triangles` (replacing what it holds) and frees the packed bytes.
  void unpack(std::vector<Triangle>& triangles);

  bool packed() const { return packed_; }
  std::size_t size() const { return count_; }
  std::size_t packed_bytes() const { return bytes_.size(); }

 private:
  /// The triangles [first, last) of block b.
  std::pair<std::size_t, std::size_t> block_range(std::size_t b) const {
    return {b * kBlock, std::min(count_, (b + 1) * kBlock)};
  }

  bool packed_ = false;
  std::size_t count_ = 0;
  UninitVector<uint8_t> bytes_;
  std::vector<std::size_t> block_begin_;  ///< byte offset of each block, and the total at the end
};

}  // namespace meniscus
