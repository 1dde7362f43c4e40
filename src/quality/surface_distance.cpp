// meniscus — point-to-surface distance (frame-to-frame flicker, docs/cli.md "Sequences"): closest points on
// triangles (Ericson 2005 §5.1.5) found through Embree's BVH (quality/triangle_bvh.hpp).
#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <random>
#include <stdexcept>

#include "common/for_each.hpp"
#include "common/primitives.hpp"
#include "meniscus/quality.hpp"
#include "quality/triangle_bvh.hpp"

namespace meniscus {
namespace {

struct Box {
  Vec3f lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
};

Box bounds(std::span<const Vec3f> points) {
  return reduce(
      points.size(), 1 << 14, Box{},
      [&](std::size_t begin, std::size_t end, Box b) {
        for (std::size_t i = begin; i != end; ++i) b.lo = min(b.lo, points[i]), b.hi = max(b.hi, points[i]);
        return b;
      },
      [](Box a, const Box& b) { return Box{min(a.lo, b.lo), max(a.hi, b.hi)}; });
}

/// The triangles of `surface` whose bounding boxes reach into `box`: with a cap, the only ones a
/// query from inside the box (grown by the cap) can find. One pass over the triangles, so the
/// BVH costs what the part of the surface near the points costs, not the whole previous frame
/// (one droplet after a full frame builds a BVH of a few triangles). Returns false, and leaves
/// `kept` empty, when every triangle is near (no copy then).
bool triangles_near(const TriangleMesh& surface, const Box& box, std::vector<Triangle>& kept) {
  const auto& v = surface.vertices;
  const auto& t = surface.triangles;
  const auto near = [&](std::size_t i) {
    if (std::max({t[i][0], t[i][1], t[i][2]}) >= v.size())
      throw std::invalid_argument(fmt::format("distance_to_surface: triangle {} names a vertex past the {} vertices", i, v.size()));
    const Vec3f lo = min(min(v[t[i][0]], v[t[i][1]]), v[t[i][2]]), hi = max(max(v[t[i][0]], v[t[i][1]]), v[t[i][2]]);
    return lo.x <= box.hi.x && lo.y <= box.hi.y && lo.z <= box.hi.z && hi.x >= box.lo.x && hi.y >= box.lo.y &&
           hi.z >= box.lo.z;
  };
  std::vector<std::size_t> offsets;
  const std::size_t count = chunk_offsets(t.size(), near, offsets);
  if (count == t.size()) return false;
  kept.resize(count);
  for_each_set(t.size(), near, offsets, [&](std::size_t i, std::size_t rank) { kept[rank] = t[i]; });
  return true;
}

}  // namespace

std::vector<Vec3f> random_surface_points(const TriangleMesh& mesh, std::size_t count, uint32_t seed) {
  std::vector<Vec3f> points;
  if (mesh.triangles.empty()) return points;
  std::vector<double> area(mesh.triangles.size());
  for (std::size_t t = 0; t < area.size(); ++t) {
    const Triangle& c = mesh.triangles[t];
    area[t] =
        double(length(cross(mesh.vertices[c[1]] - mesh.vertices[c[0]], mesh.vertices[c[2]] - mesh.vertices[c[0]])));
  }
  std::mt19937 rng(seed);
  std::discrete_distribution<std::size_t> pick(area.begin(), area.end());
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  points.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const Triangle& c = mesh.triangles[pick(rng)];
    float u = unit(rng), v = unit(rng);
    if (u + v > 1) u = 1 - u, v = 1 - v;  // the parallelogram's far half folded onto the triangle
    const Vec3f a = mesh.vertices[c[0]];
    points.push_back(a + (mesh.vertices[c[1]] - a) * u + (mesh.vertices[c[2]] - a) * v);
  }
  return points;
}

SurfaceDistanceReport distance_to_surface(std::span<const Vec3f> points, const TriangleMesh& surface, double cap) {
  SurfaceDistanceReport report;
  report.cap = cap;
  if (points.empty() || surface.triangles.empty()) return report;
  report.count = points.size();
  const float reach = cap < double(INFINITY) ? float(cap) : INFINITY;
  std::vector<Triangle> near;
  std::span<const Triangle> searched = surface.triangles;
  if (reach < INFINITY) {
    Box box = bounds(points);
    box.lo -= Vec3f{reach, reach, reach}, box.hi += Vec3f{reach, reach, reach};
    if (triangles_near(surface, box, near)) searched = near;
  }
  const TriangleBvh bvh(surface.vertices, searched);
  std::vector<float> dist(points.size());
  std::atomic<std::size_t> tests{0}, beyond{0};
  for_each_chunk(points.size(), 1024, [&](std::size_t begin, std::size_t end) {
    std::size_t t = 0, b = 0;
    for (std::size_t i = begin; i != end; ++i) {
      // Warm start: the distance to a surface changes by at most the step between two points, so
      // the previous point's distance plus the step bounds this one's (with a little slack for
      // rounding). The query starts at that radius instead of the cap; our vertices are in cell
      // order, so the step is usually a fraction of the spacing.
      float start = reach;
      if (i != begin && dist[i - 1] < reach)
        start = std::min(reach, (dist[i - 1] + length(points[i] - points[i - 1])) * (1 + 1e-5f) + 1e-30f);
      TriangleBvh::Closest c = bvh.closest(points[i], start);
      if (c.triangle == UINT32_MAX && start < reach) {  // only when rounding beat the slack
        t += c.triangle_tests;
        c = bvh.closest(points[i], reach);
      }
      t += c.triangle_tests;
      if (c.triangle == UINT32_MAX) {
        dist[i] = reach;  // nothing within the cap: counted at the cap
        ++b;
      } else {
        dist[i] = c.distance;
      }
    }
    tests += t;
    beyond += b;
  });
  report.triangle_tests = tests;
  report.beyond_cap = beyond;
  // The statistics in double, with the cap itself (not its float) for the points beyond it.
  double sum = 0;
  for (float d : dist) sum += std::min(double(d), cap), report.max = std::max(report.max, std::min(double(d), cap));
  report.mean = sum / double(dist.size());
  auto q = dist.begin() + std::ptrdiff_t(double(dist.size() - 1) * 0.95);
  std::nth_element(dist.begin(), q, dist.end());
  report.p95 = std::min(double(*q), cap);
  return report;
}

JitterReport surface_jitter(const TriangleMesh& previous, const TriangleMesh& current, const TriangleMesh& next,
                            std::size_t count, uint32_t seed, double cap) {
  JitterReport report;
  if (previous.triangles.empty() || current.triangles.empty() || next.triangles.empty()) return report;
  const std::vector<Vec3f> points = random_surface_points(current, count, seed);
  const float reach = cap < double(INFINITY) ? float(cap) : INFINITY;
  const TriangleBvh before(previous.vertices, previous.triangles), after(next.vertices, next.triangles);
  // Per point, |s₋ + s₊| / 2, or NaN when either surface lies beyond the cap.
  std::vector<float> jitter(points.size());
  for_each_index(points.size(), 256, [&](std::size_t i) {
    const TriangleBvh::Closest b = before.closest(points[i], reach), a = after.closest(points[i], reach);
    if (b.triangle == UINT32_MAX || a.triangle == UINT32_MAX) {
      jitter[i] = NAN;
      return;
    }
    // The sign from the closest triangle's plane (outward normals): exact where the closest point
    // lies inside the triangle, and at an edge or corner off only for points farther from the
    // surface than its bend, which the median does not see.
    const auto side = [&](const TriangleMesh& m, uint32_t t, float distance) {
      const Triangle& c = m.triangles[t];
      const Vec3f a0 = m.vertices[c[0]];
      const Vec3f n = cross(m.vertices[c[1]] - a0, m.vertices[c[2]] - a0);
      return dot(points[i] - a0, n) < 0 ? -distance : distance;
    };
    const float s_before = side(previous, b.triangle, b.distance), s_after = side(next, a.triangle, a.distance);
    jitter[i] = std::fabs(s_before + s_after) / 2;
  });
  const auto end = std::remove_if(jitter.begin(), jitter.end(), [](float j) { return std::isnan(j); });
  report.beyond_cap = std::size_t(jitter.end() - end);
  jitter.erase(end, jitter.end());
  report.points = jitter.size();
  if (jitter.empty()) return report;
  const auto at = [&](double q) {
    const auto k = jitter.begin() + std::ptrdiff_t(double(jitter.size() - 1) * q);
    std::nth_element(jitter.begin(), k, jitter.end());
    return double(*k);
  };
  report.median = at(0.5);
  report.p90 = at(0.9);
  return report;
}

}  // namespace meniscus
