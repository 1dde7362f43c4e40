// meniscus — bridges across pinholes in thin water (pinholes.hpp).
#include "grid/pinholes.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <mutex>
#include <numbers>
#include <tuple>

#include "common/for_each.hpp"
#include "field/eigen_sym3_impl.hpp"
#include "grid/hash_grid.hpp"
#include "grid/key_index.hpp"

namespace meniscus {

namespace {

/// The most particles a probe looks at: more within the reach means dense water, no hole.
constexpr int kMaxRing = 64;

struct Candidate {
  int64_t cube[3];   ///< the cube of edge r_outer/2 the bridge falls in (x, y, z)
  int64_t probe[3];  ///< the probe's lattice coordinates (z, y, x): the first one wins a cube
  Vec3f bridge;
};

/// The bridge the probe at `x` asks for, if any (pinholes.hpp).
/// x is outside every outer ball: `around` holds every particle within reach + plane tolerance of
/// it (and maybe more).
bool probe_bridge(const HashGrid& grid, const PinholeSettings& s, std::span<const Vec3f> around, Vec3f x, Vec3f* out) {
  const float r = s.r_outer, search = s.reach + s.plane_tolerance;
  Vec3f near[kMaxRing];
  int n = 0;
  float phi2 = INFINITY;
  for (const Vec3f& p : around) {
    const float d2 = length2(p - x);
    if (d2 > search * search) continue;
    if (n == kMaxRing) return false;  // too many round it to be a hole
    phi2 = std::min(phi2, d2);
    near[n++] = p;
  }
  if (n < 3 || phi2 > s.reach * s.reach) return false;
  // Particles round x on every side average to a short mean direction; a point beside the water
  // (above a surface, in a groove) sees them all on one side. A cheap test before the plane's.
  Vec3f mean{0, 0, 0};
  for (int k = 0; k < n; ++k) mean = mean + normalized(near[k] - x);
  if (length2(mean) > 0.36f * float(n) * float(n)) return false;  // |mean direction| > 0.6
  // The least-squares plane of the particles through x: its normal is the scatter's weakest axis.
  double m[3][3] = {};
  for (int k = 0; k < n; ++k) {
    const Vec3f q = near[k] - x;
    const double c[3] = {q.x, q.y, q.z};
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) m[a][b] += c[a] * c[b];
  }
  const Eigen3<double> e = eigen_sym3(m);
  const Vec3f normal = normalized(Vec3f{float(e.vectors[2][0]), float(e.vectors[2][1]), float(e.vectors[2][2])});
  const Vec3f u = normalized(std::fabs(normal.x) < 0.9f ? cross(normal, Vec3f{1, 0, 0}) : cross(normal, Vec3f{0, 1, 0}));
  const Vec3f v = cross(normal, u);
  // The ring: the particles near that plane, by their angle round x.
  struct Spoke {
    float angle;
    Vec3f p;
  };
  Spoke ring[kMaxRing];
  int k = 0;
  Vec3f centre{0, 0, 0};
  for (int i = 0; i < n; ++i) {
    const Vec3f q = near[i] - x;
    if (std::fabs(dot(q, normal)) > s.plane_tolerance) continue;
    ring[k++] = {std::atan2(dot(q, v), dot(q, u)), near[i]};
    centre = centre + near[i];
  }
  if (k < 3) return false;
  std::sort(ring, ring + k, [](const Spoke& a, const Spoke& b) { return a.angle < b.angle; });
  const float max_gap = s.max_gap_degrees * float(std::numbers::pi / 180.0), touch2 = 4 * r * r;
  for (int i = 0; i < k; ++i) {
    const Spoke& a = ring[i];
    const Spoke& b = ring[(i + 1) % k];
    const float gap = i + 1 < k ? b.angle - a.angle : b.angle + 2 * float(std::numbers::pi) - a.angle;
    if (gap > max_gap || length2(b.p - a.p) > touch2) return false;
  }
  // The bridge: x brought onto the ring's mean plane.
  centre = centre / float(k);
  const Vec3f g = x - normal * dot(x - centre, normal);
  // It must not sit on a particle (the hole's middle is well outside them) nor touch a particle
  // that the ring does not touch (which would join what was apart).
  bool ok = true;
  grid.for_each_in_cells_of_box(g - Vec3f{2 * r, 2 * r, 2 * r}, g + Vec3f{2 * r, 2 * r, 2 * r}, [&](uint32_t i) {
    const Vec3f q = grid.point(i);
    const float d2 = length2(q - g);
    if (d2 > touch2) return true;
    if (d2 < 0.64f * r * r) return ok = false;
    for (int j = 0; j < k; ++j)
      if (length2(q - ring[j].p) <= touch2) return true;
    return ok = false;
  });
  if (!ok) return false;
  *out = g;
  return true;
}

}  // namespace

PinholeSettings pinhole_settings(double spacing, double r_outer) {
  PinholeSettings s;
  s.r_outer = float(r_outer);
  s.reach = float(1.2 * spacing);
  s.plane_tolerance = float(0.6 * spacing);
  s.probe_step = float(0.3 * spacing);
  s.max_gap_degrees = 150;
  return s;
}

double pinhole_reach(const PinholeSettings& s) {
  // A probe reads the 27 cells (of edge reach + plane tolerance) round its own, up to 2√3 cells
  // away (the merge test's 2·r_outer round the bridge lies within them); its bridge lies within
  // the plane tolerance of it, in a cube (of edge r_outer/2) whose first probe wins.
  const double cell = double(s.reach) + double(s.plane_tolerance);
  return 2.0 * std::sqrt(3.0) * cell + double(s.plane_tolerance) + 0.5 * std::sqrt(3.0) * double(s.r_outer) / 2.0;
}

std::vector<Vec3f> pinhole_bridges(std::span<const Vec3f> points, const PinholeSettings& s) {
  if (points.size() < 3 || !(s.r_outer > 0) || !(s.probe_step > 0)) return {};
  // Cells of edge reach + plane tolerance: the particles a probe looks at lie in the 27 cells
  // round its own, gathered once for the probes of a cell.
  const float cell = s.reach + s.plane_tolerance;
  const HashGrid grid(points, cell);
  // The cells a hole's probes may lie in: the occupied ones and their empty neighbours (only the
  // water's edge has those, so the list stays about as long as the occupied cells').
  std::vector<uint64_t> cells(grid.cell_keys().begin(), grid.cell_keys().end());
  for (const uint64_t key : grid.cell_keys()) {
    const Vec3i c = unpack_coords(key);
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const Vec3i n{c.x + dx, c.y + dy, c.z + dz};
          const auto range = grid.cell_range(n);
          if (range.first == range.second) cells.push_back(pack_coords(n.x, n.y, n.z));
        }
  }
  std::sort(cells.begin(), cells.end());
  cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
  // The candidates, in any order (sorted below): the few cells that find any append them.
  std::vector<Candidate> all;
  std::mutex appending;
  const double h = s.probe_step, cube = 0.5 * double(s.r_outer);
  const float r2 = s.r_outer * s.r_outer, reach2 = s.reach * s.reach;
  for_each_index(cells.size(), 64, [&](std::size_t ci) {
    const Vec3i c = unpack_coords(cells[ci]);
    // The particles a probe of this cell may read, its own cell's first. A cell with water in all
    // 27 round it lies deep in the water, 1.8 d or more from any empty cell: a pinhole's sheet has
    // empty cells on both sides.
    std::vector<Vec3f> cover;
    int empty = 0;
    {
      const auto own = grid.cell_range(c);
      empty += own.first == own.second;
      for (uint32_t i = own.first; i < own.second; ++i) cover.push_back(grid.point(i));
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            if (dx == 0 && dy == 0 && dz == 0) continue;
            const auto range = grid.cell_range(Vec3i{c.x + dx, c.y + dy, c.z + dz});
            empty += range.first == range.second;
            for (uint32_t i = range.first; i < range.second; ++i) cover.push_back(grid.point(i));
          }
    }
    if (cover.empty() || empty == 0) return;  // far from all, or deep in the water: no hole's middle
    std::size_t last = 0;
    // The cell in 3×3×3 parts: a part whose every point is within r_outer of a particle, or whose
    // every point is farther than reach from all, has no probe to test.
    const float part = cell / 3, half_diagonal = part * 0.8660254f;
    const Vec3f origin = Vec3f{float(c.x), float(c.y), float(c.z)} * cell;
    bool skip[27];
    for (int k = 0; k < 27; ++k) {
      const Vec3f mid = origin + Vec3f{float(k % 3) + 0.5f, float(k / 3 % 3) + 0.5f, float(k / 9) + 0.5f} * part;
      float nearest2 = INFINITY;
      for (const Vec3f& p : cover) nearest2 = std::min(nearest2, length2(p - mid));
      const float nearest = std::sqrt(nearest2);
      skip[k] = nearest + half_diagonal <= s.r_outer || nearest - half_diagonal > s.reach;
    }
    auto part_of = [&](float v, float o) { return std::clamp(int((v - o) / part), 0, 2); };
    // The probes k·h with floor(k·h / cell) = c on each axis (half-open, so each probe is in one cell).
    int64_t lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = int64_t(std::ceil(double(c[a]) * cell / h));
      hi[a] = int64_t(std::ceil(double(c[a] + 1) * cell / h));
    }
    std::vector<Candidate> found;
    for (int64_t z = lo[2]; z < hi[2]; ++z)
      for (int64_t y = lo[1]; y < hi[1]; ++y)
        for (int64_t x = lo[0]; x < hi[0]; ++x) {
          const Vec3f at{float(double(x) * h), float(double(y) * h), float(double(z) * h)};
          if (!(grid.cell_of(at) == c)) continue;  // rounding at a cell wall: the neighbour has it
          if (skip[part_of(at.x, origin.x) + 3 * part_of(at.y, origin.y) + 9 * part_of(at.z, origin.z)]) continue;
          // Covered (within r_outer of a particle: most probes, and mostly by the particle that
          // covered the probe before), or farther than reach from every particle?
          if (length2(cover[last] - at) <= r2) continue;
          float phi2 = INFINITY;
          for (std::size_t k = 0; k < cover.size() && phi2 > r2; ++k) {
            const float d2 = length2(cover[k] - at);
            if (d2 < phi2) phi2 = d2, last = k;
          }
          if (phi2 <= r2 || phi2 > reach2) continue;
          Vec3f g;
          if (!probe_bridge(grid, s, cover, at, &g)) continue;
          found.push_back({{int64_t(std::floor(double(g.x) / cube)), int64_t(std::floor(double(g.y) / cube)),
                                int64_t(std::floor(double(g.z) / cube))},
                               {z, y, x},
                               g});
        }
    if (!found.empty()) {
      const std::lock_guard<std::mutex> lock(appending);
      all.insert(all.end(), found.begin(), found.end());
    }
  });
  std::sort(all.begin(), all.end(), [](const Candidate& a, const Candidate& b) {
    return std::tie(a.cube[0], a.cube[1], a.cube[2], a.probe[0], a.probe[1], a.probe[2]) <
           std::tie(b.cube[0], b.cube[1], b.cube[2], b.probe[0], b.probe[1], b.probe[2]);
  });
  std::vector<Vec3f> bridges;
  for (std::size_t i = 0; i < all.size(); ++i)
    if (i == 0 || !std::equal(all[i].cube, all[i].cube + 3, all[i - 1].cube)) bridges.push_back(all[i].bridge);
  return bridges;
}

}  // namespace meniscus
