// meniscus — parallel LSD radix sort (Satish, Harris & Garland 2009 describe the same count / scan
// / scatter passes for GPUs; cub::DeviceRadixSort is the CUDA counterpart). Linear in the keys and
// streaming, it sorts the edge weld's 64-bit keys several times faster than a comparison sort;
// the spatial reordering sorts the triangles themselves by their smallest corner.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "common/for_each.hpp"
#include "common/huge_pages.hpp"

namespace meniscus {

/// Sorts `items` stably by the bits [first_bit, end_bit) of key(item) (a uint64_t; 0 ≤ first_bit <
/// end_bit ≤ 64), 11 bits per pass; a pass whose digit is the same in every item is skipped. Bits
/// from end_bit up are ignored. Parallel (oneTBB), deterministic; allocates one scratch copy of
/// `items` (and no keys: key() is called again at every pass).
template <class T, class Key>
void radix_sort_by(std::vector<T>& items, Key&& key, int first_bit, int end_bit) {
  constexpr int kDigitBits = 11;
  constexpr std::size_t kBuckets = std::size_t(1) << kDigitBits;
  // Fixed-size chunks (not one per thread): the scatter order, hence the result, never depends on
  // the thread count, and each chunk's histogram row stays in cache.
  constexpr std::size_t kChunk = std::size_t(1) << 17;
  const std::size_t n = items.size();
  if (n < 2) return;
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<T> scratch;
  std::vector<std::array<std::size_t, kBuckets>> offsets(chunks);

  for (int shift = first_bit; shift < end_bit; shift += kDigitBits) {
    // The last pass may be narrower, so that bits from end_bit up never take part.
    const uint64_t mask = (end_bit - shift >= kDigitBits) ? kBuckets - 1 : (uint64_t(1) << (end_bit - shift)) - 1;
    auto digit = [&key, shift, mask](const T& item) { return std::size_t((uint64_t(key(item)) >> shift) & mask); };
    for_each_index(chunks, [&](std::size_t c) {
      std::array<std::size_t, kBuckets>& count = offsets[c];
      count.fill(0);
      for (std::size_t i = c * kChunk, end = std::min(n, i + kChunk); i < end; ++i) ++count[digit(items[i])];
    });
    // Exclusive scan in (digit, chunk) order: chunk c's items with digit d go after all smaller
    // digits and after the earlier chunks' items with digit d — the stable order.
    std::size_t total = 0;
    bool one_digit = false;
    for (std::size_t d = 0; d < kBuckets; ++d) {
      std::size_t digit_total = 0;
      for (std::size_t c = 0; c < chunks; ++c) {
        const std::size_t count = offsets[c][d];
        offsets[c][d] = total;
        total += count;
        digit_total += count;
      }
      one_digit |= digit_total == n;
    }
    if (one_digit) continue;  // this digit is the same everywhere: the pass would copy in order
    if (scratch.size() != n) resize_populated(scratch, n);
    for_each_index(chunks, [&](std::size_t c) {
      std::array<std::size_t, kBuckets>& next = offsets[c];
      for (std::size_t i = c * kChunk, end = std::min(n, i + kChunk); i < end; ++i)
        scratch[next[digit(items[i])]++] = items[i];
    });
    items.swap(scratch);
  }
}

/// Sorts `keys` stably by their bits [first_bit, end_bit): the bits below first_bit are a payload
/// carried along (stable: equal sort bits keep the input order).
inline void radix_sort(std::vector<uint64_t>& keys, int first_bit, int end_bit) {
  radix_sort_by(keys, [](uint64_t k) { return k; }, first_bit, end_bit);
}

}  // namespace meniscus
