// meniscus — triangle lists packed into variable-length integers.
#include "mesh/packed_triangles.hpp"

#include <algorithm>
#include <numeric>

#include "common/for_each.hpp"

namespace meniscus {

namespace {

uint64_t zigzag(int64_t v) { return (uint64_t(v) << 1) ^ uint64_t(v >> 63); }

std::size_t varint_size(uint64_t z) {
  std::size_t n = 1;
  while (z >= 0x80) {
    z >>= 7;
    ++n;
  }
  return n;
}

uint8_t* put_varint(uint8_t* out, uint64_t z) {
  while (z >= 0x80) {
    *out++ = uint8_t(z | 0x80);
    z >>= 7;
  }
  *out++ = uint8_t(z);
  return out;
}

/// The three integers of triangle t after one whose first corner was `previous`.
template <class F>
void for_each_code(const Triangle& t, uint32_t previous, F&& f) {
  f(zigzag(int64_t(t[0]) - int64_t(previous)));
  f(zigzag(int64_t(t[1]) - int64_t(t[0])));
  f(zigzag(int64_t(t[2]) - int64_t(t[0])));
}

}  // namespace

void PackedTriangles::pack(std::vector<Triangle>& triangles) {
  count_ = triangles.size();
  const std::size_t blocks = (count_ + kBlock - 1) / kBlock;
  block_begin_.assign(blocks + 1, 0);
  for_each_index(blocks, [&](std::size_t b) {
    const auto [first, last] = block_range(b);
    std::size_t bytes = 0;
    uint32_t previous = 0;
    for (std::size_t k = first; k < last; ++k) {
      for_each_code(triangles[k], previous, [&](uint64_t z) { bytes += varint_size(z); });
      previous = triangles[k][0];
    }
    block_begin_[b + 1] = bytes;
  });
  std::inclusive_scan(block_begin_.begin(), block_begin_.end(), block_begin_.begin());
  bytes_.clear();
  resize_populated(bytes_, block_begin_.back());
  for_each_index(blocks, [&](std::size_t b) {
    const auto [first, last] = block_range(b);
    uint8_t* out = bytes_.data() + block_begin_[b];
    uint32_t previous = 0;
    for (std::size_t k = first; k < last; ++k) {
      for_each_code(triangles[k], previous, [&](uint64_t z) { out = put_varint(out, z); });
      previous = triangles[k][0];
    }
  });
  std::vector<Triangle>().swap(triangles);
  packed_ = true;
}

void PackedTriangles::unpack(std::vector<Triangle>& triangles) {
  triangles.clear();
  resize_populated(triangles, count_);
  for_each_index(block_count(), [&](std::size_t b) {
    std::size_t k = block_range(b).first;
    decode_block(b, [&](const Triangle& t) { triangles[k++] = t; });
  });
  UninitVector<uint8_t>().swap(bytes_);
  block_begin_.clear();
  count_ = 0;
  packed_ = false;
}

}  // namespace meniscus
