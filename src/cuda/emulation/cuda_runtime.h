// meniscus — the emulated CUDA device (MENISCUS_CUDA_EMULATION, tests only; never installed):
// a stand-in for the part of the CUDA runtime the backend uses, so src/cuda/*.cu compile with the
// host compiler and every kernel runs on the CPU. A launch runs its blocks in parallel on oneTBB
// and every thread of a block, with the blockDim the launch asked for, on one CPU thread: the
// block's threads run one after another in an order that changes from launch to launch, and a
// thread that reaches __syncthreads (or a warp reduction) is suspended on its own stack (a fiber)
// until every live thread of its block (or warp) has arrived, then they go on in another order.
// So a missing barrier, a race between a block's threads or a divergent barrier shows up as it
// would on a GPU (a wrong result, or cudaErrorLaunchFailure for the barrier), and __shared__
// memory is one copy per block (a thread_local of the CPU thread that runs the whole block).
// Device memory is host memory (cudaMemcpy is memcpy), with an optional size limit to test the
// out-of-memory paths (MENISCUS_EMULATED_DEVICE_MEMORY, bytes); MENISCUS_EMULATED_SEED changes the
// thread orders (default 0: a run is reproducible).
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

/// Waits until every live thread of the block has reached it (see the file's comment).
void __syncthreads();
inline int __float_as_int(float f) {
  int i;
  std::memcpy(&i, &f, sizeof i);
  return i;
}
namespace meniscus::cuda::emulation {
enum class WarpOp { min, max, add };
/// The value of `op` over the live threads of the caller's warp (32 consecutive threads of the
/// block), every one of which must call it: a barrier over the warp on each side of the exchange.
int warp_reduce(int value, WarpOp op);
}  // namespace meniscus::cuda::emulation
inline int __reduce_min_sync(unsigned, int v) {
  return meniscus::cuda::emulation::warp_reduce(v, meniscus::cuda::emulation::WarpOp::min);
}
inline int __reduce_max_sync(unsigned, int v) {
  return meniscus::cuda::emulation::warp_reduce(v, meniscus::cuda::emulation::WarpOp::max);
}
inline int __reduce_add_sync(unsigned, int v) {
  return meniscus::cuda::emulation::warp_reduce(v, meniscus::cuda::emulation::WarpOp::add);
}

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
  cudaErrorLaunchFailure = 719,
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

/// Runs body() as every thread of every block of the grid: blocks in parallel, a block's threads
/// on one CPU thread as the file's comment says, with blockIdx, threadIdx, blockDim and gridDim
/// set. Records (for the next cudaGetLastError) cudaErrorInvalidConfiguration for an empty grid or
/// a block of more than 1024 threads, cudaErrorLaunchFailure for a barrier that not every live
/// thread of a block reached.
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
