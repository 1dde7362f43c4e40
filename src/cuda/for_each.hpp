// meniscus — the parallel loop of the CUDA backend: for_each_index(Device{}, n, f) runs f(i) for
// every i in [0, n) as one kernel (a grid-stride loop), on the emulated device on the CPU. f is a
// MENISCUS_HD callable taken by value (it travels to the device as a kernel argument): a struct of
// device pointers and scalars. The CPU's loop is common/for_each.hpp.
#pragma once

#include <cstddef>
#include <cstdint>

#include "cuda/cuda_check.hpp"
#include "cuda/device.hpp"

namespace meniscus::cuda {

template <class F>
__global__ void for_each_kernel(uint64_t n, F f) {
  MENISCUS_GRID_STRIDE(i, n) { f(i); }
}

/// Queues f(i) for every i in [0, n) on the device (asynchronous; checked at launch).
template <class F>
void for_each_index(Device, std::size_t n, F f, unsigned threads = 256) {
  if (n == 0) return;
  MENISCUS_LAUNCH(for_each_kernel<F>, blocks_for(n, threads), threads)(uint64_t(n), f);
  MENISCUS_CUDA_CHECK_LAUNCH();
}

}  // namespace meniscus::cuda
