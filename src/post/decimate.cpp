// meniscus — simplification under a measured error bound (post/decimate.hpp).
#include "post/decimate.hpp"

#include <meshoptimizer.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <mutex>
#include <unordered_map>
#include <vector>

#include "common/for_each.hpp"
#include "mesh/compact.hpp"
#include "mesh/components.hpp"
#include "mesh/directed_edges.hpp"
#include "quality/triangle_bvh.hpp"

namespace meniscus {

namespace {

/// meshopt_simplify over `triangles` (the mesh's vertex array, borders locked) down to the
/// relative error `error`; no target count, so the error alone stops it.
std::vector<Triangle> simplify(const std::vector<Vec3f>& x, const std::vector<Triangle>& triangles, float error) {
  static_assert(sizeof(Triangle) == 3 * sizeof(unsigned) && sizeof(Vec3f) == 3 * sizeof(float));
  std::vector<Triangle> out(triangles.size());
  const std::size_t indices =
      meshopt_simplify(reinterpret_cast<unsigned*>(out.data()), reinterpret_cast<const unsigned*>(triangles.data()),
                       3 * triangles.size(), &x[0].x, x.size(), sizeof(Vec3f), 0, error, meshopt_SimplifyLockBorder, nullptr);
  out.resize(indices / 3);
  return out;
}

/// The vertex → triangle incidences of a mesh (compressed rows).
struct Incidence {
  std::vector<uint32_t> first, triangles;
  Incidence(std::size_t vertex_count, const std::vector<Triangle>& mesh) : first(vertex_count + 1, 0) {
    for (const Triangle& t : mesh)
      for (uint32_t v : t) ++first[v + 1];
    for (std::size_t v = 0; v < vertex_count; ++v) first[v + 1] += first[v];
    triangles.resize(first[vertex_count]);
    std::vector<uint32_t> at(first.begin(), first.end() - 1);
    for (std::size_t t = 0; t < mesh.size(); ++t)
      for (uint32_t v : mesh[t]) triangles[at[v]++] = uint32_t(t);
  }
};

/// The corners after and before v in triangle t.
std::pair<uint32_t, uint32_t> neighbours(uint32_t v, const Triangle& t) {
  const int k = t[0] == v ? 0 : (t[1] == v ? 1 : 2);
  return {t[std::size_t((k + 1) % 3)], t[std::size_t((k + 2) % 3)]};
}

/// Whether the triangles around v form one fan: walking from one of them to the next across the
/// edges they share (the next one's corner after v is this one's corner before v), both ways
/// where the fan is open, visits them all.
bool single_fan(uint32_t v, const Incidence& around, const std::vector<Triangle>& triangles) {
  const uint32_t first = around.first[v], count = around.first[v + 1] - first;
  if (count <= 1) return true;
  const auto step = [&](uint32_t t, bool forward) {  // the next triangle around v, or UINT32_MAX
    const auto [after, before] = neighbours(v, triangles[t]);
    for (uint32_t k = first; k < first + count; ++k) {
      const auto [a, b] = neighbours(v, triangles[around.triangles[k]]);
      if (forward ? a == before : b == after) return around.triangles[k];
    }
    return UINT32_MAX;
  };
  const uint32_t start = around.triangles[first];
  uint32_t seen = 1, t = start;
  while (seen <= count && (t = step(t, true)) != UINT32_MAX && t != start) ++seen;
  if (t == UINT32_MAX)  // an open fan: the other way too
    for (t = start; seen <= count && (t = step(t, false)) != UINT32_MAX;) ++seen;
  return seen == count;
}

/// The share of the bound the check's points may use: they are points, the bound holds between
/// surfaces, and the distance between two points of the triangles can exceed the distances at the
/// points around them (measured independently on the bundled frames at 0.02 d: up to 13 % above
/// the check's largest; a check at 0.9 let one frame past the bound).
constexpr double kMargin = 0.8;

/// One region of the mesh simplified on its own, in its own vertex numbering: the base mesh's
/// triangles whose centroids fall in one cell of a grid. Its open edges (the cell's seams, and any
/// border of the mesh) are locked, so the regions' results fit together as they are.
struct Patch {
  std::vector<uint32_t> global;     ///< local vertex → mesh vertex (sorted)
  std::vector<Vec3f> x;             ///< positions, local
  std::vector<uint32_t> root;       ///< component root (mesh vertex) per local vertex
  std::vector<Triangle> input;      ///< the base triangles, local numbering
  std::vector<float> input_far;     ///< their distances to the full surface, as measured (NaN: not yet)
  std::vector<uint8_t> interior;    ///< local vertices whose base triangles are all in the patch
  std::vector<EdgeKey> borders;     ///< the input's open directed edges, sorted
  std::vector<uint8_t> fan_before;  ///< local vertices whose input triangles form one fan
  std::vector<Vec3f> gone;          ///< check points an earlier pass removed, nearest to this patch
  std::vector<uint32_t> gone_near;  ///< per gone vertex: the input triangle it was nearest
};

/// The patch's interior vertices (by the base mesh's incidence counts), fans and open edges.
void prepare(Patch& patch, const std::vector<uint32_t>& incident_count) {
  const std::size_t n = patch.global.size();
  const Incidence incidence(n, patch.input);
  patch.interior.resize(n);
  patch.fan_before.resize(n);
  for (std::size_t v = 0; v < n; ++v) {
    patch.interior[v] = incidence.first[v + 1] - incidence.first[v] == incident_count[patch.global[v]];
    patch.fan_before[v] = single_fan(uint32_t(v), incidence, patch.input);
  }
  patch.borders = open_edges(sorted_directed_edges(patch.input));
}

/// The local vertices where `after` (a simplification of patch.input) breaks DecimateOutcome's
/// contract, and the largest distance measured where it holds.
struct Verdict {
  std::vector<uint32_t> violations;  ///< sorted, unique
  double max_error = 0;
};

/// The full surface the results are measured against, and the step at which the check samples
/// a simplified triangle (the full mesh's mean edge length: finer than the features it can miss).
struct Reference {
  const TriangleBvh& bvh;
  float step;
};

/// The largest distance from points of triangle abc to `full`, sampled on a grid of step at most
/// full.step (at least the edges' midpoints and the centres of the four half-size triangles): the
/// grid's points and the centres of its cells (the corners are the full mesh's own vertices).
/// INFINITY as soon as a point lies farther than `limit`.
float farthest(Vec3f a, Vec3f b, Vec3f c, const Reference& full, float limit) {
  const float longest = std::sqrt(std::max({length2(b - a), length2(c - b), length2(a - c)}));
  // The cap bounds one triangle's points at about 1.5 million: a triangle over 1,024 mean edges
  // long would be sampled more coarsely (on the bundled frames the longest is 60).
  const int k = int(std::clamp(std::ceil(longest / full.step), 2.0f, 1024.0f));
  const Vec3f u = (b - a) * (1.0f / float(k)), v = (c - a) * (1.0f / float(k));
  float far = 0;
  const auto beyond = [&](float i, float j) {  // measures the point at grid coordinates (i, j)
    far = std::max(far, full.bvh.closest(a + u * i + v * j, limit).distance);
    return far == INFINITY;
  };
  for (int i = 0; i <= k; ++i)
    for (int j = 0; i + j <= k; ++j) {
      const bool corner = (i == 0 && (j == 0 || j == k)) || (i == k && j == 0);
      if ((!corner && beyond(float(i), float(j))) || (i + j < k && beyond(float(i) + 1.0f / 3, float(j) + 1.0f / 3)) ||
          (i + j + 1 < k && beyond(float(i) + 2.0f / 3, float(j) + 2.0f / 3)))
        return INFINITY;
    }
  return far;
}

/// Triangles with their distances to the full surface (farthest()), NaN where not yet measured.
struct Measured {
  std::vector<Triangle> triangles;
  std::vector<float> far;
};

/// `after.far` comes in with the distances known (an earlier round or pass measured the same
/// triangle) and leaves with all of them.
Verdict check(const Patch& patch, Measured& after_measured, const Reference& full, double max_error) {
  const std::vector<Triangle>& after = after_measured.triangles;
  const std::vector<Vec3f>& x = patch.x;
  const std::vector<Triangle>& before = patch.input;
  const std::size_t nv = x.size();
  std::vector<std::atomic<uint8_t>> bad(nv), used(nv);
  std::vector<std::atomic<uint32_t>> left(nv);  // simplified triangles per component, at its first local vertex
  std::vector<uint32_t> first_of(nv);           // each local vertex's component's first local vertex
  {
    std::vector<std::pair<uint32_t, uint32_t>> roots(nv);
    for (uint32_t v = 0; v < nv; ++v) roots[v] = {patch.root[v], v};
    std::sort(roots.begin(), roots.end());
    for (std::size_t i = 0; i < nv; ++i)
      first_of[roots[i].second] = (i > 0 && roots[i - 1].first == roots[i].first) ? first_of[roots[i - 1].second] : roots[i].second;
  }
  for_each_index(after.size(), 4096, [&](std::size_t t) {
    left[first_of[after[t][0]]].fetch_add(1, std::memory_order_relaxed);
    for (uint32_t v : after[t]) used[v].store(1, std::memory_order_relaxed);
  });
  // Closed and manifold: each directed edge once, with its reverse (or an open edge of the input).
  const std::vector<EdgeKey> edges = sorted_directed_edges(after);
  for_each_index(edges.size(), 4096, [&](std::size_t i) {
    const EdgeKey e = edges[i];
    if ((i + 1 < edges.size() && edges[i + 1] == e) || (!contains(edges, reversed(e)) && !contains(patch.borders, e))) {
      bad[edge_from(e)].store(1, std::memory_order_relaxed);
      bad[edge_to(e)].store(1, std::memory_order_relaxed);
    }
  });
  // Manifold vertices: the triangles around each vertex form one fan, where they did before (a
  // collapse can pinch two sheets together at a vertex while every edge stays shared by two).
  const Incidence around(nv, after);
  for_each_chunk(nv, 4096, [&](std::size_t begin, std::size_t end) {
    for (std::size_t v = begin; v != end; ++v)
      if (patch.interior[v] && patch.fan_before[v] && !single_fan(uint32_t(v), around, after))
        bad[v].store(1, std::memory_order_relaxed);
  });
  // Nothing collapsed away, and the distances both ways.
  const TriangleBvh simplified(x, after);
  const float reach = float(2 * max_error);
  std::atomic<double> worst{0.0};
  const auto measure = [&](uint32_t v, float distance) {
    if (!(distance <= kMargin * max_error)) {
      bad[v].store(1, std::memory_order_relaxed);
      return;
    }
    double old = worst.load(std::memory_order_relaxed);
    while (distance > old && !worst.compare_exchange_weak(old, distance, std::memory_order_relaxed)) {}
  };
  for_each_index(before.size(), 1024, [&](std::size_t t) {
    bool changed = false;
    for (uint32_t v : before[t]) {
      if (left[first_of[v]].load(std::memory_order_relaxed) == 0) bad[v].store(1, std::memory_order_relaxed);
      if (used[v].load(std::memory_order_relaxed)) continue;
      // A vertex of several triangles is measured by each: the same distance, harmless.
      measure(v, simplified.closest(x[v], reach).distance);
      changed = true;
    }
    if (changed) {  // and the middle of a triangle that went
      const Vec3f c = (x[before[t][0]] + x[before[t][1]] + x[before[t][2]]) * (1.0f / 3);
      const float distance = simplified.closest(c, reach).distance;
      for (uint32_t v : before[t]) measure(v, distance);
    }
  });
  // The vertices an earlier pass removed, against the surface that replaces the one they measured.
  for_each_index(patch.gone.size(), 1024, [&](std::size_t g) {
    const float distance = simplified.closest(patch.gone[g], reach).distance;
    for (uint32_t v : before[patch.gone_near[g]]) measure(v, distance);
  });
  // A new triangle's distance to the full surface is its own: the rounds and passes before may know it.
  std::vector<float>& far = after_measured.far;
  far.resize(after.size(), NAN);
  for_each_chunk(after.size(), 256, [&](std::size_t begin, std::size_t end) {
    for (std::size_t t = begin; t != end; ++t)
      if (std::isnan(far[t]))
        far[t] = farthest(x[after[t][0]], x[after[t][1]], x[after[t][2]], full, float(kMargin * max_error));
  });
  for (std::size_t t = 0; t < after.size(); ++t)
    for (uint32_t v : after[t]) measure(v, far[t]);
  Verdict verdict;
  for (std::size_t v = 0; v < nv; ++v)
    if (bad[v].load(std::memory_order_relaxed)) verdict.violations.push_back(uint32_t(v));
  verdict.max_error = worst.load();
  return verdict;
}

/// Simplifies one patch under the contract: meshopt at `target` times the bound, then, where the check
/// fails, the input triangles around the offending vertices set aside (the rest sees them as a
/// locked border) and the rest simplified again, up to kRounds times; a patch that still fails
/// keeps its input. Returns the triangles, local numbering, with their distances.
Measured simplify_patch(const Patch& patch, const Reference& full, double max_error, double target, DecimateOutcome& outcome,
                        std::mutex& lock) {
  constexpr int kRounds = 8;
  const Incidence incidence(patch.x.size(), patch.input);
  const float scale = meshopt_simplifyScale(&patch.x[0].x, patch.x.size(), sizeof(Vec3f));
  std::vector<uint8_t> kept(patch.input.size(), 0);
  // The distances measured so far, by triangle: a triangle of fewer than 2²¹ vertices as one word
  // (its corners in order: the same triangle).
  const bool memo = patch.x.size() < (std::size_t(1) << 21);
  const auto key = [](const Triangle& t) { return uint64_t(t[0]) << 42 | uint64_t(t[1]) << 21 | t[2]; };
  std::unordered_map<uint64_t, float> known;
  if (memo)
    for (std::size_t t = 0; t < patch.input.size(); ++t)
      if (!std::isnan(patch.input_far[t])) known.emplace(key(patch.input[t]), patch.input_far[t]);
  for (int round = 1;; ++round) {
    std::vector<Triangle> rest;
    Measured result;
    for (std::size_t t = 0; t < patch.input.size(); ++t) (kept[t] ? result.triangles : rest).push_back(patch.input[t]);
    const std::vector<Triangle> simplified = simplify(patch.x, rest, float(target * max_error / scale));
    result.triangles.insert(result.triangles.end(), simplified.begin(), simplified.end());
    result.far.assign(result.triangles.size(), NAN);
    if (memo)
      for (std::size_t t = 0; t < result.triangles.size(); ++t)
        if (const auto it = known.find(key(result.triangles[t])); it != known.end()) result.far[t] = it->second;
    const Verdict verdict = check(patch, result, full, max_error);
    if (memo)
      for (std::size_t t = 0; t < result.triangles.size(); ++t) known.emplace(key(result.triangles[t]), result.far[t]);
    const bool done = verdict.violations.empty();
    if (done || round == kRounds) {
      const std::lock_guard<std::mutex> guard(lock);
      outcome.rounds = std::max(outcome.rounds, round);
      if (done) outcome.max_error = std::max(outcome.max_error, verdict.max_error);
      if (done) return result;
      return {patch.input, patch.input_far};  // the input met the contract already
    }
    for (const uint32_t v : verdict.violations)
      for (uint32_t k = incidence.first[v]; k < incidence.first[v + 1]; ++k) kept[incidence.triangles[k]] = 1;
  }
}

/// A patch of `triangles` (mesh numbering) with its local vertices and component roots.
Patch make_patch(const std::vector<Vec3f>& x, const std::vector<uint32_t>& root, Measured triangles_measured) {
  std::vector<Triangle>& triangles = triangles_measured.triangles;
  Patch patch;
  for (const Triangle& t : triangles)
    for (uint32_t v : t) patch.global.push_back(v);
  std::sort(patch.global.begin(), patch.global.end());
  patch.global.erase(std::unique(patch.global.begin(), patch.global.end()), patch.global.end());
  for (Triangle& t : triangles)
    for (uint32_t& v : t) v = uint32_t(std::lower_bound(patch.global.begin(), patch.global.end(), v) - patch.global.begin());
  patch.input = std::move(triangles);
  patch.input_far = std::move(triangles_measured.far);
  for (const uint32_t v : patch.global) patch.x.push_back(x[v]), patch.root.push_back(root[v]);
  return patch;
}

/// One pass: `base` (mesh numbering) cut into patches by a grid of side `side` shifted by
/// `offset`, each simplified on its own with meshopt at `target` times the bound, in parallel.
/// `full` holds the BVH of `full_triangles`.
Measured simplify_patches(const std::vector<Vec3f>& x, const std::vector<uint32_t>& root,
                          const std::vector<Triangle>& full_triangles, const Measured& base_measured, const Reference& full,
                          double side, double offset, double max_error, double target, DecimateOutcome& outcome) {
  const std::vector<Triangle>& base = base_measured.triangles;
  const std::size_t nv = x.size();
  std::vector<uint32_t> incident(nv, 0);
  for (const Triangle& t : base)
    for (uint32_t v : t) ++incident[v];
  // Each base triangle's cell; the patches in the cells' order (the result does not depend on
  // the thread count).
  std::vector<std::pair<std::array<int64_t, 3>, uint32_t>> cells(base.size());
  for_each_index(base.size(), [&](std::size_t t) {
    const Vec3f c = (x[base[t][0]] + x[base[t][1]] + x[base[t][2]]) * (1.0f / 3);
    for (int a = 0; a < 3; ++a) cells[t].first[std::size_t(a)] = int64_t(std::floor((double(c[a]) + offset) / side));
    cells[t].second = uint32_t(t);
  });
  tbb::parallel_sort(cells.begin(), cells.end());
  std::vector<std::size_t> starts;
  std::vector<uint32_t> patch_of(base.size()), position(base.size());  // base triangle → patch, and its index there
  for (std::size_t i = 0; i < cells.size(); ++i) {
    if (i == 0 || cells[i].first != cells[i - 1].first) starts.push_back(i);
    patch_of[cells[i].second] = uint32_t(starts.size() - 1);
    position[cells[i].second] = uint32_t(i - starts.back());
  }
  starts.push_back(cells.size());
  std::vector<Patch> patches(starts.size() - 1);
  for_each_index(patches.size(), [&](std::size_t p) {
    Measured triangles;
    for (std::size_t i = starts[p]; i < starts[p + 1]; ++i) {
      triangles.triangles.push_back(base[cells[i].second]);
      triangles.far.push_back(base_measured.far[cells[i].second]);
    }
    patches[p] = make_patch(x, root, std::move(triangles));
  });
  // The vertices an earlier pass removed: each goes to the patch of the base triangle nearest it.
  if (base.size() != full_triangles.size()) {
    std::vector<uint8_t> seen(nv, 0);
    for (const Triangle& t : base)
      for (uint32_t v : t) seen[v] = 1;
    // The check's points on the full mesh that base no longer has: its removed vertices and the
    // middles of the full triangles base does not have.
    const auto sorted = [](Triangle t) {
      std::sort(t.begin(), t.end());
      return t;
    };
    std::vector<Triangle> kept(base.size());
    for (std::size_t t = 0; t < base.size(); ++t) kept[t] = sorted(base[t]);
    tbb::parallel_sort(kept.begin(), kept.end());
    std::vector<Vec3f> gone;
    for (const Triangle& t : full_triangles) {
      for (uint32_t v : t)
        if (seen[v] == 0) seen[v] = 2, gone.push_back(x[v]);
      if (!std::binary_search(kept.begin(), kept.end(), sorted(t))) gone.push_back((x[t[0]] + x[t[1]] + x[t[2]]) * (1.0f / 3));
    }
    const TriangleBvh nearest(x, base);
    std::vector<uint32_t> near(gone.size());
    for_each_index(gone.size(),
                   [&](std::size_t g) { near[g] = nearest.closest(gone[g], float(2 * max_error)).triangle; });
    for (std::size_t g = 0; g < gone.size(); ++g) {
      if (near[g] == UINT32_MAX) continue;  // farther than the bound: the final check sees it
      Patch& patch = patches[patch_of[near[g]]];
      patch.gone.push_back(gone[g]);
      patch.gone_near.push_back(position[near[g]]);
    }
  }
  std::vector<Measured> results(patches.size());
  std::mutex lock;
  for_each_index(patches.size(), [&](std::size_t p) {
    Patch& patch = patches[p];
    prepare(patch, incident);
    results[p] = simplify_patch(patch, full, max_error, target, outcome, lock);
    for (Triangle& t : results[p].triangles)
      for (uint32_t& v : t) v = patch.global[v];
  });
  Measured out;
  for (const Measured& r : results) {
    out.triangles.insert(out.triangles.end(), r.triangles.begin(), r.triangles.end());
    out.far.insert(out.far.end(), r.far.begin(), r.far.end());
  }
  return out;
}

}  // namespace

const char* decimate_unavailable() { return nullptr; }

DecimateOutcome decimate(TriangleMesh& mesh, double max_error) {
  DecimateOutcome outcome;
  outcome.triangles_before = outcome.triangles_after = mesh.triangles.size();
  if (max_error <= 0 || mesh.triangles.empty()) return outcome;
  const std::vector<Vec3f>& x = mesh.vertices;
  const std::vector<Triangle>& full_triangles = mesh.triangles;
  const std::vector<uint32_t> root = component_roots(x.size(), full_triangles);
  const TriangleBvh bvh(x, full_triangles);
  // Patches of about kPatchTriangles triangles (a cell of side s holds about s²/ā of a roughly
  // flat surface's triangles of mean area ā).
  constexpr double kPatchTriangles = 40000;
  double area = 0, edges = 0;
  for (const Triangle& t : full_triangles) {
    area += double(length(cross(x[t[1]] - x[t[0]], x[t[2]] - x[t[0]]))) / 2;
    edges += double(length(x[t[1]] - x[t[0]]) + length(x[t[2]] - x[t[1]]) + length(x[t[0]] - x[t[2]]));
  }
  const double triangles = double(full_triangles.size());
  const double side = std::max(std::sqrt(kPatchTriangles * area / triangles), 1e-30);
  const Reference full{bvh, float(std::max(edges / (3 * triangles), 1e-30))};
  // Passes over the whole mesh, each on a grid shifted by the golden ratio's fraction of a cell
  // along the diagonal (so each pass's seams, locked there, lie inside the next one's patches), each
  // simplifying the last one's result further with meshopt's error raised by a tenth of the bound,
  // from 0.4 to 0.8 of it: small steps collapse the easy edges first, and each pass's result is
  // checked, so a step too far costs a round, not the bound. They stop when a pass removes less
  // than 2 % of the triangles. (One pass at 0.5 of the bound keeps 43 % of the dam break's
  // triangles, two 35 %; these passes keep 28 % in about twice the time.)
  constexpr int kMaxPasses = 8;
  constexpr double kFirstTarget = 0.4, kTargetStep = 0.1, kLastTarget = 0.8, kLeastGain = 0.02;
  Measured result{full_triangles, std::vector<float>(full_triangles.size(), 0.0f)};
  for (int pass = 0; pass < kMaxPasses; ++pass) {
    const std::size_t before = result.triangles.size();
    const double offset = std::fmod(pass * 0.6180339887498949, 1.0) * side;
    const double target = std::min(kFirstTarget + pass * kTargetStep, kLastTarget);
    result = simplify_patches(x, root, full_triangles, result, full, side, offset, max_error, target, outcome);
    if (pass > 0 && double(result.triangles.size()) > (1 - kLeastGain) * double(before)) break;
  }
  // The whole result against the whole full mesh: what no patch could see (a fan pinched at a
  // seam vertex, a component spread over patches collapsed away, a vertex an earlier pass removed
  // that no later patch measured). A component that fails gets its full triangles back.
  Patch whole = make_patch(x, root, {full_triangles, {}});
  std::vector<uint32_t> count(x.size(), 0);
  for (const Triangle& t : full_triangles)
    for (uint32_t v : t) ++count[v];
  prepare(whole, count);
  Measured local = result;
  for (Triangle& t : local.triangles)
    for (uint32_t& v : t) v = uint32_t(std::lower_bound(whole.global.begin(), whole.global.end(), v) - whole.global.begin());
  const Verdict verdict = check(whole, local, full, max_error);
  outcome.max_error = verdict.max_error;
  if (!verdict.violations.empty()) {
    std::vector<uint8_t> restore(x.size(), 0);
    for (const uint32_t v : verdict.violations) restore[whole.root[v]] = 1;
    std::vector<Triangle> kept;
    for (const Triangle& t : result.triangles)
      if (!restore[root[t[0]]]) kept.push_back(t);
    for (const Triangle& t : full_triangles)
      if (restore[root[t[0]]]) kept.push_back(t);
    result.triangles.swap(kept);
    for (std::size_t v = 0; v < x.size(); ++v) outcome.kept_whole += restore[v];
  }
  mesh.triangles.swap(result.triangles);
  drop_unused_vertices(mesh);
  outcome.triangles_after = mesh.triangles.size();
  return outcome;
}

}  // namespace meniscus
