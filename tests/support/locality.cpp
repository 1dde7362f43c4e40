#include "support/locality.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <random>
#include <cstdio>
#include <unordered_set>

#include "meniscus/reconstruct.hpp"

#include "support/test_support.hpp"

namespace meniscus::test {
namespace {

struct BitHash {
  std::size_t operator()(const Vec3f& v) const {
    uint32_t a[3];
    std::memcpy(a, &v, sizeof a);
    return (std::size_t(a[0]) * 0x9E3779B97F4A7C15ull) ^ (std::size_t(a[1]) * 0xC2B2AE3D27D4EB4Full) ^ a[2];
  }
};
struct BitEqual {
  bool operator()(const Vec3f& a, const Vec3f& b) const { return std::memcmp(&a, &b, sizeof a) == 0; }
};

}  // namespace

ParticleSet with_particles(const ParticleSet& base, std::span<const Vec3f> positions) {
  ParticleSet out = base;
  for (const Vec3f& p : positions) {
    out.positions.push_back(p);
    for (Attribute& a : out.attributes)
      for (int c = 0; c < a.components; ++c) a.values.push_back(a.values[std::size_t(c)]);
  }
  return out;
}

ParticleSet without_particles(const ParticleSet& base, std::span<const std::size_t> indices) {
  ParticleSet out = base;
  out.positions.clear();
  for (Attribute& a : out.attributes) a.values.clear();
  std::size_t next = 0;
  for (std::size_t i = 0; i < base.size(); ++i) {
    if (next < indices.size() && indices[next] == i) {
      ++next;
      continue;
    }
    out.positions.push_back(base.positions[i]);
    for (std::size_t k = 0; k < out.attributes.size(); ++k) {
      const Attribute& from = base.attributes[k];
      for (int c = 0; c < from.components; ++c)
        out.attributes[k].values.push_back(from.values[i * std::size_t(from.components) + std::size_t(c)]);
    }
  }
  return out;
}

std::vector<FrameChange> frame_changes(const ParticleSet& base, double d, double reach) {
  const float df = float(d);
  Vec3f lo = base.positions[0], hi = lo;
  std::size_t low_x = 0, high_x = 0, top = 0;
  for (std::size_t i = 0; i < base.size(); ++i) {
    const Vec3f& p = base.positions[i];
    lo = min(lo, p), hi = max(hi, p);
    if (p.x < base.positions[low_x].x) low_x = i;
    if (p.x > base.positions[high_x].x) high_x = i;
    if (p.z > base.positions[top].z) top = i;
  }
  std::vector<FrameChange> changes;
  {
    const Vec3f far = hi + Vec3f{float(reach) + 2 * df, 0, 0};
    changes.push_back({"a particle beyond R_local", with_particles(base, std::vector{far}), {far}});
  }
  {
    const Vec3f p = base.positions[low_x] - Vec3f{1.5f * df, 0, 0};
    changes.push_back({"a particle joining the low-x end", with_particles(base, std::vector{p}), {p}});
  }
  {
    std::vector<Vec3f> drop;
    const Vec3f corner = base.positions[high_x] + Vec3f{1.5f * df, -df, -0.5f * df};
    for (int k = 0; k < 2; ++k)
      for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 3; ++i) drop.push_back(corner + Vec3f{float(i), float(j), float(k)} * df);
    drop.push_back(corner + Vec3f{1, 1, 2} * df);
    drop.push_back(corner + Vec3f{1, 1, -1} * df);
    changes.push_back({"a droplet of 20 particles at the high-x end", with_particles(base, drop), drop});
  }
  {
    std::vector<std::size_t> order(base.size());
    std::iota(order.begin(), order.end(), std::size_t(0));
    const Vec3f t = base.positions[top];
    const std::size_t n = std::min<std::size_t>(40, base.size() / 4);
    std::partial_sort(order.begin(), order.begin() + std::ptrdiff_t(n), order.end(), [&](std::size_t a, std::size_t b) {
      return length2(base.positions[a] - t) < length2(base.positions[b] - t);
    });
    std::vector<std::size_t> removed(order.begin(), order.begin() + std::ptrdiff_t(n));
    std::sort(removed.begin(), removed.end());
    std::vector<Vec3f> at;
    for (std::size_t i : removed) at.push_back(base.positions[i]);
    changes.push_back({"a splash of 40 particles removed at the top", without_particles(base, removed), at});
  }
  return changes;
}

LocalityReport compare_locally(const TriangleMesh& before, const TriangleMesh& after, std::span<const Vec3f> changed,
                               double reach) {
  const std::unordered_set<Vec3f, BitHash, BitEqual> kept(after.vertices.begin(), after.vertices.end());
  const double r2 = reach * reach;
  LocalityReport r;
  for (const Vec3f& v : before.vertices) {
    double nearest2 = INFINITY;
    for (const Vec3f& c : changed) nearest2 = std::min(nearest2, double(length2(v - c)));
    const bool near = nearest2 <= r2, same = kept.count(v) != 0;
    if (!same) r.farthest_changed = std::max(r.farthest_changed, std::sqrt(nearest2));
    if (near) {
      ++r.near;
      r.near_changed += !same;
    } else {
      ++r.region;
      r.region_changed += !same;
    }
  }
  return r;
}

Params variant_params(Variant v) {
  Params p;
  if (v == Variant::anisotropic) p.field = FieldMethod::anisotropic;
  if (v == Variant::cubes) p.extract = Extractor::cubes;
  return p;
}

const char* to_string(Variant v) {
  return v == Variant::standard ? "default" : v == Variant::anisotropic ? "anisotropic" : "cubes";
}

std::size_t expect_local(const std::string& label, const ParticleSet& base, const Params& p,
                         const std::vector<FrameChange>& changes, double reach) {
  const Result before = reconstruct(base, p);
  std::size_t region = 0;
  for (const FrameChange& c : changes) {
    const Result after = reconstruct(c.particles, p);
    EXPECT_EQ(after.stats.backend, before.stats.backend);
    const LocalityReport r = compare_locally(before.mesh, after.mesh, c.changed, reach);
    std::printf("%s on the %s, %s: %zu of %zu near vertices moved, the farthest %.1f d away; %zu region vertices\n",
                label.c_str(), before.stats.backend.c_str(), c.what.c_str(), r.near_changed, r.near,
                r.farthest_changed / p.spacing, r.region);
    EXPECT_EQ(r.region_changed, 0u) << label << ", " << c.what << ": of " << r.region
                                    << " vertices farther than R_local, some moved (the farthest change "
                                    << r.farthest_changed / p.spacing << " d away)";
    if (r.near > 0) {
      EXPECT_GT(r.near_changed, 0u) << label << ", " << c.what << ": nothing changed near the change";
    }
    region += r.region;
  }
  return region;
}

SplashScene synthetic_splash() {
  SplashScene s;
  const float d = s.d;
  s.particles = lattice_block(100, 16, 4, d, 0.1f, 7);
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> jitter(-0.1f * d, 0.1f * d);
  const auto add = [&](Vec3f p) {
    s.particles.positions.push_back(p + Vec3f{jitter(rng), jitter(rng), jitter(rng)});
    ++s.splash_count;
  };
  // The column: 3 × 3 particles rising from the water's surface (z = 3d) to 8 d above it.
  for (int k = 4; k <= 11; ++k)
    for (int j = 6; j <= 8; ++j)
      for (int i = 2; i <= 4; ++i) add(Vec3f{float(i), float(j), float(k)} * d);
  // Droplets of 1–4 particles thrown beyond it, each 3 d or more from the others.
  for (int n = 0; n < 8; ++n) {
    const Vec3f c = Vec3f{float(1 + 2 * (n % 4)), float(4 + 6 * (n / 4)), float(14 + 3 * (n % 3))} * d;
    for (int m = 0; m <= n % 4; ++m) add(c + Vec3f{float(m % 2), float(m / 2), 0} * d);
  }
  return s;
}

}  // namespace meniscus::test
