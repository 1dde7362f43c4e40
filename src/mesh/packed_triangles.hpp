// meniscus — a triangle list packed into variable-length integers while it is not needed (the
// smoothing sweeps never read the triangles once the operator's corner lists are built).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "common/for_each.hpp"
#include "common/huge_pages.hpp"
#include "meniscus/mesh.hpp"

namespace meniscus {

/// The triangles of a mesh in blocks of kBlock, each triangle as three zigzag LEB128 integers: its
/// first corner less the previous triangle's first corner (0 before a block's first), and its
/// other two corners less its first. On a mesh numbered in space (reorder_vertices_spatially)
/// the differences are small: a few bytes a triangle instead of 12.
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

  /// The triangles with keep(triangle), in order, each mapped through map(triangle) — decoded in
  /// parallel, block by block (twice: to count, then to write), without unpacking the rest. Only
  /// the blocks b with search(b) are decoded: the caller vouches that no other block has a
  /// triangle to keep.
  template <class Keep, class Map, class Search>
  std::vector<Triangle> select(Keep&& keep, Map&& map, Search&& search) const;
  template <class Keep, class Map>
  std::vector<Triangle> select(Keep&& keep, Map&& map) const {
    return select(keep, map, [](std::size_t) { return true; });
  }

  /// The blocks of kBlock triangles (the last one shorter), and their triangles in order.
  std::size_t block_count() const { return block_begin_.empty() ? 0 : block_begin_.size() - 1; }
  /// Calls f(triangle) for the triangles of block b, in order.
  template <class F>
  void decode_block(std::size_t b, F&& f) const {
    const uint8_t* in = bytes_.data() + block_begin_[b];
    uint32_t previous = 0;
    const auto [first, last] = block_range(b);
    for (std::size_t k = first; k < last; ++k) {
      uint64_t z0, z1, z2;
      in = get_varint(get_varint(get_varint(in, z0), z1), z2);
      const uint32_t v0 = uint32_t(int64_t(previous) + unzigzag(z0));
      f(Triangle{v0, uint32_t(int64_t(v0) + unzigzag(z1)), uint32_t(int64_t(v0) + unzigzag(z2))});
      previous = v0;
    }
  }

 private:
  static int64_t unzigzag(uint64_t z) { return int64_t(z >> 1) ^ -int64_t(z & 1); }
  static const uint8_t* get_varint(const uint8_t* in, uint64_t& z) {
    z = 0;
    for (int shift = 0;; shift += 7) {
      const uint8_t b = *in++;
      z |= uint64_t(b & 0x7f) << shift;
      if (!(b & 0x80)) return in;
    }
  }
  /// The triangles [first, last) of block b.
  std::pair<std::size_t, std::size_t> block_range(std::size_t b) const {
    return {b * kBlock, std::min(count_, (b + 1) * kBlock)};
  }

  bool packed_ = false;
  std::size_t count_ = 0;
  UninitVector<uint8_t> bytes_;
  std::vector<std::size_t> block_begin_;  ///< byte offset of each block, and the total at the end
};

template <class Keep, class Map, class Search>
std::vector<Triangle> PackedTriangles::select(Keep&& keep, Map&& map, Search&& search) const {
  const std::size_t blocks = block_count();
  std::vector<std::size_t> start(blocks + 1, 0);
  for_each_index(blocks, [&](std::size_t b) {
    std::size_t n = 0;
    if (search(b)) decode_block(b, [&](const Triangle& t) { n += keep(t) ? 1 : 0; });
    start[b + 1] = n;
  });
  for (std::size_t b = 0; b < blocks; ++b) start[b + 1] += start[b];
  std::vector<Triangle> out;
  resize_huge(out, start[blocks]);
  for_each_index(blocks, [&](std::size_t b) {
    if (start[b + 1] == start[b]) return;
    std::size_t k = start[b];
    decode_block(b, [&](const Triangle& t) {
      if (keep(t)) out[k++] = map(t);
    });
  });
  return out;
}

}  // namespace meniscus
