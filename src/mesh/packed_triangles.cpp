// meniscus — triangle lists packed into variable-length integers.
#include "mesh/packed_triangles.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <numeric>

namespace meniscus {

namespace {

uint64_t zigzag(int64_t v) { return (uint64_t(v) << 1) ^ uint64_t(v >> 63); }
int64_t unzigzag(uint64_t z) { return int64_t(z >> 1) ^ -int64_t(z & 1); }

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

const uint8_t* get_varint(const uint8_t* in, uint64_t& z) {
  z = 0;
  for (int shift = 0;; shift += 7) {
    const uint8_t b = *in++;
    z |= uint64_t(b & 0x7f) << shift;
    if (!(b & 0x80)) return in;
  }
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
  tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t b) {
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
  tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t b) {
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
  const std::size_t blocks = block_begin_.empty() ? 0 : block_begin_.size() - 1;
  tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t b) {
    const uint8_t* in = bytes_.data() + block_begin_[b];
    uint32_t previous = 0;
    const auto [first, last] = block_range(b);
    for (std::size_t k = first; k < last; ++k) {
      uint64_t z0, z1, z2;
      in = get_varint(get_varint(get_varint(in, z0), z1), z2);
      const uint32_t v0 = uint32_t(int64_t(previous) + unzigzag(z0));
      triangles[k] = {v0, uint32_t(int64_t(v0) + unzigzag(z1)), uint32_t(int64_t(v0) + unzigzag(z2))};
      previous = v0;
    }
  });
  UninitVector<uint8_t>().swap(bytes_);
  block_begin_.clear();
  count_ = 0;
  packed_ = false;
}

}  // namespace meniscus
