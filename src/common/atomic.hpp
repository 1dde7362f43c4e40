// meniscus — atomics for code written once for both backends (MENISCUS_HD): CUDA's atomic
// functions and cuda::atomic_ref in device code, std::atomic_ref on the CPU (and on the emulated device, whose kernels
// are CPU code). Relaxed order: they count, take minima and claim slots; what is read after a
// pass is read after the pass's end (a kernel's end, or the CPU loop's join). Code that uses them
// must give a result independent of the threads' order (counts, min/max, a set of claimed flags),
// or say where it does not.
#pragma once

#include <atomic>
#include <cstdint>

#if defined(__CUDACC__) && !defined(MENISCUS_CUDA_EMULATION)
#include <cuda/atomic>
#endif

#include "meniscus/vec.hpp"

namespace meniscus {

#if defined(__CUDA_ARCH__)
template <class T>
__device__ inline T atomic_add(T* p, T v) { return atomicAdd(p, v); }
template <class T>
__device__ inline T atomic_min(T* p, T v) { return atomicMin(p, v); }
template <class T>
__device__ inline T atomic_max(T* p, T v) { return atomicMax(p, v); }
template <class T>
__device__ inline T atomic_exchange(T* p, T v) { return atomicExch(p, v); }
template <class T>
__device__ inline T load_relaxed(const T* p) {
  return ::cuda::atomic_ref<T, ::cuda::thread_scope_device>(*const_cast<T*>(p)).load(::cuda::memory_order_relaxed);
}
template <class T>
__device__ inline void store_relaxed(T* p, T v) {
  ::cuda::atomic_ref<T, ::cuda::thread_scope_device>(*p).store(v, ::cuda::memory_order_relaxed);
}
#else
/// *p += v; returns the old value.
template <class T>
inline T atomic_add(T* p, T v) { return std::atomic_ref<T>(*p).fetch_add(v, std::memory_order_relaxed); }
/// *p = min(*p, v); returns the old value.
template <class T>
inline T atomic_min(T* p, T v) {
  std::atomic_ref<T> a(*p);
  T old = a.load(std::memory_order_relaxed);
  while (v < old && !a.compare_exchange_weak(old, v, std::memory_order_relaxed)) {}
  return old;
}
/// *p = max(*p, v); returns the old value.
template <class T>
inline T atomic_max(T* p, T v) {
  std::atomic_ref<T> a(*p);
  T old = a.load(std::memory_order_relaxed);
  while (old < v && !a.compare_exchange_weak(old, v, std::memory_order_relaxed)) {}
  return old;
}
/// *p = v; returns the old value.
template <class T>
inline T atomic_exchange(T* p, T v) { return std::atomic_ref<T>(*p).exchange(v, std::memory_order_relaxed); }
/// *p, where other threads write *p meanwhile (a union-find's parent): no data race in the C++
/// sense, at no cost on a GPU (ld.relaxed).
template <class T>
inline T load_relaxed(const T* p) { return std::atomic_ref<T>(*const_cast<T*>(p)).load(std::memory_order_relaxed); }
/// *p = v, where other threads read or write *p meanwhile (a flag many threads set; st.relaxed).
template <class T>
inline void store_relaxed(T* p, T v) { std::atomic_ref<T>(*p).store(v, std::memory_order_relaxed); }
#endif

}  // namespace meniscus
