// meniscus — the field's stages on the device: band_field.hpp (band blocks, distance and kernel
// fields) and particle_frames.hpp (Yu & Turk's centres and ellipsoids, shells, largest axis)
// instantiated with cuda::Device (the declarations are in cuda/stages_cuda.hpp).
#include "cuda/primitives.hpp"
#include "cuda/stages_cuda.hpp"
#include "field/band_field.hpp"
#include "field/particle_frames.hpp"

namespace meniscus::cuda {

DeviceBuffer<uint64_t> band_blocks(const DeviceGrid& grid, const SampleLattice& lattice, float band,
                                   std::size_t* block_count) {
  return ::meniscus::band_blocks(Device{}, grid, lattice, band, block_count);
}

DeviceField distance_field(const DeviceGrid& grid, const SampleLattice& lattice, float band,
                           DeviceBuffer<uint64_t> keys, std::size_t block_count) {
  return ::meniscus::distance_field(Device{}, grid, lattice, band, std::move(keys), block_count);
}

DeviceField kernel_field(const DeviceGrid& grid, const SampleLattice& lattice, const KernelParticles& k, float support,
                         float iso, float background, DeviceBuffer<uint64_t> keys, std::size_t block_count) {
  return ::meniscus::kernel_field(Device{}, grid, lattice, k, support, iso, background, std::move(keys), block_count);
}

void particle_frames(const DeviceGrid& raw, float pca_radius, const AnisotropyConstants& k, float smooth_radius,
                     float lambda, DeviceBuffer<Vec3f>* centres, DeviceBuffer<Ellipsoid>* ellipsoids,
                     float centre_reach) {
  ::meniscus::particle_frames(Device{}, raw, pca_radius, k, smooth_radius, lambda, centres, ellipsoids, centre_reach);
}

DeviceBuffer<Ellipsoid> unit_volume_shells(const DeviceBuffer<Ellipsoid>& ellipsoids) {
  return ::meniscus::unit_volume_shells(Device{}, ellipsoids);
}

float max_ellipsoid_axis(const DeviceBuffer<Ellipsoid>& ellipsoids, uint32_t count) {
  return ::meniscus::max_ellipsoid_axis(Device{}, ellipsoids.data(), count);
}

}  // namespace meniscus::cuda
