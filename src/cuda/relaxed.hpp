// meniscus — relaxed atomic loads and stores for the device code: the values kernels read while
// other threads write them (a union-find's parents) or that many threads set to the same value (a
// flag). Formal atomics, so the emulated device's runs have no data race in the C++ sense, at no
// cost on a GPU (ld.relaxed / st.relaxed). 32- and 64-bit values.
#pragma once

#if defined(MENISCUS_CUDA_EMULATION)
#include <atomic>
#else
#include <cuda/atomic>
#endif

namespace meniscus::cuda {

#if defined(MENISCUS_CUDA_EMULATION)
template <class T>
inline T load_relaxed(const T* p) {
  return std::atomic_ref<T>(*const_cast<T*>(p)).load(std::memory_order_relaxed);
}
template <class T>
inline void store_relaxed(T* p, T v) {
  std::atomic_ref<T>(*p).store(v, std::memory_order_relaxed);
}
#else
template <class T>
__device__ inline T load_relaxed(const T* p) {
  return ::cuda::atomic_ref<T, ::cuda::thread_scope_device>(*const_cast<T*>(p)).load(::cuda::memory_order_relaxed);
}
template <class T>
__device__ inline void store_relaxed(T* p, T v) {
  ::cuda::atomic_ref<T, ::cuda::thread_scope_device>(*p).store(v, ::cuda::memory_order_relaxed);
}
#endif

}  // namespace meniscus::cuda
