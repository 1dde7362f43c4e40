// meniscus — the per-particle arithmetic of Yu & Turk 2010 §4–5 (anisotropy.cpp), shared by the
// CPU and CUDA backends: any `Grid` of hash_grid_impl.hpp (the CPU HashGrid, the device's
// GridView). Both visit the same neighbours in the same order and sum in double, so both give
// the same centres and ellipsoids.
#pragma once

#include <cmath>
#include <cstdint>

#include "field/kernel_impl.hpp"
#include "grid/hash_grid_impl.hpp"

namespace meniscus {

/// Laplacian smoothing of sorted point i (Yu & Turk §5): (1−λ)x_i + λ Σ_j w_ij x_j / Σ_j w_ij over
/// the points within `radius` (i itself included), w_ij = 1 − (r_ij/radius)³. Sums relative to
/// x_i: no cancellation far from the origin.
template <class Grid>
MENISCUS_HD Vec3f smoothed_position(const Grid& g, uint32_t i, float radius, float lambda) {
  const Vec3f p = g.point(i);
  Vec3f sum{0, 0, 0};
  float weight = 0;
  grid_for_each_within(g, p, radius, [&](uint32_t j, float d2) {
    const float w = yu_turk_weight(std::sqrt(d2), radius);
    sum += (g.point(j) - p) * w;
    weight += w;
  });
  return weight > 0 ? p + sum * (lambda / weight) : p;
}

/// Yu & Turk's ellipsoid of sorted point i: the covariance of its neighbours within `radius`
/// (their 2h), weights w = 1 − (r/radius)³, about the weighted mean, clamped (yu_turk_ellipsoid).
template <class Grid>
MENISCUS_HD Ellipsoid particle_ellipsoid(const Grid& g, uint32_t i, float radius, const AnisotropyConstants& k) {
  const Vec3f p = g.point(i);
  double w_sum = 0, m[3] = {0, 0, 0}, c[6] = {0, 0, 0, 0, 0, 0};
  int count = 0;
  grid_for_each_within(g, p, radius, [&](uint32_t j, float d2) {
    const double w = yu_turk_weight(std::sqrt(d2), radius);
    const Vec3f q = g.point(j) - p;
    w_sum += w;
    m[0] += w * q.x, m[1] += w * q.y, m[2] += w * q.z;
    c[0] += w * q.x * q.x, c[1] += w * q.x * q.y, c[2] += w * q.x * q.z;
    c[3] += w * q.y * q.y, c[4] += w * q.y * q.z, c[5] += w * q.z * q.z;
    ++count;
  });
  float cov[3][3] = {};
  if (w_sum > 0) {
    for (double& v : m) v /= w_sum;
    cov[0][0] = float(c[0] / w_sum - m[0] * m[0]), cov[0][1] = float(c[1] / w_sum - m[0] * m[1]);
    cov[0][2] = float(c[2] / w_sum - m[0] * m[2]), cov[1][1] = float(c[3] / w_sum - m[1] * m[1]);
    cov[1][2] = float(c[4] / w_sum - m[1] * m[2]), cov[2][2] = float(c[5] / w_sum - m[2] * m[2]);
    cov[1][0] = cov[0][1], cov[2][0] = cov[0][2], cov[2][1] = cov[1][2];
  }
  return yu_turk_ellipsoid(cov, count - 1, k);  // the point itself is not a neighbour
}

/// The kernel centre of the particle at x, smoothed to `centre`, taken back along the line to x
/// until x lies within `reach` of it in the metric of the particle's constraint shell (the unit
/// volume shell of its ellipsoid `e`): the constrained smoothing keeps the surface outside every
/// inner shell, which keeps the particle inside only while it lies inside its own
/// (kCentreInShell). reach ≤ 0: the centre as smoothed.
MENISCUS_HD inline Vec3f centre_holding_particle(Vec3f x, Vec3f centre, const Ellipsoid& e, float reach) {
  if (!(reach > 0.0f)) return centre;
  const float m = length(unit_volume_shell(e).metric * (x - centre));
  return m > reach ? x + (centre - x) * (reach / m) : centre;
}

}  // namespace meniscus
