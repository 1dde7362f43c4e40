// meniscus — counting from per-element code shared by the backends: an atomic add on the device,
// std::atomic_ref on the CPU (and on the emulated device, whose kernels are host code).
#pragma once

#include <atomic>
#include <cstdint>

#include "meniscus/vec.hpp"

namespace meniscus {

MENISCUS_HD inline void count_one(unsigned long long* counter) {
#if defined(__CUDA_ARCH__)
  atomicAdd(counter, 1ull);
#else
  std::atomic_ref<unsigned long long>(*counter).fetch_add(1, std::memory_order_relaxed);
#endif
}

}  // namespace meniscus
