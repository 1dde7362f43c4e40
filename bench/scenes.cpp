// meniscus bench — the synthetic scenes (block, sphere, splash); copied from the test support
// generators rather than linked, so the benchmarks build without tests/.
#include "scenes.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

namespace meniscus::bench {
namespace {

constexpr double kPi = 3.14159265358979323846;

// nx·ny·nz lattice points of spacing d from `origin`, each coordinate jittered by ±jitter·d.
void append_block(std::vector<Vec3f>& out, int nx, int ny, int nz, float d, float jitter, std::mt19937& rng,
                  Vec3f origin) {
  std::uniform_real_distribution<float> u(-jitter * d, jitter * d);
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        Vec3f p{origin.x + float(i) * d, origin.y + float(j) * d, origin.z + float(k) * d};
        if (jitter > 0) p += Vec3f{u(rng), u(rng), u(rng)};
        out.push_back(p);
      }
}

// Concentric Fibonacci shells d apart, outermost at R, hexagonal density on each shell
// (test_support's shell_ball): a sphere whose surface particles lie exactly on a sphere.
void append_shell_ball(std::vector<Vec3f>& out, float R, float d, Vec3f center) {
  out.push_back(center);
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  for (float r = R; r > 0.5f * d; r -= d) {
    const int n = std::max(4, int(std::lround(4.0 * kPi * double(r) * double(r) / (0.8660254 * double(d) * double(d)))));
    for (int i = 0; i < n; ++i) {
      const double z = 1.0 - 2.0 * (i + 0.5) / n, rho = std::sqrt(1.0 - z * z), phi = golden * i;
      out.push_back(center + Vec3f{float(rho * std::cos(phi)), float(rho * std::sin(phi)), float(z)} * r);
    }
  }
}

// Particles of a shell ball grow as ≈ (4π/3)(R/d)³ · (2/√3)·(some shell discretisation); rather
// than model that, bisect R on the actual count (cheap: counting needs no allocation).
std::size_t shell_ball_count(float R, float d) {
  std::size_t n = 1;
  for (float r = R; r > 0.5f * d; r -= d)
    n += std::size_t(std::max(4L, std::lround(4.0 * kPi * double(r) * double(r) / (0.8660254 * double(d) * double(d)))));
  return n;
}

}  // namespace

std::vector<std::string> scene_names() { return {"block", "sphere", "splash"}; }

Scene make_scene(const std::string& name, std::size_t count, float d) {
  Scene s;
  s.name = name;
  s.spacing = d;
  std::mt19937 rng(12345u + uint32_t(count % 100000u));
  std::vector<Vec3f>& out = s.particles.positions;
  if (name == "block") {
    const int n = std::max(2, int(std::lround(std::cbrt(double(count)))));
    out.reserve(std::size_t(n) * std::size_t(n) * std::size_t(n));
    append_block(out, n, n, n, d, 0.1f, rng, {0, 0, 0});
    s.has_flat_top = true;
    // The top face spans the lattice's xy extent at z = (n-1)·d.
    const float top = float(n - 1) * d;
    s.top_lo = {0, 0, top};
    s.top_hi = {top, top, top};
  } else if (name == "sphere") {
    float lo = d, hi = d * float(std::cbrt(double(count))) * 2.0f;
    for (int it = 0; it < 40; ++it) {
      const float mid = 0.5f * (lo + hi);
      (shell_ball_count(mid, d) < count ? lo : hi) = mid;
    }
    out.reserve(shell_ball_count(hi, d));
    append_shell_ball(out, hi, d, {0, 0, 0});
  } else if (name == "splash") {
    // Pool: a slab 8 : 8 : 1 holding 80 % of the particles (a shallow tank, like a dam break's
    // end state), droplets in a box over it up to 2 pool depths high — lots of small components,
    // the case where band-limited methods do many tiny disjoint pieces of work.
    const std::size_t pool_count = count * 4 / 5;
    const int depth = std::max(2, int(std::lround(std::cbrt(double(pool_count) / 64.0))));
    const int side = 8 * depth;
    append_block(out, side, side, depth, d, 0.1f, rng, {0, 0, 0});
    const float extent = float(side - 1) * d, pool_top = float(depth - 1) * d;
    std::uniform_real_distribution<float> ux(2 * d, extent - 2 * d), uz(pool_top + 3 * d, pool_top + float(6 * depth) * d);
    std::uniform_int_distribution<int> size(1, 30);
    std::normal_distribution<float> offset(0.0f, 1.0f);
    while (out.size() < count) {
      const Vec3f c{ux(rng), ux(rng), uz(rng)};
      const int m = std::min<int>(size(rng), int(count - out.size()));
      // A droplet: m particles packed around c (a small lattice ball of the right count, so the
      // droplet has fluid spacing inside rather than overlapping particles).
      const float R = d * float(std::cbrt(3.0 * m / (4.0 * kPi))) + 0.5f * d;
      const int r = int(std::ceil(R / d));
      int placed = 0;
      for (int k = -r; k <= r && placed < m; ++k)
        for (int j = -r; j <= r && placed < m; ++j)
          for (int i = -r; i <= r && placed < m; ++i) {
            const Vec3f q{float(i) * d, float(j) * d, float(k) * d};
            if (length(q) > R) continue;
            out.push_back(c + q + Vec3f{offset(rng), offset(rng), offset(rng)} * (0.05f * d));
            ++placed;
          }
    }
  } else {
    throw std::invalid_argument("unknown scene '" + name + "' (block, sphere, splash)");
  }
  return s;
}

}  // namespace meniscus::bench
