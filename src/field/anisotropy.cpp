// meniscus — per-particle anisotropy (Yu & Turk 2010 §4–5).
#include "field/anisotropy.hpp"

#include <tbb/parallel_for.h>

#include "field/anisotropy_impl.hpp"

namespace meniscus {

std::vector<Vec3f> smooth_positions(const HashGrid& grid, float radius, float lambda) {
  const auto order = grid.order();
  std::vector<Vec3f> out(grid.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, out.size(), 512), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) out[order[i]] = smoothed_position(grid, uint32_t(i), radius, lambda);
  });
  return out;
}

std::vector<Ellipsoid> yu_turk_ellipsoids(const HashGrid& grid, float radius, const AnisotropyConstants& constants) {
  const auto order = grid.order();
  std::vector<Ellipsoid> out(grid.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, out.size(), 256), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i)
      out[order[i]] = particle_ellipsoid(grid, uint32_t(i), radius, constants);
  });
  return out;
}

void hold_particles_in_shells(std::span<const Vec3f> particles, std::span<const Ellipsoid> ellipsoids, float reach,
                              std::span<Vec3f> centres) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, centres.size(), 1024), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i)
      centres[i] = centre_holding_particle(particles[i], centres[i], ellipsoids[i], reach);
  });
}

}  // namespace meniscus
