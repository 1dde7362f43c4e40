// meniscus — the emulated CUDA device's runtime (see cuda_runtime.h here): one device, host
// memory with an optional limit, launches run on oneTBB, events on the steady clock.
#include <cuda_runtime.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <cstdlib>
#include <mutex>
#include <new>
#include <string>
#include <unordered_map>

namespace {

thread_local cudaError_t last_error = cudaSuccess;

struct Memory {
  std::mutex mutex;
  std::unordered_map<void*, std::size_t> sizes;
  std::size_t used = 0;
  std::size_t total() const {  // read at every call, so a test can shrink the device
    const char* v = std::getenv("MENISCUS_EMULATED_DEVICE_MEMORY");
    return v != nullptr && *v != '\0' ? std::size_t(std::stoull(v)) : std::size_t(16) << 30;
  }
};
Memory& memory() {
  static Memory m;
  return m;
}

cudaError_t fail(cudaError_t e) { return last_error = e; }

}  // namespace

struct EmulatedEvent {
  std::chrono::steady_clock::time_point time;
};

const char* cudaGetErrorString(cudaError_t e) {
  switch (e) {
    case cudaSuccess: return "no error";
    case cudaErrorInvalidValue: return "invalid argument";
    case cudaErrorMemoryAllocation: return "out of memory (emulated device)";
    case cudaErrorInvalidConfiguration: return "invalid configuration argument";
    case cudaErrorInsufficientDriver: return "CUDA driver version is insufficient for CUDA runtime version";
    case cudaErrorNoDevice: return "no CUDA-capable device is detected";
  }
  return "unknown error";
}

cudaError_t cudaGetLastError() { return std::exchange(last_error, cudaSuccess); }

cudaError_t cudaGetDeviceCount(int* count) {
  *count = 1;
  return cudaSuccess;
}

cudaError_t cudaGetDeviceProperties(cudaDeviceProp* prop, int device) {
  if (device != 0) return fail(cudaErrorInvalidValue);
  std::snprintf(prop->name, sizeof prop->name, "emulated on the CPU (MENISCUS_CUDA_EMULATION, for tests)");
  prop->totalGlobalMem = memory().total();
  prop->major = prop->minor = 0;
  return cudaSuccess;
}

cudaError_t cudaSetDevice(int device) { return device == 0 ? cudaSuccess : fail(cudaErrorInvalidValue); }

cudaError_t cudaMemGetInfo(std::size_t* free_bytes, std::size_t* total_bytes) {
  Memory& m = memory();
  std::lock_guard lock(m.mutex);
  *total_bytes = m.total();
  *free_bytes = m.used < m.total() ? m.total() - m.used : 0;
  return cudaSuccess;
}

cudaError_t cudaMalloc(void** p, std::size_t bytes) {
  Memory& m = memory();
  std::lock_guard lock(m.mutex);
  if (m.used > m.total() || bytes > m.total() - m.used) return fail(cudaErrorMemoryAllocation);
  *p = ::operator new(bytes, std::align_val_t(256), std::nothrow);
  if (*p == nullptr) return fail(cudaErrorMemoryAllocation);
  m.sizes.emplace(*p, bytes);
  m.used += bytes;
  return cudaSuccess;
}

cudaError_t cudaFree(void* p) {
  if (p == nullptr) return cudaSuccess;
  Memory& m = memory();
  std::lock_guard lock(m.mutex);
  const auto it = m.sizes.find(p);
  if (it == m.sizes.end()) return fail(cudaErrorInvalidValue);
  m.used -= it->second;
  m.sizes.erase(it);
  ::operator delete(p, std::align_val_t(256));
  return cudaSuccess;
}

cudaError_t cudaMemcpy(void* dst, const void* src, std::size_t bytes, cudaMemcpyKind) {
  if (bytes > 0) std::memmove(dst, src, bytes);
  return cudaSuccess;
}

cudaError_t cudaMemset(void* p, int value, std::size_t bytes) {
  if (bytes > 0) std::memset(p, value, bytes);
  return cudaSuccess;
}

cudaError_t cudaDeviceSynchronize() { return cudaSuccess; }

cudaError_t cudaEventCreate(cudaEvent_t* e) {
  *e = new EmulatedEvent{};
  return cudaSuccess;
}
cudaError_t cudaEventDestroy(cudaEvent_t e) {
  delete e;
  return cudaSuccess;
}
cudaError_t cudaEventRecord(cudaEvent_t e, void*) {
  e->time = std::chrono::steady_clock::now();  // launches are synchronous here
  return cudaSuccess;
}
cudaError_t cudaEventSynchronize(cudaEvent_t) { return cudaSuccess; }
cudaError_t cudaEventElapsedTime(float* ms, cudaEvent_t start, cudaEvent_t stop) {
  *ms = std::chrono::duration<float, std::milli>(stop->time - start->time).count();
  return cudaSuccess;
}

namespace meniscus::cuda::emulation {

void run_grid(dim3 grid, dim3 block, const std::function<void()>& body) {
  const std::size_t blocks = std::size_t(grid.x) * grid.y * grid.z;
  if (blocks == 0 || block.x * block.y * block.z == 0 || block.x * block.y * block.z > 1024 || grid.y > 65535 ||
      grid.z > 65535) {
    fail(cudaErrorInvalidConfiguration);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks), [&](const auto& r) {
    for (std::size_t b = r.begin(); b != r.end(); ++b) {
      blockIdx = {unsigned(b % grid.x), unsigned(b / grid.x % grid.y), unsigned(b / (std::size_t(grid.x) * grid.y))};
      threadIdx = {0, 0, 0};
      blockDim = dim3(1, 1, 1);
      gridDim = grid;
      body();
    }
  });
}

}  // namespace meniscus::cuda::emulation
