// meniscus — the CUDA devices of this process (cudaGetDeviceCount / cudaGetDeviceProperties).
#include <cuda_runtime.h>

#include "meniscus/backend.hpp"

namespace meniscus {

bool cuda_built() { return true; }

std::vector<CudaDeviceInfo> cuda_devices(std::string* reason) {
  std::vector<CudaDeviceInfo> out;
  int count = 0;
  const cudaError_t status = cudaGetDeviceCount(&count);
  if (status != cudaSuccess || count == 0) {
    if (reason)
      *reason = status == cudaErrorNoDevice || count == 0 || status == cudaErrorInsufficientDriver
                    ? std::string("no CUDA device") + (status == cudaSuccess ? "" : std::string(": ") + cudaGetErrorString(status))
                    : std::string("no CUDA device: ") + cudaGetErrorString(status);
    cudaGetLastError();  // clear the sticky-free error state of the failed query
    return out;
  }
  for (int i = 0; i < count; ++i) {
    cudaDeviceProp prop{};
    if (cudaGetDeviceProperties(&prop, i) != cudaSuccess) continue;
    CudaDeviceInfo d;
    d.index = i;
    d.name = prop.name;
    d.major = prop.major;
    d.minor = prop.minor;
    d.total_memory = prop.totalGlobalMem;
#if defined(MENISCUS_CUDA_EMULATION)
    d.emulated = true;
#endif
    std::size_t free_bytes = 0, total_bytes = 0;
    if (cudaSetDevice(i) == cudaSuccess && cudaMemGetInfo(&free_bytes, &total_bytes) == cudaSuccess)
      d.free_memory = free_bytes;
    out.push_back(d);
  }
  if (out.empty() && reason) *reason = "no CUDA device (properties could not be read)";
  cudaGetLastError();
  return out;
}

}  // namespace meniscus
