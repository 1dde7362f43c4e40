// meniscus — small handles cut from a closed mesh (handles.hpp).
#include "mesh/handles.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <mutex>
#include <numbers>
#include <numeric>
#include <unordered_map>
#include <utility>
#include <vector>

#include "common/for_each.hpp"
#include "common/primitives.hpp"
#include "grid/hash_grid.hpp"
#include "mesh/components.hpp"
#include "mesh/ray_parity_impl.hpp"

namespace meniscus {

namespace {

constexpr uint32_t kNone = ~0u;

/// The triangles round each vertex.
struct Stars {
  std::vector<uint32_t> first;  ///< per vertex, its first entry in `star` (V + 1)
  std::vector<uint32_t> star;   ///< the corners round each vertex (3·triangle + corner)
};

Stars stars_of(const TriangleMesh& m) {
  const std::size_t V = m.vertices.size(), T = m.triangles.size();
  Stars g;
  g.first.assign(V + 1, 0);
  for (const Triangle& t : m.triangles)
    for (int k = 0; k < 3; ++k) ++g.first[t[k] + 1];
  std::partial_sum(g.first.begin(), g.first.end(), g.first.begin());
  g.star.resize(3 * T);
  std::vector<uint32_t> cursor(g.first.begin(), g.first.end() - 1);
  for (std::size_t t = 0; t < T; ++t)
    for (int k = 0; k < 3; ++k) g.star[cursor[m.triangles[t][k]]++] = uint32_t(3 * t + k);
  return g;
}

/// The triangle across edge t[c] → t[c+1]: the one of t[c+1]'s that holds it the other way
/// (kNone on an open edge).
uint32_t across(const TriangleMesh& m, const Stars& g, uint32_t t, int c) {
  const uint32_t a = m.triangles[t][c], b = m.triangles[t][(c + 1) % 3];
  for (uint32_t j = g.first[b]; j < g.first[b + 1]; ++j) {
    const uint32_t u = g.star[j] / 3, k = g.star[j] % 3;
    if (m.triangles[u][(k + 1) % 3] == a) return u;
  }
  return kNone;
}

/// acos(x) within 7e-5 rad (Abramowitz & Stegun 4.4.45): the seeds' test needs no more.
float fast_acos(float x) {
  x = std::clamp(x, -1.0f, 1.0f);
  const float a = std::fabs(x);
  const float r = std::sqrt(1.0f - a) * (((-0.0187293f * a + 0.0742610f) * a - 0.2121144f) * a + 1.5707288f);
  return x < 0 ? std::numbers::pi_v<float> - r : r;
}


/// An annulus to remove: its triangles and its two boundary loops (vertices in the order of the
/// removed triangles' edges, so a cap over a loop pairs with the mesh round it).
struct Annulus {
  uint32_t seed = 0;
  int rings = 0;
  std::vector<uint32_t> triangles;
  std::vector<uint32_t> loops[2];
};

/// A small open-addressing table from vertex or triangle numbers to the entries of one seed's
/// rings (a few hundred), emptied per seed: a thread's scratch stays a few kB whatever the mesh.
class SmallIndex {
 public:
  static constexpr std::size_t kCapacity = 4096;  ///< at most half of it used
  SmallIndex() : keys_(kCapacity, kNone), values_(kCapacity) {}
  uint32_t find(uint32_t key) const {
    for (std::size_t i = hash(key);; i = (i + 1) & (kCapacity - 1)) {
      if (keys_[i] == key) return values_[i];
      if (keys_[i] == kNone) return kNone;
    }
  }
  /// Inserts a new key; false when the table is half full (the seed is then given up).
  bool insert(uint32_t key, uint32_t value) {
    if (used_.size() >= kCapacity / 2) return false;
    std::size_t i = hash(key);
    while (keys_[i] != kNone) i = (i + 1) & (kCapacity - 1);
    keys_[i] = key, values_[i] = value;
    used_.push_back(uint32_t(i));
    return true;
  }
  void clear() {
    for (const uint32_t i : used_) keys_[i] = kNone;
    used_.clear();
  }

 private:
  static std::size_t hash(uint32_t key) { return std::size_t(key * 2654435761u) & (kCapacity - 1); }
  std::vector<uint32_t> keys_, values_, used_;
};

/// A thread's scratch for one seed's rings: the vertices reached (their entries: ring, neighbours'
/// farthest ring, boundary marks) and the region's triangles.
struct Scratch {
  SmallIndex vertex;                ///< vertex → its entry in `visited`
  SmallIndex triangle;              ///< triangle in the region → 0
  std::vector<uint32_t> visited;    ///< the vertices reached, ring by ring
  std::vector<int32_t> hop;         ///< per entry, its ring
  std::vector<int32_t> farthest;    ///< per entry, its neighbours' farthest ring
  std::vector<uint32_t> next_mark;  ///< per entry, the walk whose boundary leaves it
  std::vector<uint32_t> next;       ///< that boundary edge's end (a vertex)
  std::vector<uint32_t> walked;     ///< per entry, the walk whose loop passed it
  std::vector<uint8_t> used;        ///< per entry, whether a region triangle uses it
  std::vector<uint32_t> region;
  std::vector<uint32_t> ring;       ///< where each ring starts in `visited`
  uint32_t walk = 0;
};

/// Grows the rings round `seed`; true with `out` when ring k ≤ hops first stops being a disk by
/// wrapping into a clean annulus (no vertex twice on its boundary).
bool wrapped_ring(const TriangleMesh& m, const Stars& g, uint32_t seed, int hops, Scratch& s, Annulus& out) {
  s.vertex.clear();
  s.triangle.clear();
  s.visited.clear();
  s.hop.clear();
  // The vertices within hops + 1 edges, ring by ring (ring r is visited[ring[r], ring[r + 1])).
  const auto reach = [&](uint32_t v, int32_t h) {
    if (!s.vertex.insert(v, uint32_t(s.visited.size()))) return false;
    s.visited.push_back(v), s.hop.push_back(h);
    return true;
  };
  if (!reach(seed, 0)) return false;
  s.ring.assign(1, 0);
  for (std::size_t i = 0; i < s.visited.size(); ++i) {
    const uint32_t v = s.visited[i];
    if (std::size_t(s.hop[i]) == s.ring.size()) s.ring.push_back(uint32_t(i));
    if (s.hop[i] > hops) continue;
    for (uint32_t j = g.first[v]; j < g.first[v + 1]; ++j)
      for (const uint32_t w : m.triangles[g.star[j] / 3])
        if (s.vertex.find(w) == kNone && !reach(w, s.hop[i] + 1)) return false;  // too many: give it up
  }
  while (s.ring.size() < std::size_t(hops) + 3) s.ring.push_back(uint32_t(s.visited.size()));
  s.ring.push_back(uint32_t(s.visited.size()));
  const std::size_t n = s.visited.size();
  const auto hop_of = [&](uint32_t v) {
    const uint32_t e = s.vertex.find(v);
    return e == kNone ? -1 : s.hop[e];
  };
  // Per vertex reached, its neighbours' farthest ring (hops + 2: beyond).
  s.farthest.assign(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const uint32_t v = s.visited[i];
    int32_t far = 0;
    for (uint32_t j = g.first[v]; j < g.first[v + 1]; ++j)
      for (const uint32_t w : m.triangles[g.star[j] / 3]) {
        const int32_t h = hop_of(w);
        far = std::max(far, h < 0 ? hops + 2 : h);
      }
    s.farthest[i] = far;
  }
  s.used.assign(n, 0);
  s.next_mark.assign(n, 0);
  s.next.assign(n, 0);
  s.walked.assign(n, 0);
  const auto in_region = [&](uint32_t t) { return t != kNone && s.triangle.find(t) != kNone; };
  // The region grows ring by ring; its Euler characteristic V − E + F (E = (3F + boundary) / 2)
  // stays 1 while it is a disk.
  s.region.clear();
  std::ptrdiff_t vertices = 0, boundary = 0;
  bool found = false;
  for (int k = 1; k <= hops; ++k) {
    // Inside ring k: the vertices within k edges, and those one further whose every neighbour is
    // within k (a pocket the rings would close one step later).
    const auto inside = [&](uint32_t v) {
      const uint32_t e = s.vertex.find(v);
      return e != kNone && (s.hop[e] <= k || (s.hop[e] == k + 1 && s.farthest[e] <= k));
    };
    bool full = false;
    for (std::size_t i = s.ring[k]; i < s.ring[k + 2] && !full; ++i) {
      const uint32_t v = s.visited[i];
      if (s.hop[i] == k + 1 && s.farthest[i] > k) continue;
      for (uint32_t j = g.first[v]; j < g.first[v + 1]; ++j) {
        const uint32_t t = g.star[j] / 3;
        if (in_region(t)) continue;
        const Triangle& tri = m.triangles[t];
        if (!inside(tri[0]) || !inside(tri[1]) || !inside(tri[2])) continue;
        if (!s.triangle.insert(t, 0)) {
          full = true;
          break;
        }
        s.region.push_back(t);
        for (int c = 0; c < 3; ++c) {
          const uint32_t e = s.vertex.find(tri[c]);
          if (!s.used[e]) s.used[e] = 1, ++vertices;
          boundary += in_region(across(m, g, t, c)) ? -1 : 1;
        }
      }
    }
    if (full) break;
    const std::ptrdiff_t faces = std::ptrdiff_t(s.region.size());
    if (vertices - (3 * faces + boundary) / 2 + faces == 1) continue;  // still a disk
    // Not a disk: is it an annulus with two clean loops?
    const uint32_t walk = ++s.walk;
    bool clean = true, open_edge = false;
    std::vector<uint32_t> starts;
    for (const uint32_t t : s.region)
      for (int c = 0; c < 3; ++c) {
        const uint32_t o = across(m, g, t, c);
        if (in_region(o)) continue;
        const uint32_t e = s.vertex.find(m.triangles[t][c]);
        open_edge = open_edge || o == kNone;
        clean = clean && o != kNone && s.next_mark[e] != walk;  // an open mesh, or a vertex twice
        s.next_mark[e] = walk;
        s.next[e] = m.triangles[t][(c + 1) % 3];
        starts.push_back(e);
      }
    std::vector<std::vector<uint32_t>> loops;
    for (std::size_t i = 0; clean && i < starts.size() && loops.size() <= 2; ++i) {
      if (s.walked[starts[i]] == walk) continue;
      std::vector<uint32_t> loop;
      for (uint32_t e = starts[i]; s.walked[e] != walk; e = s.vertex.find(s.next[e])) {
        s.walked[e] = walk;
        loop.push_back(s.visited[e]);
      }
      loops.push_back(std::move(loop));
    }
    if (clean && loops.size() == 2 && loops[0].size() >= 3 && loops[1].size() >= 3 &&
        vertices - (3 * faces + boundary) / 2 + faces == 0) {
      out.seed = seed;
      out.rings = k;
      out.triangles = s.region;
      std::sort(out.triangles.begin(), out.triangles.end());
      out.loops[0] = std::move(loops[0]);
      out.loops[1] = std::move(loops[1]);
      found = true;
      break;
    }
    // A front that first meets itself at a vertex (a pinch) may close into an annulus a ring
    // later; anything else (an open edge, a closed piece, more loops) ends the growth.
    if (clean || open_edge) break;
  }
  return found;
}

/// The caps of an annulus, apart from the mesh until the cut is made: their new vertices are
/// numbered from the mesh's vertex count V on (vertex V + i is `added[i]`).
struct Plug {
  std::size_t V = 0;
  std::vector<Vec3f> added;
  std::vector<Triangle> caps;
  uint32_t origin = 0;  ///< the vertex whose attributes the new ones take
};

/// A vertex's position: the mesh's, or a cap's new one.
Vec3f at(const TriangleMesh& m, const Plug& plug, uint32_t v) { return v < plug.V ? m.vertices[v] : plug.added[v - plug.V]; }

/// Caps `loop` (its vertices in the order of the edges the cap must hold) with a disk: rings of
/// about half as many vertices each, a fan at the end.
void cap(std::vector<uint32_t> loop, const TriangleMesh& m, Plug& plug) {
  const auto add = [&](Vec3f x) {
    plug.added.push_back(x);
    return uint32_t(plug.V + plug.added.size() - 1);
  };
  while (true) {
    const std::size_t n = loop.size();
    Vec3f centre{0, 0, 0};
    for (const uint32_t v : loop) centre = centre + at(m, plug, v);
    centre = centre / float(n);
    if (n == 3) {
      plug.caps.push_back({loop[0], loop[1], loop[2]});
      return;
    }
    if (n == 4) {
      plug.caps.push_back({loop[0], loop[1], loop[2]});
      plug.caps.push_back({loop[0], loop[2], loop[3]});
      return;
    }
    if (n <= 6) {
      const uint32_t c = add(centre);
      for (std::size_t i = 0; i < n; ++i) plug.caps.push_back({loop[i], loop[(i + 1) % n], c});
      return;
    }
    const std::size_t inner_n = std::max<std::size_t>(3, n / 2);
    std::vector<uint32_t> inner(inner_n);
    for (std::size_t j = 0; j < inner_n; ++j) inner[j] = add(centre + (at(m, plug, loop[j * n / inner_n]) - centre) * 0.5f);
    // The band between the loop and the inner ring: advance on whichever is behind.
    std::size_t i = 0, j = 0;
    while (i < n || j < inner_n) {
      const bool outer = j == inner_n || (i < n && (i + 1) * inner_n <= (j + 1) * n);
      if (outer) {
        plug.caps.push_back({loop[i], loop[(i + 1) % n], inner[j % inner_n]});
        ++i;
      } else {
        plug.caps.push_back({loop[i % n], inner[(j + 1) % inner_n], inner[j]});
        ++j;
      }
    }
    loop = std::move(inner);
  }
}

/// Relaxes the caps' new vertices towards the mean of their neighbours with the loops held: a fair
/// disk spanning each loop, near the least-area one, which the sweeps then move little.
void fair(const TriangleMesh& m, Plug& plug) {
  const std::size_t n = plug.added.size();
  if (n == 0) return;
  std::vector<Vec3f> sum(n);
  std::vector<float> count(n);
  for (int iteration = 0; iteration < 30; ++iteration) {
    std::fill(sum.begin(), sum.end(), Vec3f{0, 0, 0});
    std::fill(count.begin(), count.end(), 0.0f);
    for (const Triangle& t : plug.caps)
      for (int c = 0; c < 3; ++c) {
        if (t[c] < plug.V) continue;
        // Each triangle adds the two other corners (an edge counted from both its triangles).
        const std::size_t i = t[c] - plug.V;
        sum[i] = sum[i] + at(m, plug, t[(c + 1) % 3]) + at(m, plug, t[(c + 2) % 3]);
        count[i] += 2;
      }
    for (std::size_t i = 0; i < n; ++i)
      if (count[i] > 0) plug.added[i] = sum[i] / count[i];
  }
}

/// The triangles round the vertices near the caps, made on first use: the mesh's stars less the
/// cut triangles and the slots the caps took, plus the caps'.
class LocalStars {
 public:
  LocalStars(const TriangleMesh& m, const Stars& g, const std::vector<uint8_t>& drop, const std::vector<uint32_t>& caps)
      : g_(g), drop_(drop), cap_(drop.size(), 0) {
    for (const uint32_t t : caps) {
      cap_[t] = 1;
      for (const uint32_t v : m.triangles[t]) caps_[v].push_back(t);
    }
  }
  std::vector<uint32_t>& operator[](uint32_t v) {
    auto [it, made] = local_.try_emplace(v);
    if (made) {
      if (v + 1 < g_.first.size())  // the mesh's triangles round v that are neither cut nor a cap's now
        for (uint32_t j = g_.first[v]; j < g_.first[v + 1]; ++j) {
          const uint32_t t = g_.star[j] / 3;
          if (!drop_[t] && !cap_[t]) it->second.push_back(t);
        }
      if (const auto c = caps_.find(v); c != caps_.end()) it->second.insert(it->second.end(), c->second.begin(), c->second.end());
    }
    return it->second;
  }

 private:
  const Stars& g_;
  const std::vector<uint8_t>& drop_;
  std::vector<uint8_t> cap_;  ///< per triangle slot, whether a cap's triangle holds it now
  std::unordered_map<uint32_t, std::vector<uint32_t>> caps_, local_;
};

/// Flips edges opposite the vertices in `touched` whose valence is under 5 (a loop vertex that kept
/// two triangles and got two from its cap), towards vertices that have a neighbour to spare.
void raise_low_valences(TriangleMesh& m, LocalStars& stars, const std::vector<uint32_t>& touched) {
  const auto corner = [&](uint32_t t, uint32_t v) {
    const Triangle& x = m.triangles[t];
    return x[0] == v ? 0 : x[1] == v ? 1 : 2;
  };
  // A vertex under 5 takes a neighbour from the two across one of its triangles, those with the
  // most to spare first; one left at 4 by it is worked on in turn (the deficit moves out until it
  // meets a vertex of valence 6 or more). Bounded: flips add no vertex and the work list is capped.
  std::vector<uint32_t> work(touched.rbegin(), touched.rend());
  std::size_t budget = 16 * touched.size() + 64;
  while (!work.empty() && budget-- > 0) {
    const uint32_t v = work.back();
    work.pop_back();
    if (stars[v].size() >= 5) continue;
    uint32_t best_t = kNone, best_u = kNone, best_a = 0, best_b = 0, best_w = 0;
    std::size_t best = 0;
    for (const uint32_t t : std::vector<uint32_t>(stars[v])) {
      const int c = corner(t, v);
      const uint32_t a = m.triangles[t][(c + 1) % 3], b = m.triangles[t][(c + 2) % 3];
      const std::size_t spare = std::min(stars[a].size(), stars[b].size());
      if (spare < 5 || spare <= best) continue;
      uint32_t u = kNone, w = kNone;
      for (const uint32_t o : stars[b]) {
        const int k = corner(o, b);
        if (m.triangles[o][(k + 1) % 3] == a) u = o, w = m.triangles[o][(k + 2) % 3];
      }
      if (u == kNone || w == v) continue;
      bool joined = false;
      for (const uint32_t o : stars[v])
        for (const uint32_t x : m.triangles[o]) joined = joined || x == w;
      if (joined) continue;
      best = spare, best_t = t, best_u = u, best_a = a, best_b = b, best_w = w;
    }
    if (best_t == kNone) continue;
    // (v, a, b) and (b, a, w) become (v, a, w) and (v, w, b).
    m.triangles[best_t] = {v, best_a, best_w};
    m.triangles[best_u] = {v, best_w, best_b};
    auto& sb = stars[best_b];
    sb.erase(std::find(sb.begin(), sb.end(), best_t));
    auto& sa = stars[best_a];
    sa.erase(std::find(sa.begin(), sa.end(), best_u));
    stars[best_w].push_back(best_t);
    stars[v].push_back(best_u);
    for (const uint32_t x : {v, best_a, best_b})
      if (stars[x].size() < 5) work.push_back(x);
  }
}

}  // namespace

std::size_t cut_small_handles(TriangleMesh& m, const HandleSettings& settings, const HashGrid& particles) {
  std::size_t cut = 0;
  // (Corners are numbered in 32 bits: a mesh of more than 1.4 billion triangles is left as it is.)
  if (m.triangles.empty() || settings.rings < 1 || m.triangles.size() >= (std::size_t(1) << 32) / 3) return 0;
  const std::size_t V = m.vertices.size(), T = m.triangles.size();
  const Stars g = stars_of(m);
  // Seeds: the vertices where the surface is a saddle sharp enough for a narrow tube.
  std::vector<uint8_t> seed(V, 0);
  for_each_index(V, 1024, [&](std::size_t v) {
    float sum = 0;
    for (uint32_t j = g.first[v]; j < g.first[v + 1]; ++j) {
      const Triangle& t = m.triangles[g.star[j] / 3];
      const uint32_t c = g.star[j] % 3;
      const Vec3f p = m.vertices[v], a = m.vertices[t[(c + 1) % 3]] - p, b = m.vertices[t[(c + 2) % 3]] - p;
      const float q = length2(a) * length2(b);
      sum += q > 0 ? fast_acos(dot(a, b) / std::sqrt(q)) : 0.0f;
    }
    seed[v] = g.first[v] != g.first[v + 1] && 2 * std::numbers::pi_v<float> - sum < -settings.saddle_defect;
  });
  // The annuli round the seeds, in any order (sorted below). Every seed's own: which are cut
  // depends only on the annuli found near them (a vertex's number is its position's rank), not
  // on the threads nor on the mesh far away.
  PerThread<Scratch> scratch;
  std::vector<Annulus> found;
  std::mutex appending;
  for_each_chunk(V, 1024, [&](std::size_t begin, std::size_t end) {
    Scratch& s = scratch.local();
    std::vector<Annulus> mine;
    Annulus a;
    for (std::size_t v = begin; v < end; ++v)
      if (seed[v] && wrapped_ring(m, g, uint32_t(v), settings.rings, s, a)) mine.push_back(std::move(a));
    if (mine.empty()) return;
    const std::lock_guard<std::mutex> lock(appending);
    for (Annulus& x : mine) found.push_back(std::move(x));
  });
  if (found.empty()) return 0;
  // The smallest first, then the lower seed: each that shares no vertex with one taken before,
  // round air, and whose plug holds no particle, is taken.
  std::sort(found.begin(), found.end(), [](const Annulus& a, const Annulus& b) {
    return std::make_tuple(a.rings, a.triangles.size(), a.seed) < std::make_tuple(b.rings, b.triangles.size(), b.seed);
  });
  std::vector<uint8_t> claimed(V, 0), drop(T, 0);
  std::vector<const Annulus*> taken;
  std::vector<Plug> plugs;
  for (const Annulus& a : found) {
    bool free = true;
    for (const uint32_t t : a.triangles)
      for (const uint32_t v : m.triangles[t]) free = free && !claimed[v];
    if (!free) continue;
    if (settings.water_distance > 0) {
      // A neck of water (two drops' balls overlapping) has its particles along the tube, one at
      // each end, the nearest within water_distance of its middle; a pinhole has them round it,
      // across the tube. The tube: from one loop's centroid to the other's.
      Vec3f c[2];
      for (int k = 0; k < 2; ++k) {
        c[k] = Vec3f{0, 0, 0};
        for (const uint32_t v : a.loops[k]) c[k] = c[k] + m.vertices[v];
        c[k] = c[k] / float(a.loops[k].size());
      }
      const Vec3f middle = (c[0] + c[1]) * 0.5f, axis = c[1] - c[0];
      const float w = settings.water_distance;
      const HashGrid::Nearest nearest = particles.nearest(middle, w);
      if (nearest.index != kNotFound && nearest.dist2 < w * w) {
        const Vec3f to = particles.point(nearest.index) - middle;
        const float along = dot(to, axis);
        if (along * along >= 0.5f * length2(to) * length2(axis)) continue;  // within 45° of it
      }
    }
    // The plug: the annulus and its two caps, a closed surface round what the cut turns from one
    // side to the other. It may hold air only (a pinhole's, a tunnel's): a particle in it would
    // end up outside (a ring of water, or a cap across the particles at a hole's rim).
    Plug plug;
    plug.V = V;
    plug.origin = a.loops[0][0];
    for (const auto& loop : a.loops) cap(loop, m, plug);
    fair(m, plug);
    // The blob test's ray parity (ray_parity_impl.hpp) over the plug's triangles, each with its
    // own three corners.
    std::vector<Vec3f> corners;
    for (const uint32_t t : a.triangles)
      for (const uint32_t v : m.triangles[t]) corners.push_back(m.vertices[v]);
    for (const Triangle& t : plug.caps)
      for (const uint32_t v : t) corners.push_back(at(m, plug, v));
    std::vector<uint32_t> order(corners.size()), ids(corners.size() / 3);
    std::iota(order.begin(), order.end(), 0u);
    std::iota(ids.begin(), ids.end(), 0u);
    if (encloses_a_point(particles, order.data(), ids.data(), uint32_t(ids.size()), corners.data())) continue;
    for (const uint32_t t : a.triangles) {
      drop[t] = 1;
      for (const uint32_t v : m.triangles[t]) claimed[v] = 1;
    }
    taken.push_back(&a);
    plugs.push_back(std::move(plug));
  }
  if (taken.empty()) return 0;
  // An annulus is cut only when the mesh without all the taken ones still joins its two loops (by
  // shared vertices: the loops are clean and the annuli apart, so no vertex pinches): its loop
  // does not separate the surface, nor do all of them together.
  // (The taken annuli's triangles are stood in for by a corner repeated, which joins nothing,
  // for the count, and then put back: no copy of the mesh's triangles.)
  std::vector<Triangle> kept_aside;
  for (std::size_t t = 0; t < T; ++t)
    if (drop[t]) kept_aside.push_back(m.triangles[t]), m.triangles[t] = {m.triangles[t][0], m.triangles[t][0], m.triangles[t][0]};
  const std::vector<uint32_t> root = component_roots(V, m.triangles);
  for (std::size_t t = 0, k = 0; t < T; ++t)
    if (drop[t]) m.triangles[t] = kept_aside[k++];
  std::fill(drop.begin(), drop.end(), 0);
  std::vector<uint32_t> touched, origin, caps;  // caps: the slots the caps' triangles took
  std::vector<uint8_t> inner(V, 0);             // the cut annuli's vertices off their loops
  std::size_t added = 0;
  for (std::size_t k = 0; k < taken.size(); ++k)
    if (root[taken[k]->loops[0][0]] == root[taken[k]->loops[1][0]]) added += plugs[k].added.size();
  m.vertices.reserve(V + added);
  for (std::size_t k = 0; k < taken.size(); ++k) {
    const Annulus& a = *taken[k];
    if (root[a.loops[0][0]] != root[a.loops[1][0]]) continue;
    // The cut: the annulus out, its caps in (their new vertices numbered on from the mesh's). The
    // caps take the annulus' slots (more than they need, as a rule), so the triangles' array does
    // not grow: on a large frame a second copy of it would be the pass's largest cost in memory.
    std::vector<uint32_t> slots(a.triangles.rbegin(), a.triangles.rend());
    for (const uint32_t t : a.triangles) {
      drop[t] = 1;
      for (const uint32_t v : m.triangles[t]) inner[v] = 1;
    }
    for (const auto& loop : a.loops)
      for (const uint32_t v : loop) inner[v] = 0, touched.push_back(v);
    const Plug& plug = plugs[k];
    const uint32_t base = uint32_t(m.vertices.size());
    m.vertices.insert(m.vertices.end(), plug.added.begin(), plug.added.end());
    origin.insert(origin.end(), plug.added.size(), plug.origin);
    for (Triangle t : plug.caps) {
      for (uint32_t& v : t)
        if (v >= V) v = base + (v - uint32_t(V));
      if (slots.empty()) {
        caps.push_back(uint32_t(m.triangles.size()));
        m.triangles.push_back(t);
        drop.push_back(0);
      } else {
        caps.push_back(slots.back());
        m.triangles[slots.back()] = t;
        drop[slots.back()] = 0;
        slots.pop_back();
      }
    }
    ++cut;
  }
  if (cut == 0) return 0;
  for (std::size_t v = V; v < m.vertices.size(); ++v) touched.push_back(uint32_t(v));
  LocalStars stars(m, g, drop, caps);
  raise_low_valences(m, stars, touched);
  // The mesh without the annuli and their inner vertices, in order; the caps' vertices take their
  // loop's first vertex's attributes.
  std::vector<uint32_t> remap(m.vertices.size());
  uint32_t next = 0;
  for (std::size_t v = 0; v < m.vertices.size(); ++v) remap[v] = v < V && inner[v] ? kNone : next++;
  std::size_t kept = 0;
  for (std::size_t t = 0; t < m.triangles.size(); ++t) {
    if (drop[t]) continue;
    const Triangle x = m.triangles[t];
    m.triangles[kept++] = {remap[x[0]], remap[x[1]], remap[x[2]]};
  }
  m.triangles.resize(kept);
  for (std::size_t v = 0; v < m.vertices.size(); ++v)
    if (remap[v] != kNone) m.vertices[remap[v]] = m.vertices[v];
  for (Attribute& attribute : m.attributes) {
    const std::size_t n = std::size_t(attribute.components);
    attribute.values.resize(n * m.vertices.size());
    for (std::size_t v = 0; v < m.vertices.size(); ++v) {
      const std::size_t from = v < V ? v : origin[v - V];
      if (remap[v] != kNone)
        std::copy_n(attribute.values.begin() + std::ptrdiff_t(n * from), n,
                    attribute.values.begin() + std::ptrdiff_t(n * remap[v]));
    }
  }
  m.vertices.resize(next);
  for (Attribute& attribute : m.attributes) attribute.values.resize(std::size_t(attribute.components) * next);
  return cut;
}

}  // namespace meniscus
