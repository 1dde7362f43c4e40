// meniscus — the device as a backend tag (cuda::Device) and its buffer (DeviceBuffer) as the
// BufferOf of code written once for both backends; no kernels, so host code (.cpp) may include it.
#pragma once

#include "common/buffer.hpp"
#include "cuda/cuda_check.hpp"

namespace meniscus::cuda {

/// The device, as a tag for code shared with the CPU backend; its arrays are DeviceBuffers.
struct Device {};

}  // namespace meniscus::cuda

template <>
struct meniscus::BackendBuffer<meniscus::cuda::Device> {
  template <class T>
  using type = meniscus::cuda::DeviceBuffer<T>;
};
