// meniscus — the velocity weights on the device: velocity_weights.hpp instantiated with
// cuda::Device (the declaration is in cuda/stages_cuda.hpp).
#include "cuda/primitives.hpp"
#include "cuda/stages_cuda.hpp"
#include "transfer/velocity_weights.hpp"

namespace meniscus::cuda {

DeviceBuffer<float> velocity_weights(const DeviceBuffer<float>& velocity, std::size_t vertices, float reference,
                                     float min_weight) {
  return ::meniscus::velocity_weights(Device{}, velocity.data(), vertices, reference, min_weight);
}

}  // namespace meniscus::cuda
