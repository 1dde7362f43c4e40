// meniscus — the CUDA entry points of a build without CUDA (MENISCUS_CUDA=OFF or no nvcc).
#include "cuda/pipeline_cuda.hpp"
#include "meniscus/backend.hpp"
#include "meniscus/errors.hpp"

namespace meniscus {

bool cuda_built() { return false; }

std::vector<CudaDeviceInfo> cuda_devices(std::string* reason) {
  if (reason) *reason = "built without CUDA";
  return {};
}

namespace cuda {
std::unique_ptr<StageBackend> make_device_stages(const PipelineInput&, Stats&, const ProgressFn&) {
  throw ResourceError("the CUDA backend is not built in (built without CUDA; configure with -DMENISCUS_CUDA=ON)");
}
}  // namespace cuda

}  // namespace meniscus
