// meniscus — per-particle anisotropy (Yu & Turk 2010 §4–5).
#include "field/anisotropy.hpp"

#include "common/for_each.hpp"
#include "field/anisotropy_impl.hpp"

namespace meniscus {

std::vector<Vec3f> smooth_positions(const HashGrid& grid, float radius, float lambda) {
  const auto order = grid.order();
  std::vector<Vec3f> out(grid.size());
  for_each_index(out.size(), 512,
                 [&](std::size_t i) { out[order[i]] = smoothed_position(grid, uint32_t(i), radius, lambda); });
  return out;
}

std::vector<Ellipsoid> yu_turk_ellipsoids(const HashGrid& grid, float radius, const AnisotropyConstants& constants) {
  const auto order = grid.order();
  std::vector<Ellipsoid> out(grid.size());
  for_each_chunk(out.size(), 256, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i != end; ++i) out[order[i]] = particle_ellipsoid(grid, uint32_t(i), radius, constants);
  });
  return out;
}

void hold_particles_in_shells(std::span<const Vec3f> particles, std::span<const Ellipsoid> ellipsoids, float reach,
                              std::span<Vec3f> centres) {
  for_each_chunk(centres.size(), 1024, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i != end; ++i)
      centres[i] = centre_holding_particle(particles[i], centres[i], ellipsoids[i], reach);
  });
}

}  // namespace meniscus
