// meniscus — the emulated CUDA device (MENISCUS_CUDA_EMULATION, tests only; never installed):
// a stand-in for the part of the CUDA runtime the backend uses, so src/cuda/*.cu compile with the
// host compiler and every kernel runs on the CPU. A launch runs its blocks in parallel on oneTBB,
// each block as one thread (blockDim = 1): the backend's loops are grid- or block-stride, so they
// cover every item; __syncthreads has nothing to wait for; __shared__ arrays are the thread's own.
// Device memory is host memory (cudaMemcpy is memcpy), with an optional size limit to test the
// out-of-memory paths (MENISCUS_EMULATED_DEVICE_MEMORY, bytes).
#pragma once

#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <functional>
#include <tuple>
#include <utility>

// --- qualifiers and built-in variables ---------------------------------------------------------------
#define __global__
#define __device__
#define __host__
#define __constant__
#define __shared__ static thread_local
#define __forceinline__ inline

struct uint3 {
  unsigned x = 0, y = 0, z = 0;
};
struct dim3 {
  unsigned x = 1, y = 1, z = 1;
  constexpr dim3(unsigned x_ = 1, unsigned y_ = 1, unsigned z_ = 1) : x(x_), y(y_), z(z_) {}
};
inline thread_local uint3 blockIdx, threadIdx;
inline thread_local dim3 blockDim, gridDim;

inline void __syncthreads() {}
inline int __float_as_int(float f) {
  int i;
  std::memcpy(&i, &f, sizeof i);
  return i;
}
// A warp is one thread: its reductions are the thread's own value.
inline int __reduce_min_sync(unsigned, int v) { return v; }
inline int __reduce_max_sync(unsigned, int v) { return v; }

// --- atomics (std::atomic_ref: formal atomics, as the device's are) --------------------------------------
template <class T> T atomicAdd(T* p, T v) { return std::atomic_ref<T>(*p).fetch_add(v); }
template <class T> T atomicSub(T* p, T v) { return std::atomic_ref<T>(*p).fetch_sub(v); }
template <class T> T atomicExch(T* p, T v) { return std::atomic_ref<T>(*p).exchange(v); }
template <class T> T atomicMin(T* p, T v) {
  std::atomic_ref<T> a(*p);
  T old = a.load();
  while (v < old && !a.compare_exchange_weak(old, v)) {}
  return old;
}
template <class T> T atomicMax(T* p, T v) {
  std::atomic_ref<T> a(*p);
  T old = a.load();
  while (v > old && !a.compare_exchange_weak(old, v)) {}
  return old;
}

// --- the runtime ---------------------------------------------------------------------------------------
enum cudaError_t {
  cudaSuccess = 0,
  cudaErrorInvalidValue = 1,
  cudaErrorMemoryAllocation = 2,
  cudaErrorInvalidConfiguration = 9,
  cudaErrorInsufficientDriver = 35,
  cudaErrorNoDevice = 100,
};
enum cudaMemcpyKind { cudaMemcpyHostToHost, cudaMemcpyHostToDevice, cudaMemcpyDeviceToHost, cudaMemcpyDeviceToDevice };
struct cudaDeviceProp {
  char name[256];
  std::size_t totalGlobalMem;
  int major, minor;
};
using cudaEvent_t = struct EmulatedEvent*;

const char* cudaGetErrorString(cudaError_t e);
cudaError_t cudaGetLastError();
cudaError_t cudaGetDeviceCount(int* count);
cudaError_t cudaGetDeviceProperties(cudaDeviceProp* prop, int device);
cudaError_t cudaSetDevice(int device);
cudaError_t cudaMemGetInfo(std::size_t* free_bytes, std::size_t* total_bytes);
cudaError_t cudaMalloc(void** p, std::size_t bytes);
cudaError_t cudaFree(void* p);
cudaError_t cudaMemcpy(void* dst, const void* src, std::size_t bytes, cudaMemcpyKind kind);
cudaError_t cudaMemset(void* p, int value, std::size_t bytes);
cudaError_t cudaDeviceSynchronize();
cudaError_t cudaEventCreate(cudaEvent_t* e);
cudaError_t cudaEventDestroy(cudaEvent_t e);
cudaError_t cudaEventRecord(cudaEvent_t e, void* stream = nullptr);
cudaError_t cudaEventSynchronize(cudaEvent_t e);
cudaError_t cudaEventElapsedTime(float* ms, cudaEvent_t start, cudaEvent_t stop);
template <class T>
cudaError_t cudaMemcpyToSymbol(T& symbol, const void* src, std::size_t bytes, std::size_t offset = 0,
                               cudaMemcpyKind = cudaMemcpyHostToDevice) {
  if (offset + bytes > sizeof(T)) return cudaErrorInvalidValue;
  std::memcpy(reinterpret_cast<char*>(&symbol) + offset, src, bytes);
  return cudaSuccess;
}

namespace meniscus::cuda::emulation {

/// Runs block(b) for every block b of the grid, in parallel, with blockIdx, threadIdx, blockDim
/// and gridDim set on the thread that runs it; records cudaErrorInvalidConfiguration (returned by
/// the next cudaGetLastError) for an empty grid or a block of more than 1024 threads.
void run_grid(dim3 grid, dim3 block, const std::function<void()>& body);

/// MENISCUS_LAUNCH(kernel, grid, block)(args…): the arguments are converted to the kernel's
/// parameter types and copied, as a launch does, then every block runs the kernel on them.
template <class... P>
struct Launch {
  void (*kernel)(P...);
  dim3 grid, block;
  template <class... A>
  void operator()(A&&... args) const {
    const std::tuple<P...> params(std::forward<A>(args)...);
    run_grid(grid, block, [&] { std::apply(kernel, params); });
  }
};
template <class... P>
Launch<P...> launch(void (*kernel)(P...), dim3 grid, dim3 block) {
  return {kernel, grid, block};
}

}  // namespace meniscus::cuda::emulation
