// meniscus — the hash grid's build and per-particle gathers on the device: build_grid.hpp
// instantiated with cuda::Device (the declarations are in cuda/stages_cuda.hpp).
#include "cuda/primitives.hpp"
#include "cuda/stages_cuda.hpp"
#include "grid/build_grid.hpp"

namespace meniscus::cuda {

DeviceGrid build_grid(const DeviceBuffer<Vec3f>& points, uint32_t count, float cell_size, Vec3i lo, Vec3i hi) {
  return ::meniscus::build_grid(Device{}, points.data(), count, cell_size, lo, hi);
}

void point_bounds(const DeviceBuffer<Vec3f>& points, uint32_t count, Vec3f* lo, Vec3f* hi) {
  ::meniscus::point_bounds(Device{}, points.data(), count, lo, hi);
}

DeviceBuffer<float> to_sorted_order(const DeviceGrid& grid, const DeviceBuffer<float>& values) {
  return ::meniscus::to_sorted_order(Device{}, grid, values.data());
}
DeviceBuffer<Ellipsoid> to_sorted_order(const DeviceGrid& grid, const DeviceBuffer<Ellipsoid>& values) {
  return ::meniscus::to_sorted_order(Device{}, grid, values.data());
}

}  // namespace meniscus::cuda
