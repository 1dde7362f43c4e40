// meniscus — per-particle anisotropy (Yu & Turk 2010 §4–5).
#include "field/anisotropy.hpp"

#include "common/for_each.hpp"
#include "field/anisotropy_impl.hpp"

namespace meniscus {

namespace {

/// out[order[i]] = f(i) for every sorted point i that is the first at its position (every point
/// without `first`), then each copy's out from its first's.
template <class T, class F>
std::vector<T> per_position(const HashGrid& grid, std::span<const uint32_t> first, std::size_t grain, F&& f) {
  const auto order = grid.order();
  std::vector<T> out(grid.size());
  for_each_index(out.size(), grain, [&](std::size_t i) {
    const uint32_t o = order[i];
    if (first.empty() || first[o] == o) out[o] = f(uint32_t(i));
  });
  if (!first.empty())
    for_each_index(out.size(), 4096, [&](std::size_t o) {
      if (first[o] != o) out[o] = out[first[o]];
    });
  return out;
}

}  // namespace

std::vector<Vec3f> smooth_positions(const HashGrid& grid, float radius, float lambda,
                                    std::span<const uint32_t> first) {
  return per_position<Vec3f>(grid, first, 512, [&](uint32_t i) { return smoothed_position(grid, i, radius, lambda); });
}

std::vector<Ellipsoid> yu_turk_ellipsoids(const HashGrid& grid, float radius, const AnisotropyConstants& constants,
                                          std::span<const uint32_t> first) {
  return per_position<Ellipsoid>(grid, first, 256,
                                 [&](uint32_t i) { return particle_ellipsoid(grid, i, radius, constants); });
}

void hold_particles_in_shells(std::span<const Vec3f> particles, std::span<const Ellipsoid> ellipsoids, float reach,
                              std::span<Vec3f> centres) {
  for_each_chunk(centres.size(), 1024, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i != end; ++i)
      centres[i] = centre_holding_particle(particles[i], centres[i], ellipsoids[i], reach);
  });
}

}  // namespace meniscus
