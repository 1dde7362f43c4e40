// meniscus — the parallel primitives of the CUDA backend (cub: radix sort, prefix sum), behind
// plain functions so only primitives.cu instantiates cub (compile time).
#pragma once

#include <cstddef>
#include <cstdint>

#include "cuda/cuda_check.hpp"

namespace meniscus::cuda {

/// Stable sort of (key, value) pairs by key bits [begin_bit, end_bit), in place.
void sort_pairs(DeviceBuffer<uint64_t>& keys, DeviceBuffer<uint32_t>& values, std::size_t n, int begin_bit = 0,
                int end_bit = 64);
void sort_pairs(DeviceBuffer<uint32_t>& keys, DeviceBuffer<uint32_t>& values, std::size_t n, int begin_bit = 0,
                int end_bit = 32);
/// Sort of keys, in place.
void sort_keys(DeviceBuffer<uint64_t>& keys, std::size_t n);
/// out[i] = Σ_{k<i} in[k] for i ≤ n (out has n + 1 elements; out[n] is the total).
void exclusive_sum(const uint64_t* in, uint64_t* out, std::size_t n);
void exclusive_sum(const uint32_t* in, uint32_t* out, std::size_t n);
/// Distinct values of sorted keys[0, n) to the front of keys; returns their count.
std::size_t unique_sorted(DeviceBuffer<uint64_t>& keys, std::size_t n);

}  // namespace meniscus::cuda
