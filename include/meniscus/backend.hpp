// meniscus — the compute backends: what was built in and which CUDA devices are there.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace meniscus {

struct CudaDeviceInfo {
  int index = 0;
  std::string name;
  int major = 0, minor = 0;        ///< compute capability
  std::size_t total_memory = 0;    ///< bytes
  std::size_t free_memory = 0;     ///< bytes free when queried
  /// The emulated device of a MENISCUS_CUDA_EMULATION build (the CUDA backend's kernels run on
  /// the CPU, for tests): --backend cuda uses it, --backend auto never does.
  bool emulated = false;
};

/// True when this build contains the CUDA backend (CMake MENISCUS_CUDA found nvcc).
bool cuda_built();

/// The CUDA devices this process can use. Empty when there are none; then `reason` (when not
/// null) says why: "built without CUDA", "no CUDA device" or the CUDA driver's error string.
/// Never throws.
std::vector<CudaDeviceInfo> cuda_devices(std::string* reason = nullptr);

}  // namespace meniscus
