// meniscus — per-particle anisotropy (Yu & Turk 2010, "Reconstructing Surfaces of
// Particle-Based Fluids Using Anisotropic Kernels", §4–5): weighted PCA of each particle's
// neighbourhood gives an ellipsoid kernel; Laplacian smoothing of the positions gives the
// kernel centres.
#pragma once

#include <span>
#include <vector>

#include "field/kernel_impl.hpp"
#include "grid/hash_grid.hpp"

namespace meniscus {

/// Laplacian smoothing of the points of `grid` (Yu & Turk §5): x̄_i = (1−λ)x_i + λ Σ_j w_ij x_j / Σ_j w_ij
/// over the points within `radius` (the point itself included), w_ij = 1 − (r_ij/radius)³.
/// Returns the smoothed points in the *original* order (grid.order() maps sorted → original).
/// `first` (original indices, empty: none): per point the first point at its position
/// (coincident_points); a copy takes its first's result, the same numbers, computed once — each
/// of a pile of k copies would otherwise sum over all k (O(k²)). With it, O(n + k · (the points
/// within `radius` of the pile)) for a pile of k.
std::vector<Vec3f> smooth_positions(const HashGrid& grid, float radius, float lambda,
                                    std::span<const uint32_t> first = {});

/// Yu & Turk's ellipsoid of every point of `grid` from the weighted covariance of its neighbours
/// within `radius` (their 2h), weights w = 1 − (r/radius)³, about the weighted mean. Returned in
/// the *original* order. Parallel over points. `first`: as for smooth_positions.
std::vector<Ellipsoid> yu_turk_ellipsoids(const HashGrid& grid, float radius, const AnisotropyConstants& constants,
                                          std::span<const uint32_t> first = {});

/// centre_holding_particle for every particle, in place: `particles`, `ellipsoids` and `centres`
/// in the same (original) order. Parallel over particles.
void hold_particles_in_shells(std::span<const Vec3f> particles, std::span<const Ellipsoid> ellipsoids, float reach,
                              std::span<Vec3f> centres);

}  // namespace meniscus
