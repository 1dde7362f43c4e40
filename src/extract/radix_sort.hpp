// meniscus — parallel LSD radix sort of 64-bit keys (Satish, Harris & Garland 2009 describe the
// same count / scan / scatter passes for GPUs; cub::DeviceRadixSort is the CUDA counterpart). Used
// by the edge weld, whose keys sort 3–8× faster this way than with a comparison sort.
#pragma once

#include <cstdint>
#include <vector>

namespace meniscus {

/// Sorts `keys` stably by their bits [first_bit, end_bit) (0 ≤ first_bit < end_bit ≤ 64), 11 bits
/// per pass; a pass whose digit is the same in every key is skipped. Bits below first_bit are a
/// payload carried along (stable: equal sort bits keep the input order); bits from end_bit up must
/// be zero or are ignored. Parallel (oneTBB), deterministic; allocates one scratch copy of `keys`.
void radix_sort(std::vector<uint64_t>& keys, int first_bit, int end_bit);

}  // namespace meniscus
