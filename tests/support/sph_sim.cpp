// meniscus tests — weakly compressible SPH dam break (see sph_sim.hpp).
#include "support/sph_sim.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "grid/hash_grid.hpp"

namespace meniscus::test {

namespace {

constexpr float kPi = 3.14159265358979f;

struct Fluid {
  std::vector<Vec3f> x, v;
};

/// Reorders the particles into the grid's cell order (locality for the neighbour sums).
void sort_by_cells(Fluid& f, const HashGrid& grid) {
  const auto order = grid.order();
  Fluid sorted;
  sorted.x.assign(grid.sorted_points().begin(), grid.sorted_points().end());
  sorted.v.resize(f.v.size());
  for (std::size_t i = 0; i < order.size(); ++i) sorted.v[i] = f.v[order[i]];
  f = std::move(sorted);
}

}  // namespace

std::vector<ParticleSet> simulate_dam_break(const DamBreakSetup& s, float t_first, float frame_dt, int frames) {
  const float d = s.spacing, h = 2 * d, h2 = h * h;
  const float gravity = 9.81f;
  const float c = 10 * std::sqrt(2 * gravity * float(s.ny) * d);
  const float dt = 0.4f * h / c;
  const float poly6 = 315.0f / (64.0f * kPi * std::pow(h, 9.0f));
  const float spiky = -45.0f / (kPi * std::pow(h, 6.0f));
  const float xsph = 0.5f;

  Fluid f;
  for (int k = 0; k < s.nz; ++k)
    for (int j = 0; j < s.ny; ++j)
      for (int i = 0; i < s.nx; ++i) f.x.push_back({(float(i) + 0.5f) * d, (float(j) + 0.5f) * d, (float(k) + 0.5f) * d});
  f.v.assign(f.x.size(), Vec3f{0, 0, 0});
  const std::size_t n = f.x.size();

  // Rest density and particle mass: an interior particle of the initial lattice has density ρ0.
  const float rho0 = 1000.0f;
  float kernel_sum = 0;
  for (int k = -2; k <= 2; ++k)
    for (int j = -2; j <= 2; ++j)
      for (int i = -2; i <= 2; ++i) {
        const float r2 = float(i * i + j * j + k * k) * d * d;
        if (r2 < h2) kernel_sum += poly6 * (h2 - r2) * (h2 - r2) * (h2 - r2);
      }
  const float mass = rho0 / kernel_sum;
  const float stiffness = rho0 * c * c / 7.0f;

  std::vector<float> rho(n), pressure(n);
  std::vector<Vec3f> accel(n), smooth(n);
  auto step = [&] {
    const HashGrid grid(f.x, h);
    sort_by_cells(f, grid);
    tbb::parallel_for(std::size_t(0), n, [&](std::size_t i) {
      float sum = 0;
      grid.for_each_within(f.x[i], h, [&](uint32_t, float r2) {
        const float t = h2 - r2;
        sum += poly6 * t * t * t;
      });
      rho[i] = mass * sum;
      // Tait, negative pressures clamped: free-surface particles lack neighbours, and suction
      // would clump them.
      pressure[i] = std::max(0.0f, stiffness * (std::pow(rho[i] / rho0, 7.0f) - 1.0f));
    });
    tbb::parallel_for(std::size_t(0), n, [&](std::size_t i) {
      Vec3f a{0, -gravity, 0}, dv{0, 0, 0};
      const float pi = pressure[i] / (rho[i] * rho[i]);
      grid.for_each_within(f.x[i], h, [&](uint32_t j, float r2) {
        if (j == i || r2 == 0) return;
        const Vec3f r = f.x[i] - f.x[j];
        const float len = std::sqrt(r2);
        const float pj = pressure[j] / (rho[j] * rho[j]);
        a -= r * (mass * (pi + pj) * spiky * (h - len) * (h - len) / len);
        const float t = h2 - r2;
        dv += (f.v[j] - f.v[i]) * (mass / rho[j] * poly6 * t * t * t);
      });
      accel[i] = a;
      smooth[i] = dv * xsph;
    });
    for (std::size_t i = 0; i < n; ++i) {
      f.v[i] += accel[i] * dt;
      f.x[i] += (f.v[i] + smooth[i]) * dt;
      for (int axis = 0; axis < 3; ++axis) {  // walls: clamp, reflect the normal velocity damped
        const float lo = 0.5f * d, hi = s.tank[axis] - 0.5f * d;
        if (f.x[i][axis] < lo) f.x[i][axis] = lo, f.v[i][axis] = std::max(0.0f, -0.3f * f.v[i][axis]);
        if (f.x[i][axis] > hi) f.x[i][axis] = hi, f.v[i][axis] = std::min(0.0f, -0.3f * f.v[i][axis]);
      }
    }
  };

  std::vector<ParticleSet> out;
  double t = 0;
  for (int frame = 0; frame < frames; ++frame) {
    const double until = double(t_first) + double(frame) * double(frame_dt);
    while (t + 0.5 * double(dt) < until) {
      step();
      t += double(dt);
    }
    ParticleSet ps;
    ps.positions = f.x;
    Attribute velocity{"velocity", 3, false, {}};
    velocity.values.reserve(3 * n);
    for (const Vec3f& v : f.v) velocity.values.insert(velocity.values.end(), {v.x, v.y, v.z});
    ps.attributes.push_back(std::move(velocity));
    out.push_back(std::move(ps));
  }
  return out;
}

}  // namespace meniscus::test
