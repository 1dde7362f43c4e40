// meniscus — CUDA error checking, launches, and device memory ownership for the CUDA backend.
// Every runtime call goes through MENISCUS_CUDA_CHECK, which throws CudaError (file, line, the
// call and the CUDA error string) — the library never exits. Every kernel launch goes through
// MENISCUS_LAUNCH (no raw <<< >>> in the sources: a test checks it), which counts it and, in the
// emulated device's build (MENISCUS_CUDA_EMULATION), runs it on the CPU. DeviceBuffer owns one
// cudaMalloc allocation (RAII, move-only), so every path out of a stage, exceptions included,
// frees device memory.
#pragma once

#include <cuda_runtime.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <utility>

#include "meniscus/errors.hpp"

#define MENISCUS_CUDA_CHECK(call)                                                                        \
  do {                                                                                                   \
    const cudaError_t meniscus_cuda_status_ = (call);                                                    \
    if (meniscus_cuda_status_ != cudaSuccess)                                                            \
      throw ::meniscus::CudaError(__FILE__, __LINE__,                                                    \
                                  std::string(#call) + ": " + cudaGetErrorString(meniscus_cuda_status_)); \
  } while (0)

/// MENISCUS_LAUNCH(kernel, grid, block)(arguments…): kernel<<<grid, block>>>(arguments…), counted;
/// on the emulated device, a run of every block on the CPU.
#if defined(MENISCUS_CUDA_EMULATION)
#define MENISCUS_LAUNCH(kernel, grid, block) \
  ::meniscus::cuda::count_launch(), ::meniscus::cuda::emulation::launch(kernel, dim3(grid), dim3(block))
#else
#define MENISCUS_LAUNCH(kernel, grid, block) ::meniscus::cuda::count_launch(), kernel<<<(grid), (block)>>>
#endif

/// Checks the launch of the kernel just queued (configuration errors; faults surface at the next
/// synchronising call, which is checked too).
#define MENISCUS_CUDA_CHECK_LAUNCH() MENISCUS_CUDA_CHECK(cudaGetLastError())

namespace meniscus::cuda {

/// What the host asked of the device, counted per host thread (a reconstruction runs on one):
/// kernel launches, copies each way, memsets, and the calls after which the host waits for the
/// device — a copy to the host or an event synchronisation: the round trips. A stage's counts
/// are the difference of two readings.
struct DeviceCalls {
  uint64_t launches = 0, uploads = 0, downloads = 0, device_copies = 0, memsets = 0, waits = 0;
};
inline thread_local DeviceCalls device_calls;

inline void count_launch() { ++device_calls.launches; }

/// cudaMemcpy and cudaMemset, counted (the sources call no others).
inline cudaError_t counted_memcpy(void* dst, const void* src, std::size_t bytes, cudaMemcpyKind kind) {
  if (kind == cudaMemcpyHostToDevice) ++device_calls.uploads;
  if (kind == cudaMemcpyDeviceToHost) ++device_calls.downloads, ++device_calls.waits;
  if (kind == cudaMemcpyDeviceToDevice) ++device_calls.device_copies;
  return cudaMemcpy(dst, src, bytes, kind);
}
inline cudaError_t counted_memset(void* p, int value, std::size_t bytes) {
  ++device_calls.memsets;
  return cudaMemset(p, value, bytes);
}

template <class T>
class DeviceBuffer {
 public:
  DeviceBuffer() = default;
  explicit DeviceBuffer(std::size_t n) { resize(n); }
  ~DeviceBuffer() { release(); }
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;
  DeviceBuffer(DeviceBuffer&& o) noexcept : data_(std::exchange(o.data_, nullptr)), size_(std::exchange(o.size_, 0)) {}
  DeviceBuffer& operator=(DeviceBuffer&& o) noexcept {
    if (this != &o) {
      release();
      data_ = std::exchange(o.data_, nullptr);
      size_ = std::exchange(o.size_, 0);
    }
    return *this;
  }

  /// Reallocates (contents are not kept) to n elements; n = 0 frees.
  void resize(std::size_t n) {
    if (n == size_) return;
    release();
    if (n > 0) {
      const cudaError_t status = cudaMalloc(reinterpret_cast<void**>(&data_), n * sizeof(T));
      if (status == cudaErrorMemoryAllocation) {
        (void)cudaGetLastError();  // not sticky: the device stays usable
        data_ = nullptr;
        std::size_t free_bytes = 0, total_bytes = 0;
        (void)cudaMemGetInfo(&free_bytes, &total_bytes);
        char message[160];
        std::snprintf(message, sizeof message, "the CUDA device is out of memory: %.2f GB asked for, %.2f GB free of %.2f GB",
                      double(n * sizeof(T)) / 1e9, double(free_bytes) / 1e9, double(total_bytes) / 1e9);
        throw ResourceError(message);
      }
      MENISCUS_CUDA_CHECK(status);
    }
    size_ = n;
  }
  void zero() {
    if (size_ > 0) MENISCUS_CUDA_CHECK(counted_memset(data_, 0, size_ * sizeof(T)));
  }
  void upload(const T* host, std::size_t n) {
    resize(n);
    if (n > 0) MENISCUS_CUDA_CHECK(counted_memcpy(data_, host, n * sizeof(T), cudaMemcpyHostToDevice));
  }
  void download(T* host, std::size_t n) const {
    if (n > size_) throw ResourceError("DeviceBuffer::download: more elements than the buffer holds");
    if (n > 0) MENISCUS_CUDA_CHECK(counted_memcpy(host, data_, n * sizeof(T), cudaMemcpyDeviceToHost));
  }
  /// One element (a count, a flag) back to the host.
  T get(std::size_t i) const {
    T v{};
    MENISCUS_CUDA_CHECK(counted_memcpy(&v, data_ + i, sizeof(T), cudaMemcpyDeviceToHost));
    return v;
  }
  void copy_from(const DeviceBuffer& o) {
    resize(o.size_);
    if (size_ > 0) MENISCUS_CUDA_CHECK(counted_memcpy(data_, o.data_, size_ * sizeof(T), cudaMemcpyDeviceToDevice));
  }
  T* data() { return data_; }
  const T* data() const { return data_; }
  std::size_t size() const { return size_; }

 private:
  void release() noexcept {
    if (data_ != nullptr) cudaFree(data_);  // cannot fail meaningfully in a destructor
    data_ = nullptr;
    size_ = 0;
  }
  T* data_ = nullptr;
  std::size_t size_ = 0;
};

/// A grid-stride loop over [0, n) in a kernel (64-bit index i).
#define MENISCUS_GRID_STRIDE(i, n) \
  for (uint64_t i = blockIdx.x * uint64_t(blockDim.x) + threadIdx.x; i < (n); i += uint64_t(gridDim.x) * blockDim.x)

/// Blocks for a grid-stride loop over n elements (at least 1, capped; kernels loop).
inline unsigned blocks_for(std::size_t n, unsigned threads = 256) {
  const std::size_t b = (n + threads - 1) / threads;
  return unsigned(b == 0 ? 1 : (b > 65535u * 8 ? 65535u * 8 : b));
}

}  // namespace meniscus::cuda
