// meniscus — the parallel primitives of the CUDA backend: the device versions of the calls of
// common/primitives.hpp (same names, same contracts, the Device tag first), so that a stage
// written once over the backend tag runs on either. Sorts, scans and selects are cub's, behind
// plain functions so only primitives.cu instantiates them (compile time); reduce_index is a
// template (its functor is the caller's). On the emulated device they are the CPU's.
#pragma once

#include <cstddef>
#include <cstdint>

#include "cuda/cuda_check.hpp"
#include "cuda/for_each.hpp"

#if defined(MENISCUS_CUDA_EMULATION)
#include "common/primitives.hpp"
#else
#include <thrust/iterator/counting_iterator.h>

#include <cub/device/device_reduce.cuh>
#endif

namespace meniscus::cuda {

/// Sorts the n pairs (keys[i], values[i]) stably by the key bits [begin_bit, end_bit), in place.
void sort_pairs(Device, uint64_t* keys, uint32_t* values, std::size_t n, int begin_bit = 0, int end_bit = 64);
void sort_pairs(Device, uint32_t* keys, uint32_t* values, std::size_t n, int begin_bit = 0, int end_bit = 32);
/// Sorts the n keys in place.
void sort_keys(Device, uint64_t* keys, std::size_t n);
/// out[i] = Σ_{k<i} in[k] for i ≤ n (out has n + 1 elements; out[n] is the total).
void exclusive_sum(Device, const uint64_t* in, uint64_t* out, std::size_t n);
void exclusive_sum(Device, const uint32_t* in, uint32_t* out, std::size_t n);
/// Moves the distinct values of the sorted keys[0, n) to the front; returns their count.
std::size_t unique_sorted(Device, uint64_t* keys, std::size_t n);

/// combine(… combine(identity, f(0)) …, f(n − 1)) for an associative, exact combine (min, max,
/// counts), to the host: f and combine are MENISCUS_HD callables.
template <class T, class F, class Combine>
T reduce_index(Device, std::size_t n, T identity, F f, Combine combine) {
#if defined(MENISCUS_CUDA_EMULATION)
  if (n == 0) return identity;
  DeviceBuffer<T> out(1);  // read back as on a device (a download and a wait)
  *out.data() = ::meniscus::reduce_index(Host{}, n, identity, f, combine);
  return out.get(0);
#else
  if (n == 0) return identity;
  DeviceBuffer<T> out(1);
  std::size_t temp_bytes = 0;
  const thrust::counting_iterator<uint64_t> first(0);
  MENISCUS_CUDA_CHECK(cub::DeviceReduce::TransformReduce(nullptr, temp_bytes, first, out.data(), n, combine, f, identity));
  DeviceBuffer<unsigned char> temp(temp_bytes);
  MENISCUS_CUDA_CHECK(
      cub::DeviceReduce::TransformReduce(temp.data(), temp_bytes, first, out.data(), n, combine, f, identity));
  return out.get(0);
#endif
}

}  // namespace meniscus::cuda
