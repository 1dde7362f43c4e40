// meniscus — parallel LSD radix sort (count, exclusive scan, stable scatter per 11-bit digit).
#include "extract/radix_sort.hpp"
#include "common/huge_pages.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>

namespace meniscus {

void radix_sort(std::vector<uint64_t>& keys, int first_bit, int end_bit) {
  constexpr int kDigitBits = 11;
  constexpr std::size_t kBuckets = std::size_t(1) << kDigitBits;
  // Fixed-size chunks (not one per thread): the scatter order, hence the result, never depends on
  // the thread count, and each chunk's histogram row stays in cache.
  constexpr std::size_t kChunk = std::size_t(1) << 17;
  const std::size_t n = keys.size();
  if (n < 2) return;
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<uint64_t> scratch;
  resize_populated(scratch, n);
  std::vector<std::array<std::size_t, kBuckets>> offsets(chunks);

  for (int shift = first_bit; shift < end_bit; shift += kDigitBits) {
    // The last pass may be narrower, so that bits from end_bit up never take part.
    const uint64_t mask = (end_bit - shift >= kDigitBits) ? kBuckets - 1 : (uint64_t(1) << (end_bit - shift)) - 1;
    auto digit = [shift, mask](uint64_t k) { return std::size_t((k >> shift) & mask); };
    tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
      std::array<std::size_t, kBuckets>& count = offsets[c];
      count.fill(0);
      for (std::size_t i = c * kChunk, end = std::min(n, i + kChunk); i < end; ++i) ++count[digit(keys[i])];
    });
    // Exclusive scan in (digit, chunk) order: chunk c's keys with digit d go after all smaller
    // digits and after the earlier chunks' keys with digit d — the stable order.
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
    tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
      std::array<std::size_t, kBuckets>& next = offsets[c];
      for (std::size_t i = c * kChunk, end = std::min(n, i + kChunk); i < end; ++i)
        scratch[next[digit(keys[i])]++] = keys[i];
    });
    keys.swap(scratch);
  }
}

}  // namespace meniscus
