// meniscus — mesh quality metrics (docs/cli.md "meniscus inspect").
#include "meniscus/quality.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numeric>
#include <numbers>

#include "common/primitives.hpp"
#include "grid/hash_grid.hpp"
#include "quality/triangle_bvh.hpp"
#include "mesh/volume_impl.hpp"

namespace meniscus {

namespace {

struct DirectedEdge {
  uint32_t lo, hi;  // undirected key
  uint32_t tri;
  bool forward;     // traversed lo → hi by this triangle
  bool operator<(const DirectedEdge& o) const { return lo != o.lo ? lo < o.lo : (hi != o.hi ? hi < o.hi : tri < o.tri); }
};

bool degenerate(const TriangleMesh& mesh, const Triangle& t) {
  if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) return true;
  const Vec3f a = mesh.vertices[t[0]], b = mesh.vertices[t[1]], c = mesh.vertices[t[2]];
  return length2(cross(b - a, c - a)) == 0.0f;
}

uint32_t find_root(std::vector<uint32_t>& parent, uint32_t x) {
  while (parent[x] != x) x = parent[x] = parent[parent[x]];
  return x;
}

}  // namespace

TopologyReport analyze_topology(const TriangleMesh& mesh) {
  TopologyReport r;
  const std::size_t nv = mesh.vertices.size(), nt = mesh.triangles.size();
  r.vertices = nv;
  r.triangles = nt;

  std::vector<DirectedEdge> edges;
  edges.reserve(nt * 3);
  std::vector<uint8_t> referenced(nv, 0);
  for (uint32_t f = 0; f < nt; ++f) {
    const Triangle& t = mesh.triangles[f];
    if (degenerate(mesh, t)) ++r.degenerate_triangles;
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = t[k], b = t[(k + 1) % 3];
      referenced[a] = 1;
      if (a == b) continue;
      edges.push_back({std::min(a, b), std::max(a, b), f, a < b});
    }
  }
  std::sort(edges.begin(), edges.end());

  // Components by shared edges (union-find over triangles).
  std::vector<uint32_t> parent(nt);
  std::iota(parent.begin(), parent.end(), 0u);
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    while (j < edges.size() && edges[j].lo == edges[i].lo && edges[j].hi == edges[i].hi) ++j;
    const std::size_t count = j - i;
    ++r.edges;
    if (count == 1) ++r.boundary_edges;
    if (count > 2) ++r.nonmanifold_edges;
    if (count == 2 && edges[i].forward == edges[i + 1].forward) ++r.misoriented_edges;
    for (auto it = edges.begin() + std::ptrdiff_t(i) + 1; it != edges.begin() + std::ptrdiff_t(j); ++it) {
      const uint32_t a = find_root(parent, edges[i].tri), b = find_root(parent, it->tri);
      if (a != b) parent[a] = b;
    }
    i = j;
  }
  for (uint32_t f = 0; f < nt; ++f)
    if (find_root(parent, f) == f) ++r.components;

  std::size_t used = 0;
  for (uint8_t u : referenced) used += u;
  r.unreferenced_vertices = nv - used;
  r.euler = (long long)used - (long long)r.edges + (long long)nt;

  // Vertex manifoldness: the triangles around a vertex must form one fan (connected through
  // edges incident to the vertex).
  std::vector<uint32_t> start(nv + 1, 0), incident(nt * 3);
  for (const Triangle& t : mesh.triangles)
    for (uint32_t v : t) ++start[v + 1];
  for (std::size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
  {
    std::vector<uint32_t> fill(start.begin(), start.end() - 1);
    for (uint32_t f = 0; f < nt; ++f)
      for (uint32_t v : mesh.triangles[f]) incident[fill[v]++] = f;
  }
  r.nonmanifold_vertices = reduce(
      nv, 1024, std::size_t(0),
      [&](std::size_t begin, std::size_t end, std::size_t acc) {
        std::vector<std::pair<uint32_t, uint32_t>> fan;  // (other vertex a, other vertex b) per triangle
        std::vector<uint32_t> local_parent;
        for (std::size_t v = begin; v != end; ++v) {
          const uint32_t b = start[v], e = start[v + 1];
          if (e - b <= 1) continue;
          // Union triangles of the fan that share an edge (v, w).
          fan.clear();
          for (uint32_t i = b; i < e; ++i) {
            const Triangle& t = mesh.triangles[incident[i]];
            const int k = t[0] == v ? 0 : (t[1] == v ? 1 : 2);
            fan.push_back({t[(k + 1) % 3], t[(k + 2) % 3]});
          }
          const uint32_t m = e - b;
          local_parent.resize(m);
          std::iota(local_parent.begin(), local_parent.end(), 0u);
          for (uint32_t i = 0; i < m; ++i)
            for (uint32_t j = i + 1; j < m; ++j) {
              const bool share = fan[i].first == fan[j].first || fan[i].first == fan[j].second ||
                                 fan[i].second == fan[j].first || fan[i].second == fan[j].second;
              if (share) {
                const uint32_t x = find_root(local_parent, i), y = find_root(local_parent, j);
                if (x != y) local_parent[x] = y;
              }
            }
          uint32_t roots = 0;
          for (uint32_t i = 0; i < m; ++i) roots += find_root(local_parent, i) == i;
          if (roots > 1) ++acc;
        }
        return acc;
      },
      std::plus<>());
  return r;
}

ValenceReport valence(const TriangleMesh& mesh) {
  std::vector<std::pair<uint32_t, uint32_t>> half;
  half.reserve(mesh.triangles.size() * 6);
  for (const Triangle& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = t[k], b = t[(k + 1) % 3];
      if (a == b) continue;
      half.push_back({a, b});
      half.push_back({b, a});
    }
  std::sort(half.begin(), half.end());
  half.erase(std::unique(half.begin(), half.end()), half.end());
  std::vector<int> val(mesh.vertices.size(), 0);
  for (const auto& h : half) ++val[h.first];

  ValenceReport r;
  r.min = INT32_MAX;
  std::size_t n = 0;
  double sum = 0;
  for (int v : val) {
    if (v == 0) continue;
    ++n;
    sum += v;
    r.min = std::min(r.min, v);
    r.max = std::max(r.max, v);
    if (v < 5) ++r.below_5;
    if (std::size_t(v) >= r.histogram.size()) r.histogram.resize(std::size_t(v) + 1, 0);
    ++r.histogram[std::size_t(v)];
  }
  if (n == 0) r.min = 0;
  r.mean = n ? sum / double(n) : 0;
  return r;
}

AngleReport triangle_angles(const TriangleMesh& mesh) {
  AngleReport r;
  r.min_degrees = 180;
  std::size_t below = 0, count = 0;
  for (const Triangle& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      const Vec3f p = mesh.vertices[t[k]];
      const Vec3f u = mesh.vertices[t[(k + 1) % 3]] - p, w = mesh.vertices[t[(k + 2) % 3]] - p;
      const double lu = length(u), lw = length(w);
      double angle = 0;
      if (lu > 0 && lw > 0)
        angle = std::acos(std::clamp(double(dot(u, w)) / (lu * lw), -1.0, 1.0)) * 180.0 / std::numbers::pi;
      r.min_degrees = std::min(r.min_degrees, angle);
      r.max_degrees = std::max(r.max_degrees, angle);
      below += angle < 10.0;
      ++count;
    }
  }
  if (count == 0) r.min_degrees = 0;
  r.share_below_10 = count ? double(below) / double(count) : 0;
  return r;
}

double signed_volume(const TriangleMesh& mesh) {
  double v = 0;
  for (const Triangle& t : mesh.triangles) v += signed_volume6(mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]]);
  return v / 6.0;
}

ConstraintReport constraint_residual(std::span<const Vec3f> vertices, std::span<const Vec3f> particles,
                                     double r_inner, double r_outer) {
  ConstraintReport r;
  if (vertices.empty() || particles.empty()) return r;
  const HashGrid grid(particles, float(std::max(r_outer, 1e-6)));
  struct Acc {
    double violation = 0, lo = INFINITY, hi = 0;
  };
  const Acc acc = reduce(
      vertices.size(), 1024, Acc{},
      [&](std::size_t begin, std::size_t end, Acc a) {
        for (std::size_t i = begin; i != end; ++i) {
          const double d = std::sqrt(double(grid.nearest(vertices[i]).dist2));
          a.lo = std::min(a.lo, d);
          a.hi = std::max(a.hi, d);
          a.violation = std::max({a.violation, r_inner - d, d - r_outer});
        }
        return a;
      },
      [](Acc a, const Acc& b) {
        a.violation = std::max(a.violation, b.violation);
        a.lo = std::min(a.lo, b.lo);
        a.hi = std::max(a.hi, b.hi);
        return a;
      });
  r.max_violation = acc.violation;
  r.min_distance = acc.lo;
  r.max_distance = acc.hi;
  return r;
}

PlaneFit fit_plane(std::span<const Vec3f> points) {
  PlaneFit fit;
  fit.count = points.size();
  if (points.size() < 3) return fit;
  double c[3] = {0, 0, 0};
  for (const Vec3f& p : points)
    for (int a = 0; a < 3; ++a) c[a] += p[a];
  for (double& v : c) v /= double(points.size());
  double m[3][3] = {};
  for (const Vec3f& p : points) {
    const double d[3] = {p.x - c[0], p.y - c[1], p.z - c[2]};
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) m[a][b] += d[a] * d[b];
  }
  // Smallest eigenvector by inverse-free Jacobi rotations on the symmetric 3×3 matrix.
  double v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int sweep = 0; sweep < 50; ++sweep) {
    const double off = m[0][1] * m[0][1] + m[0][2] * m[0][2] + m[1][2] * m[1][2];
    if (off < 1e-30) break;
    for (int p = 0; p < 2; ++p)
      for (int q = p + 1; q < 3; ++q) {
        if (std::abs(m[p][q]) < 1e-300) continue;
        const double theta = (m[q][q] - m[p][p]) / (2 * m[p][q]);
        const double t = (theta >= 0 ? 1 : -1) / (std::abs(theta) + std::sqrt(theta * theta + 1));
        const double cs = 1 / std::sqrt(t * t + 1), sn = t * cs;
        for (int k = 0; k < 3; ++k) {  // m = Jᵀ m J
          const double mkp = m[k][p], mkq = m[k][q];
          m[k][p] = cs * mkp - sn * mkq;
          m[k][q] = sn * mkp + cs * mkq;
        }
        for (int k = 0; k < 3; ++k) {
          const double mpk = m[p][k], mqk = m[q][k];
          m[p][k] = cs * mpk - sn * mqk;
          m[q][k] = sn * mpk + cs * mqk;
        }
        for (int k = 0; k < 3; ++k) {
          const double vkp = v[k][p], vkq = v[k][q];
          v[k][p] = cs * vkp - sn * vkq;
          v[k][q] = sn * vkp + cs * vkq;
        }
      }
  }
  int smallest = 0;
  for (int a = 1; a < 3; ++a)
    if (m[a][a] < m[smallest][smallest]) smallest = a;
  const Vec3f n = normalized(Vec3f{float(v[0][smallest]), float(v[1][smallest]), float(v[2][smallest])});
  fit.normal = n;
  fit.centroid = {float(c[0]), float(c[1]), float(c[2])};
  double sum2 = 0;
  for (const Vec3f& p : points) {
    const double d = (p.x - c[0]) * n.x + (p.y - c[1]) * n.y + (p.z - c[2]) * n.z;
    sum2 += d * d;
    fit.max_abs = std::max(fit.max_abs, std::abs(d));
  }
  fit.rms = std::sqrt(sum2 / double(points.size()));
  return fit;
}

double mean_edge_length(const TriangleMesh& mesh) {
  const auto& v = mesh.vertices;
  const double sum = deterministic_reduce(  // the same sum on any number of threads
      mesh.triangles.size(), 4096, 0.0,
      [&](std::size_t begin, std::size_t end, double s) {
        for (std::size_t i = begin; i != end; ++i) {
          const Triangle& t = mesh.triangles[i];
          s += double(length(v.at(t[0]) - v.at(t[1]))) + length(v.at(t[1]) - v.at(t[2])) + length(v.at(t[2]) - v.at(t[0]));
        }
        return s;
      },
      std::plus<>());
  return mesh.triangles.empty() ? 0.0 : sum / (3.0 * double(mesh.triangles.size()));
}

double least_triangles_within(const TriangleMesh& mesh, double bound) {
  const std::size_t nv = mesh.vertices.size();
  if (!(bound > 0) || mesh.triangles.empty()) return 0;
  // Each vertex's angle sum and a third of its triangles' area; its neighbours by directed edge
  // (each once on a closed mesh); a vertex on a border edge (one with no twin) is left out.
  std::vector<double> angle(nv, 0), area(nv, 0);
  std::vector<std::pair<uint32_t, uint32_t>> edges;
  edges.reserve(3 * mesh.triangles.size());
  for (const Triangle& t : mesh.triangles) {
    const Vec3f p[3] = {mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]]};
    const double a = 0.5 * double(length(cross(p[1] - p[0], p[2] - p[0])));
    for (std::size_t k = 0; k < 3; ++k) {
      const Vec3f e = p[(k + 1) % 3] - p[k], f = p[(k + 2) % 3] - p[k];
      const double l = std::sqrt(double(length2(e)) * double(length2(f)));
      if (l > 0) angle[t[k]] += std::acos(std::clamp(double(dot(e, f)) / l, -1.0, 1.0));
      area[t[k]] += a / 3;
      edges.push_back({t[k], t[(k + 1) % 3]});
    }
  }
  std::sort(edges.begin(), edges.end());
  std::vector<uint8_t> border(nv, 0);
  for (const auto& [u, v] : edges)
    if (!std::binary_search(edges.begin(), edges.end(), std::pair{v, u})) border[u] = border[v] = 1;
  std::vector<double> d(nv, 0), a = area;  // the angle defects and areas, summed over the rings
  for (std::size_t v = 0; v < nv; ++v)
    if (area[v] > 0 && !border[v]) d[v] = 2 * std::numbers::pi - angle[v];
  for (int ring = 0; ring < 2; ++ring) {
    std::vector<double> dn = d, an = a;
    for (const auto& [u, v] : edges) dn[u] += d[v], an[u] += a[v];
    d.swap(dn), a.swap(an);
  }
  double integral = 0;  // ∫_{K>0} √K dA
  for (std::size_t v = 0; v < nv; ++v)
    if (!border[v] && d[v] > 0 && a[v] > 0) integral += area[v] * std::sqrt(d[v] / a[v]);
  return integral / (3 * std::sqrt(3.0) * bound);
}

std::size_t points_outside(const TriangleMesh& mesh, std::span<const Vec3f> points) {
  if (mesh.triangles.empty()) return points.size();
  const TriangleBvh bvh(mesh.vertices, mesh.triangles);
  return reduce(
      points.size(), 256, std::size_t(0),
      [&](std::size_t begin, std::size_t end, std::size_t outside) {
        for (std::size_t i = begin; i != end; ++i) outside += !bvh.inside(points[i]);
        return outside;
      },
      std::plus<>());
}

}  // namespace meniscus
