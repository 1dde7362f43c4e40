// meniscus — simplification under a bound that keeps the triangles good (post/decimate.hpp).
#include "post/decimate.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <queue>
#include <span>
#include <vector>

#include "common/for_each.hpp"
#include "common/primitives.hpp"
#include "field/eigen_sym3_impl.hpp"
#include "mesh/closest_point_impl.hpp"
#include "mesh/compact.hpp"
#include "mesh/normals.hpp"

namespace meniscus {

namespace {

constexpr uint32_t kNone = UINT32_MAX;
constexpr std::size_t kMinValence = 5, kMaxValence = 9;
constexpr float kMinAngleCos = 0.96592583f;  // cos 15°
constexpr float kTurnCos = 0.70710678f;      // cos 45°
constexpr float kFacingCos = 0.5f;           // cos 60°: a new triangle against its corners' input normals
/// The share of the bound the input's points may lie from the simplified surface: the bound holds
/// between the surfaces, and they can part farther between the points, most under the ridges
/// that moved vertices make. A slightly larger share let a frame past the bound; 0.55 keeps every
/// measured frame within it (bench/RESULTS.md#lean-meshes---decimate).
constexpr double kMargin = 0.55;
constexpr int kRounds = 3;

/// What the patches share. The bound is kept by points of the input surface (its vertices, its
/// edges' midpoints and its triangles' centroids): each is owned by one triangle and lies within
/// reach of it; an operation hands the points of the triangles it changes to the triangles it
/// leaves (the one that held a point, where it is still there, else the first within reach), or is
/// refused. Each entry is written only by the patch that holds the triangle or the
/// vertex (one patch each), so the patches run in parallel without locks; only a seam vertex's
/// `settled`, which two patches may clear at once, is written through atomic_ref.
struct Shared {
  const std::vector<Vec3f>& x;  ///< the input's vertices
  std::vector<Vec3f> pos;       ///< the vertices where they are now (a collapse may move one)
  std::vector<Vec3f>& normals;  ///< the mesh's, with its attributes: a moved vertex takes the mean
  std::vector<Attribute>& attributes;
  std::vector<Vec3f> midpoints;        ///< the input's edges' midpoints
  std::vector<uint32_t> next;          ///< the next point of the same triangle
  std::vector<uint8_t> floor_valence;  ///< the least valence a vertex may fall to
  std::vector<Vec3f> normal;           ///< the input's vertex normals (unit, area-weighted)
  /// Vertices none of whose collapses passed since their triangles last changed: tried again only
  /// once they change (a later round after a flip, a later pass at a seam).
  std::vector<uint8_t> settled;
  float reach2 = 0;                    ///< (kMargin · bound)²
  std::vector<Triangle> input;         ///< the input's triangles (centroid point nv + t is triangle t's)

  /// Point p: the input's vertex p (p < nv), triangle p - nv's centroid (p < nv + nt), or
  /// midpoints[p - nv - nt].
  Vec3f point(uint32_t p) const {
    if (p < x.size()) return x[p];
    if (p < x.size() + input.size()) return centroid(input[p - x.size()]);
    return midpoints[p - x.size() - input.size()];
  }
  Vec3f centroid(const Triangle& c) const { return (x[c[0]] + x[c[1]] + x[c[2]]) * (1.0f / 3); }

  /// Vertex v moved to meet u, which it absorbed: its normal and (non-integer) attributes
  /// become the two's mean.
  void merge(uint32_t u, uint32_t v) {
    if (v < normals.size() && u < normals.size()) normals[v] = normalized(normals[v] + normals[u]);
    for (Attribute& a : attributes) {
      if (a.integer || a.size() != x.size()) continue;
      const std::size_t c = std::size_t(a.components);
      for (std::size_t k = 0; k < c; ++k) a.values[v * c + k] = 0.5f * (a.values[v * c + k] + a.values[u * c + k]);
    }
  }
};

/// The squared distance from q to triangle abc. Ericson's closest point answers a corner for a
/// triangle of no area (a clip's cap can hold such slivers along the box's edges): there the
/// nearest of the three edges answers instead, wherever the first answer is beyond `reach2`.
float distance2(Vec3f q, Vec3f a, Vec3f b, Vec3f c, float reach2) {
  const float d2 = length2(closest_point_on_triangle(q, a, b, c) - q);
  if (d2 <= reach2) return d2;
  const auto segment = [&](Vec3f p, Vec3f e) {
    const float l2 = length2(e - p);
    const float s = l2 > 0 ? std::clamp(dot(q - p, e - p) / l2, 0.0f, 1.0f) : 0.0f;
    return length2(p + (e - p) * s - q);
  };
  return std::min({d2, segment(a, b), segment(b, c), segment(c, a)});
}

/// A triangle prepared for many questions "is q within reach of it?": a point farther than reach
/// from its plane is not, one within reach of the plane whose projection falls inside the triangle
/// is; the others (and every point of a triangle too thin for its plane to be trusted) ask
/// distance2.
struct Target {
  Vec3f a, b, c, n, ea, eb, ec;  ///< corners, unit normal, the edges' inward normals in the plane
  bool flat = false;             ///< n and the edge normals are trustworthy

  void prepare(Vec3f pa, Vec3f pb, Vec3f pc) {
    a = pa, b = pb, c = pc;
    const Vec3f m = cross(b - a, c - a);
    const float l2 = length2(m), e2 = std::max({length2(b - a), length2(c - b), length2(a - c)});
    flat = l2 > 1e-6f * e2 * e2;  // its smallest angle above about 0.06°
    if (!flat) return;
    n = m * (1 / std::sqrt(l2));
    ea = cross(n, b - a), eb = cross(n, c - b), ec = cross(n, a - c);
  }
  /// Whether q lies within reach of the plane over the triangle (a sure yes, without distance2).
  bool over(Vec3f q, float reach2) const {
    if (!flat) return false;
    const float h = dot(q - a, n);
    return h * h <= reach2 && dot(q - a, ea) >= 0 && dot(q - b, eb) >= 0 && dot(q - c, ec) >= 0;
  }
  bool within(Vec3f q, float reach2) const {
    if (flat) {
      const float h = dot(q - a, n);
      if (h * h > reach2) return false;
      if (dot(q - a, ea) >= 0 && dot(q - b, eb) >= 0 && dot(q - c, ec) >= 0) return true;
    }
    return distance2(q, a, b, c, reach2) <= reach2;
  }
};

/// The cosine of a triangle's smallest angle (its largest cosine); 1 for a degenerate one.
float smallest_angle_cos(Vec3f a, Vec3f b, Vec3f c) {
  const auto corner = [](Vec3f p, Vec3f q, Vec3f r) {
    const Vec3f e = q - p, f = r - p;
    const float l = std::sqrt(length2(e) * length2(f));
    return l > 0 ? dot(e, f) / l : 1.0f;
  };
  return std::max({corner(a, b, c), corner(b, c, a), corner(c, a, b)});
}

/// A mesh's triangles with the heads of their lists of points (Shared::point).
struct Owned {
  std::vector<Triangle> triangles;
  std::vector<uint32_t> head;
};

/// Each local vertex's triangles in fixed slots. A vertex with more triangles in the patch than
/// slots is never interior, and only interior vertices' triangles change (their valence capped at
/// 9, or at the input's), so the slots never overflow where they are read.
class Fans {
 public:
  static constexpr uint32_t kSlots = 16;
  void reset(std::size_t n) {
    slots_.assign(n * kSlots, 0);
    count_.assign(n, 0);
  }
  void push(uint32_t v, uint32_t t) {
    if (count_[v] < kSlots) slots_[std::size_t(v) * kSlots + count_[v]] = t;
    ++count_[v];
  }
  std::size_t size(uint32_t v) const { return count_[v]; }
  bool overflows(uint32_t v) const { return count_[v] > kSlots; }
  std::span<const uint32_t> operator[](uint32_t v) const {
    return {slots_.data() + std::size_t(v) * kSlots, std::min(count_[v], kSlots)};
  }
  void erase(uint32_t v, uint32_t t) {
    uint32_t* const f = slots_.data() + std::size_t(v) * kSlots;
    uint32_t* const end = f + count_[v];
    uint32_t* const at = std::find(f, end, t);
    std::copy(at + 1, end, at);
    --count_[v];
  }
  void clear(uint32_t v) { count_[v] = 0; }

 private:
  std::vector<uint32_t> slots_, count_;
};

class PatchSimplifier {
 public:
  PatchSimplifier(Shared& s, std::vector<uint32_t> global, Owned triangles, const std::vector<uint32_t>& incident)
      : s_(s),
        global_(std::move(global)),
        tris_(std::move(triangles.triangles)),
        head_(std::move(triangles.head)),
        alive_(tris_.size(), 1) {
    // The triangles' points, copied here in the order of their lists: every operation reads them
    // again (7 times each on the bundled frames), from the patch's memory, not the mesh's.
    for (uint32_t& h : head_) {
      uint32_t* link = &h;
      for (uint32_t p = h; p != kNone; p = s_.next[p]) {
        *link = uint32_t(point_.size());
        point_.push_back(s_.point(p));
        point_id_.push_back(p);
        next_.push_back(kNone);
        link = &next_.back();
      }
    }
    const std::size_t n = global_.size();
    pos_.resize(n);
    for (uint32_t v = 0; v < n; ++v) pos_[v] = s_.pos[global_[v]];
    fan_.reset(n);
    for (uint32_t t = 0; t < tris_.size(); ++t)
      for (uint32_t v : tris_[t]) fan_.push(v, t);
    interior_.resize(n);
    stamp_.assign(n, 0);
    // Interior: all of v's triangles are here and form one closed disk. A vertex on a border (a
    // clip's cut), on an edge used twice in a direction or where two fans touch never is, and as
    // only interior vertices' triangles change, it keeps its fan, and stays, through every pass.
    for (uint32_t v = 0; v < n; ++v)
      interior_[v] = !fan_.overflows(v) && fan_.size(v) == incident[global_[v]] && single_fan(v);
  }

  std::size_t collapses = 0, flips = 0;

  void run() {
    for (int round = 0; round < kRounds; ++round) {
      const std::size_t before = collapses;
      collapse_all();
      flip_all();
      if (collapses - before < tris_.size() / 100) break;
    }
  }

  /// The surviving triangles, in the mesh's numbering, with their points; the vertices that moved.
  void emit(Owned& out) const {
    for (uint32_t v = 0; v < global_.size(); ++v)
      if (interior_[v]) s_.pos[global_[v]] = pos_[v];
    const auto id = [&](uint32_t p) { return p == kNone ? kNone : point_id_[p]; };
    for (uint32_t t = 0; t < tris_.size(); ++t)
      if (alive_[t]) {
        out.triangles.push_back({global_[tris_[t][0]], global_[tris_[t][1]], global_[tris_[t][2]]});
        out.head.push_back(id(head_[t]));
        for (uint32_t p = head_[t]; p != kNone; p = next_[p]) s_.next[point_id_[p]] = id(next_[p]);
      }
  }

 private:
  Vec3f at(uint32_t v) const { return pos_[v]; }
  /// Where vertex v is in the operation being weighed: moved_ at place_, the others where they are.
  Vec3f now(uint32_t v) const { return v == moved_ ? place_ : pos_[v]; }

  static uint32_t third(const Triangle& t, uint32_t a, uint32_t b) {
    for (uint32_t c : t)
      if (c != a && c != b) return c;
    return kNone;
  }
  static bool has(const Triangle& t, uint32_t v) { return t[0] == v || t[1] == v || t[2] == v; }

  using Corners = std::array<uint32_t, Fans::kSlots>;

  /// The corners of v's triangles after and before it: fan_[v][k] is (v, ahead[k], behind[k]).
  void around(uint32_t v, Corners& ahead, Corners& behind) const {
    const std::span<const uint32_t> f = fan_[v];
    for (std::size_t k = 0; k < f.size(); ++k) ahead[k] = after(v, f[k]), behind[k] = after(ahead[k], f[k]);
  }

  /// The corners after v in each of its triangles form one cycle (a closed disk around v).
  bool single_fan(uint32_t v) const {
    const std::span<const uint32_t> f = fan_[v];
    if (f.size() < 3) return false;
    Corners ahead, behind;
    around(v, ahead, behind);
    std::size_t k = 0;
    for (std::size_t seen = 1;; ++seen) {
      // The next triangle's corner after v is this one's before v.
      std::size_t next = f.size();
      for (std::size_t j = 0; j < f.size(); ++j)
        if (ahead[j] == behind[k]) {
          if (next != f.size()) return false;
          next = j;
        }
      if (next == f.size()) return false;
      if (next == 0) return seen == f.size();
      if (seen > f.size()) return false;
      k = next;
    }
  }

  /// Triangle t's normal where its corners are now, twice its area long.
  Vec3f plane(uint32_t t) const {
    const Triangle& c = tris_[t];
    return cross(at(c[1]) - at(c[0]), at(c[2]) - at(c[0]));
  }

  /// The corner after v in triangle t.
  uint32_t after(uint32_t v, uint32_t t) const {
    const Triangle& c = tris_[t];
    return c[0] == v ? c[1] : (c[1] == v ? c[2] : c[0]);
  }

  /// The neighbours of an interior vertex (a closed disk: each is the corner after it in exactly
  /// one of its triangles).
  void ring(uint32_t v, std::vector<uint32_t>& out) const {
    out.clear();
    for (uint32_t t : fan_[v]) out.push_back(after(v, t));
  }

  /// Whether every point of the triangles `from` lies within reach of one of `to` (id and
  /// corners): the triangle that held it where it is still there, else the first within reach; its
  /// index in `to` goes to assign_.
  bool rehome(std::span<const uint32_t> from, const std::vector<std::pair<uint32_t, Triangle>>& to) {
    prepare(to);
    moving_.clear();
    assign_.clear();
    for (uint32_t t : from) {
      uint32_t same = kNone;
      for (uint32_t k = 0; k < to.size(); ++k)
        if (to[k].first == t) same = k;
      for (uint32_t p = head_[t]; p != kNone; p = next_[p]) {
        const Vec3f q = point_[p];
        // The triangle it lies over first (the one that held it, then the others), then the
        // one within reach of it: the exact distance only where no projection falls inside.
        const auto over = [&](uint32_t k) { return targets_[k].over(q, s_.reach2); };
        const auto near = [&](uint32_t k) { return targets_[k].within(q, s_.reach2); };
        uint32_t where = same != kNone && over(same) ? same : kNone;
        for (uint32_t k = 0; where == kNone && k < to.size(); ++k)
          if (k != same && over(k)) where = k;
        if (where == kNone && same != kNone && near(same)) where = same;
        for (uint32_t k = 0; where == kNone && k < to.size(); ++k)
          if (k != same && near(k)) where = k;
        if (where == kNone) return false;
        moving_.push_back(p);
        assign_.push_back(where);
      }
    }
    return true;
  }

  /// Prepares targets_ for the triangles of `to` it does not hold yet.
  void prepare(const std::vector<std::pair<uint32_t, Triangle>>& to) {
    for (std::size_t k = prepared_; k < to.size(); ++k) {
      const Triangle& c = to[k].second;
      targets_[k].prepare(now(c[0]), now(c[1]), now(c[2]));
    }
    prepared_ = to.size();
  }

  /// Moves the points rehome() placed, after the triangles of `from` gave them up.
  void commit_rehome(std::span<const uint32_t> from, const std::vector<std::pair<uint32_t, Triangle>>& to) {
    for (uint32_t t : from) head_[t] = kNone;
    for (std::size_t i = 0; i < moving_.size(); ++i) {
      const uint32_t t = to[assign_[i]].first;
      next_[moving_[i]] = head_[t];
      head_[t] = moving_[i];
    }
  }

  /// Whether the new triangle c (replacing `old`; c's corners read where they are in the
  /// operation, old's where they are now) is good: it turns less than 45° from old and less than
  /// 60° from the input's normals at its corners, and its smallest angle is at least 15° or at
  /// least old's.
  bool good(const Triangle& c, const Triangle& old) const {
    const Vec3f a = now(c[0]), b = now(c[1]), d = now(c[2]);
    const Vec3f n = cross(b - a, d - a);
    const Vec3f o = cross(at(old[1]) - at(old[0]), at(old[2]) - at(old[0]));
    if (!(dot(n, o) >= kTurnCos * std::sqrt(length2(n) * length2(o)))) return false;
    const float ln = length(n);
    for (uint32_t k : c)
      if (!(dot(n, s_.normal[global_[k]]) >= kFacingCos * ln)) return false;
    const float cos_new = smallest_angle_cos(a, b, d);
    return cos_new <= kMinAngleCos || cos_new <= smallest_angle_cos(at(old[0]), at(old[1]), at(old[2]));
  }

  std::size_t valence(uint32_t v) const { return fan_.size(v); }
  std::size_t floor_of(uint32_t v) const { return s_.floor_valence[global_[v]]; }

  /// Whether the valences allow u into v, where a and b are the corners across edge uv: neither
  /// falls under its floor, and v does not climb over 9 (or over its own valence).
  bool valences_allow(uint32_t u, uint32_t v, uint32_t a, uint32_t b) const {
    return valence(a) - 1 >= floor_of(a) && valence(b) - 1 >= floor_of(b) &&
           valence(u) + valence(v) - 4 <= std::max(kMaxValence, valence(v));
  }

  /// can_collapse's answer: yes; no whatever v's place (the topology or the valences forbid it);
  /// no with v there (a triangle or the bound), which v elsewhere might pass.
  enum Verdict { kYes, kNever, kNotHere };

  /// Whether u can collapse into v, v staying where it is or (`middle`) moving to meet u
  /// (balanced); if so, from_, to_ and place_ say what collapse() does. ring_u_ holds u's
  /// neighbours, all interior (collapse_all tries no other u).
  Verdict can_collapse(uint32_t u, uint32_t v, bool middle) {
    if (!interior_[v]) return kNever;
    std::array<uint32_t, 2> shared{kNone, kNone};
    std::size_t count = 0;
    for (uint32_t t : fan_[u])
      if (has(tris_[t], v)) {
        if (count == 2) return kNever;
        shared[count++] = t;
      }
    if (count != 2) return kNever;
    const uint32_t a = third(tris_[shared[0]], u, v), b = third(tris_[shared[1]], u, v);
    if (a == b) return kNever;
    if (!valences_allow(u, v, a, b)) return kNever;
    ring(v, ring_v_);
    std::size_t common = 0;
    for (uint32_t w : ring_u_) common += std::find(ring_v_.begin(), ring_v_.end(), w) != ring_v_.end();
    if (common != 2) return kNever;
    moved_ = v;
    place_ = middle ? balanced(u, v) : at(v);
    to_.clear();
    for (uint32_t t : fan_[u]) {
      if (t == shared[0] || t == shared[1]) continue;
      Triangle c = tris_[t];
      for (uint32_t& k : c)
        if (k == u) k = v;
      if (!good(c, tris_[t])) return kNotHere;
      to_.push_back({t, c});
    }
    if (middle)
      for (uint32_t t : fan_[v])
        if (t != shared[0] && t != shared[1] && !good(tris_[t], tris_[t])) return kNotHere;
    // u itself first: the point most likely to be too far, checked before all the others.
    prepared_ = 0;
    prepare(to_);
    const Vec3f xu = at(u);
    if (std::none_of(targets_.begin(), targets_.begin() + std::ptrdiff_t(to_.size()),
                     [&](const Target& m) { return m.within(xu, s_.reach2); }))
      return kNotHere;
    from_.assign(fan_[u].begin(), fan_[u].end());
    for (uint32_t t : fan_[v])
      if (t != shared[0] && t != shared[1]) {
        to_.push_back({t, tris_[t]});
        if (middle) from_.push_back(t);  // v's triangles moved too: their points are checked again
      }
    if (!rehome(from_, to_)) return kNotHere;
    if (middle && !near_input(place_)) return kNotHere;
    shared_ = shared;
    return kYes;
  }

  /// Where v goes when it moves to meet u: the point nearest, in the least-squares sense, to the
  /// planes of both fans' triangles (Garland & Heckbert's placement, over the surface as it is
  /// now), from the midpoint along the directions those planes pin down; the midpoint itself where
  /// that point lies farther from it than half of uv. On a curved surface it sits off the chord,
  /// on the surface's outer side, so the new triangles straddle the surface instead of cutting
  /// under it: fewer triangles meet the bound than with the midpoint
  /// (bench/RESULTS.md#lean-meshes---decimate).
  Vec3f balanced(uint32_t u, uint32_t v) const {
    const Vec3f mid = (at(u) + at(v)) * 0.5f;
    double a[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}, r[3] = {0, 0, 0};
    const auto add = [&](uint32_t t) {
      const Triangle& c = tris_[t];
      const Vec3f m = plane(t);
      const double l = length(m);
      if (!(l > 0)) return;
      const double n[3] = {m[0], m[1], m[2]}, off = double(dot(m, at(c[0]) - mid)) / l;
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) a[i][j] += n[i] * n[j] / l;
        r[i] += n[i] * off;
      }
    };
    for (uint32_t t : fan_[u]) add(t);
    for (uint32_t t : fan_[v])
      if (!has(tris_[t], u)) add(t);
    // Along the eigenvectors the planes pin down (an eigenvalue over a thousandth of the largest);
    // along the others (a flat surface, a crease) v stays at the midpoint.
    const Eigen3<double> e = eigen_sym3(a);
    Vec3f y{0, 0, 0};
    for (int k = 0; k < 3; ++k) {
      if (!(e.values[k] > 1e-3 * e.values[0])) continue;
      const double* w = e.vectors[k];
      const double along = (w[0] * r[0] + w[1] * r[1] + w[2] * r[2]) / e.values[k];
      y += Vec3f{float(w[0] * along), float(w[1] * along), float(w[2] * along)};
    }
    if (!(length2(y) <= length2(at(u) - at(v)) * 0.25f)) return mid;
    return mid + y;
  }
  /// Whether q lies within reach of one of the input triangles whose centroids the operation
  /// hands on (rehome's moving_): a vertex placed off the input surface stays as near it as its
  /// points are to the simplified one. The points alone would not see it leave.
  bool near_input(Vec3f q) const {
    const std::size_t nv = s_.x.size(), nt = s_.input.size();
    for (uint32_t p : moving_) {
      const uint32_t id = point_id_[p];
      if (id < nv || id >= nv + nt) continue;
      const Triangle& c = s_.input[id - nv];
      if (distance2(q, s_.x[c[0]], s_.x[c[1]], s_.x[c[2]], s_.reach2) <= s_.reach2) return true;
    }
    return false;
  }

  void erase_from_fan(uint32_t v, uint32_t t) { fan_.erase(v, t); }

  void collapse(uint32_t u, uint32_t v) {
    commit_rehome(from_, to_);
    if (!(place_ == pos_[v])) {
      pos_[v] = place_;
      s_.merge(global_[u], global_[v]);
    }
    moved_ = kNone;
    for (uint32_t t : shared_) {
      alive_[t] = 0;
      for (uint32_t c : tris_[t]) erase_from_fan(c, t);
    }
    for (uint32_t t : fan_[u]) {
      for (uint32_t& k : tris_[t])
        if (k == u) k = v;
      fan_.push(v, t);
    }
    fan_.clear(u);
    interior_[u] = 0;
    ++collapses;
  }

  struct Candidate {
    double cost;
    uint32_t u, stamp;
    bool operator<(const Candidate& o) const { return cost > o.cost || (cost == o.cost && u > o.u); }
  };

  /// The cost of collapsing u into each of its neighbours v, to `each(t, v, cost)` (t: u's
  /// triangle that runs from u to v): the squared distances of v from the planes of u's triangles,
  /// weighted by their areas — the quadric of the surface as it is now, not of the input
  /// (memoryless, in Lindstrom & Turk's sense), so no vertex carries one. The points keep the
  /// bound; the cost only orders the collapses, which Garland & Heckbert's quadrics of the input
  /// order no better, for more memory (bench/RESULTS.md#lean-meshes---decimate).
  template <class Each>
  void costs(uint32_t u, Each&& each) const {
    const std::span<const uint32_t> fan = fan_[u];
    // Σ m mᵀ / |m| over u's triangles (m: the normal, |m| twice the area): (m·d)² / |m| is the
    // squared distance d moves the plane times twice the area.
    double q[6] = {0, 0, 0, 0, 0, 0};  // xx, xy, xz, yy, yz, zz
    const Vec3f xu = at(u);
    for (uint32_t t : fan) {
      const Vec3f m = plane(t);
      const double l = length(m);
      if (!(l > 0)) continue;
      const double x = m[0], y = m[1], z = m[2], w = 1 / l;
      q[0] += w * x * x, q[1] += w * x * y, q[2] += w * x * z, q[3] += w * y * y, q[4] += w * y * z, q[5] += w * z * z;
    }
    for (std::size_t k = 0; k < fan.size(); ++k) {
      const uint32_t v = after(u, fan[k]);
      const Vec3f d = at(v) - xu;
      const double x = d[0], y = d[1], z = d[2];
      each(k, v, q[0] * x * x + q[3] * y * y + q[5] * z * z + 2 * (q[1] * x * y + q[2] * x * z + q[4] * y * z));
    }
  }

  /// u's cheapest collapse's cost.
  double cost(uint32_t u) const {
    double best = INFINITY;
    costs(u, [&](std::size_t, uint32_t, double c) { best = std::min(best, c); });
    return best;
  }

  void collapse_all() {
    std::priority_queue<Candidate> heap;
    for (uint32_t u = 0; u < global_.size(); ++u)
      if (interior_[u] && !s_.settled[global_[u]]) heap.push({cost(u), u, stamp_[u]});
    std::vector<std::pair<double, uint32_t>> targets;
    std::vector<uint32_t> touched;
    while (!heap.empty()) {
      const Candidate c = heap.top();
      heap.pop();
      const uint32_t u = c.u;
      if (!interior_[u] || c.stamp != stamp_[u]) continue;
      const std::span<const uint32_t> fan = fan_[u];
      Corners ahead, behind;
      around(u, ahead, behind);
      ring_u_.assign(ahead.begin(), ahead.begin() + std::ptrdiff_t(fan.size()));
      // Settled only where the patch's seam did not stop it: a later pass tries it again. A vertex
      // beside the seam cannot go in this pass whatever its target (the link condition needs its
      // neighbours' fans whole).
      const bool whole = std::all_of(ring_u_.begin(), ring_u_.end(), [&](uint32_t w) { return interior_[w]; });
      s_.settled[global_[u]] = whole;
      if (!whole) continue;
      // The neighbours whose collapse passes the valence checks (the cheap part of
      // can_collapse), by cost.
      targets.clear();
      costs(u, [&](std::size_t k, uint32_t v, double price) {
        const uint32_t a = behind[k];  // fan[k] = (u, v, a); the other side (v, u, b)
        uint32_t b = kNone;
        for (std::size_t j = 0; j < fan.size(); ++j)
          if (behind[j] == v && ahead[j] != v) b = ahead[j];
        if (b == kNone || !interior_[v] || !valences_allow(u, v, a, b)) return;
        targets.push_back({price, v});
      });
      std::sort(targets.begin(), targets.end());
      // Into v where it is (the surface's own vertex); where a triangle or the bound refuses that
      // (the surface bends there), v moves to meet u, for the cheapest v the valences allow (moving
      // every refused v takes only a few more triangles off, for more time).
      bool may_move = true;  // only the first v refused where it is may move
      for (const auto& [ignored, v] : targets) {
        const Verdict there = can_collapse(u, v, false);
        if (there == kNever) continue;
        if (there == kNotHere) {
          if (!may_move) continue;
          may_move = false;
          if (can_collapse(u, v, true) != kYes) continue;
        }
        touched = ring_u_;
        if (!(place_ == at(v))) touched.insert(touched.end(), ring_v_.begin(), ring_v_.end());
        collapse(u, v);
        for (uint32_t w : touched) {
          // v's ring can hold a vertex on the seam, which a patch beside may clear at once.
          std::atomic_ref<uint8_t>(s_.settled[global_[w]]).store(0, std::memory_order_relaxed);
          if (interior_[w]) heap.push({cost(w), w, ++stamp_[w]});
        }
        break;
      }
    }
  }

  /// Flips edge ab (triangles t = abc and o = bad) to cd where that brings the four valences
  /// closer to 6 and keeps the bound and the triangles good.
  bool try_flip(uint32_t t, uint32_t a, uint32_t b) {
    if (!interior_[a] || !interior_[b]) return false;
    uint32_t o = kNone;
    for (uint32_t k : fan_[a])
      if (k != t && has(tris_[k], b)) o = k;
    if (o == kNone) return false;
    const uint32_t c = third(tris_[t], a, b), d = third(tris_[o], a, b);
    if (c == d || !interior_[c] || !interior_[d]) return false;
    const auto deviation = [](std::size_t va, std::size_t vb, std::size_t vc, std::size_t vd) {
      const auto dev = [](std::size_t v) { return v > 6 ? v - 6 : 6 - v; };
      return dev(va) + dev(vb) + dev(vc) + dev(vd);
    };
    const std::size_t va = valence(a), vb = valence(b), vc = valence(c), vd = valence(d);
    if (deviation(va - 1, vb - 1, vc + 1, vd + 1) >= deviation(va, vb, vc, vd)) return false;
    if (va - 1 < floor_of(a) || vb - 1 < floor_of(b) || vc + 1 > kMaxValence || vd + 1 > kMaxValence) return false;
    ring(c, ring_v_);
    if (std::find(ring_v_.begin(), ring_v_.end(), d) != ring_v_.end()) return false;
    // t = (a, b, c) in some rotation, o = (b, a, d): the new triangles (c, a, d) and (d, b, c).
    const Triangle made_t{c, a, d}, made_o{d, b, c};
    moved_ = kNone;
    for (const Triangle& m : {made_t, made_o})
      if (!good(m, tris_[t]) || !good(m, tris_[o])) return false;
    pair_ = {t, o};
    to_ = {{t, made_t}, {o, made_o}};
    prepared_ = 0;
    if (!rehome(pair_, to_)) return false;
    commit_rehome(pair_, to_);
    tris_[t] = made_t;
    tris_[o] = made_o;
    erase_from_fan(a, o);
    erase_from_fan(b, t);
    fan_.push(c, o);
    fan_.push(d, t);
    for (uint32_t w : {a, b, c, d}) s_.settled[global_[w]] = 0;
    ++flips;
    return true;
  }

  void flip_all() {
    for (int sweep = 0; sweep < 3; ++sweep) {
      std::size_t done = 0;
      for (uint32_t t = 0; t < tris_.size(); ++t) {
        if (!alive_[t]) continue;
        for (int k = 0; k < 3; ++k) {
          const Triangle& c = tris_[t];
          const uint32_t a = c[std::size_t(k)], b = c[std::size_t((k + 1) % 3)];
          if (a < b && try_flip(t, a, b)) {
            ++done;
            break;
          }
        }
      }
      if (done == 0) break;
    }
  }

  Shared& s_;
  std::vector<uint32_t> global_;
  std::vector<Triangle> tris_;
  std::vector<uint32_t> head_;  ///< per triangle, its first point (in point_)
  /// The points of the patch's triangles: where they are, their ids in Shared, the next of the
  /// same triangle.
  std::vector<Vec3f> point_;
  std::vector<uint32_t> point_id_, next_;
  std::vector<uint8_t> alive_, interior_;
  Fans fan_;
  std::vector<uint32_t> stamp_;
  std::vector<uint32_t> ring_u_, ring_v_, moving_, assign_, pair_;
  std::vector<std::pair<uint32_t, Triangle>> to_;
  /// to_'s triangles prepared (the first prepared_ of them): at most a fan of 9 (or the input's
  /// valence, under 16 slots) and another beside it.
  std::array<Target, 2 * Fans::kSlots> targets_;
  std::size_t prepared_ = 0;
  std::array<uint32_t, 2> shared_{};
  std::vector<Vec3f> pos_;      ///< the local vertices where they are now
  std::vector<uint32_t> from_;  ///< the triangles whose points a collapse hands on
  uint32_t moved_ = kNone;      ///< the vertex the operation weighed moves, to place_
  Vec3f place_{};
};

/// One pass: `current` cut into patches by a grid of side `side` shifted by `offset`, each
/// simplified on its own, in parallel. `current` and the pass's own arrays are let go before the
/// patches' results are joined, so the pass holds at most about two copies of the mesh.
Owned simplify_pass(Shared& s, Owned current, double side, double offset, DecimateOutcome& outcome) {
  const std::vector<Vec3f>& x = s.x;
  const std::vector<Triangle>& tris = current.triangles;
  std::vector<uint32_t> incident(x.size(), 0);
  for_each_index(tris.size(), 4096, [&](std::size_t t) {
    for (uint32_t v : tris[t]) std::atomic_ref<uint32_t>(incident[v]).fetch_add(1, std::memory_order_relaxed);
  });
  // Each triangle's cell, packed 21 bits an axis from the lowest (an axis spanning more cells, a
  // stray particle 16 million spacings away, has its cells merged in runs: larger patches there).
  const auto cell_of = [&](std::size_t t) {
    const Vec3f c = s.centroid(tris[t]);
    std::array<int64_t, 3> i;
    for (int a = 0; a < 3; ++a) i[std::size_t(a)] = int64_t(std::floor((double(c[a]) + offset) / side));
    return i;
  };
  constexpr std::size_t kChunk = 1 << 14;
  std::vector<std::array<int64_t, 6>> bounds((tris.size() + kChunk - 1) / kChunk);  // per chunk: lowest, highest
  for_each_index(bounds.size(), [&](std::size_t k) {
    std::array<int64_t, 6> b{INT64_MAX, INT64_MAX, INT64_MAX, INT64_MIN, INT64_MIN, INT64_MIN};
    for (std::size_t t = k * kChunk, end = std::min(tris.size(), t + kChunk); t != end; ++t) {
      const std::array<int64_t, 3> i = cell_of(t);
      for (std::size_t a = 0; a < 3; ++a) b[a] = std::min(b[a], i[a]), b[a + 3] = std::max(b[a + 3], i[a]);
    }
    bounds[k] = b;
  });
  std::array<int64_t, 3> lo{INT64_MAX, INT64_MAX, INT64_MAX}, hi{INT64_MIN, INT64_MIN, INT64_MIN}, run{1, 1, 1};
  for (const auto& b : bounds)
    for (std::size_t a = 0; a < 3; ++a) lo[a] = std::min(lo[a], b[a]), hi[a] = std::max(hi[a], b[a + 3]);
  constexpr int64_t kAxis = int64_t(1) << 21;
  for (std::size_t a = 0; a < 3 && !tris.empty(); ++a) run[a] = (hi[a] - lo[a]) / kAxis + 1;
  std::vector<std::pair<uint64_t, uint32_t>> cells(tris.size());
  for_each_index(tris.size(), 4096, [&](std::size_t t) {
    const std::array<int64_t, 3> i = cell_of(t);
    uint64_t key = 0;
    for (std::size_t a = 0; a < 3; ++a) key = key << 21 | uint64_t((i[a] - lo[a]) / run[a]);
    cells[t] = {key, uint32_t(t)};
  });
  sort(Host{}, cells.begin(), cells.end());
  std::vector<std::size_t> starts;
  for (std::size_t i = 0; i < cells.size(); ++i)
    if (i == 0 || cells[i].first != cells[i - 1].first) starts.push_back(i);
  starts.push_back(cells.size());
  const std::size_t patches = starts.size() - 1;
  std::vector<Owned> results(patches);
  std::vector<std::size_t> collapses(patches), flips(patches);
  for_each_index(patches, [&](std::size_t p) {
    Owned triangles;
    const std::size_t count = starts[p + 1] - starts[p];
    triangles.triangles.reserve(count);
    triangles.head.reserve(count);
    // The patch's vertices, numbered in the mesh's order: each corner finds its vertex's first
    // number through an open-addressing table (at most a quarter full), then the numbers are
    // ranked.
    const int bits = int(std::bit_width(4 * count - 1));
    std::vector<std::pair<uint32_t, uint32_t>> table(std::size_t(1) << bits, {kNone, 0});
    std::vector<std::pair<uint32_t, uint32_t>> seen;  // a vertex, its first number
    for (std::size_t i = starts[p]; i < starts[p + 1]; ++i) {
      Triangle t = tris[cells[i].second];
      for (uint32_t& v : t) {
        std::size_t slot = (v * 0x9E3779B1u) >> (32 - bits);
        while (table[slot].first != kNone && table[slot].first != v) slot = (slot + 1) & (table.size() - 1);
        if (table[slot].first == kNone)
          table[slot] = {v, uint32_t(seen.size())}, seen.push_back({v, uint32_t(seen.size())});
        v = table[slot].second;
      }
      triangles.triangles.push_back(t);
      triangles.head.push_back(current.head[cells[i].second]);
    }
    std::sort(seen.begin(), seen.end());
    std::vector<uint32_t> global(seen.size()), rank(seen.size());
    for (uint32_t k = 0; k < seen.size(); ++k) global[k] = seen[k].first, rank[seen[k].second] = k;
    for (Triangle& t : triangles.triangles)
      for (uint32_t& v : t) v = rank[v];
    PatchSimplifier patch(s, std::move(global), std::move(triangles), incident);
    patch.run();
    patch.emit(results[p]);
    collapses[p] = patch.collapses;
    flips[p] = patch.flips;
  });
  current = {};
  cells = {};
  incident = {};
  Owned out;
  std::size_t total = 0;
  for (const Owned& r : results) total += r.triangles.size();
  out.triangles.reserve(total);
  out.head.reserve(total);
  for (std::size_t p = 0; p < patches; ++p) {
    out.triangles.insert(out.triangles.end(), results[p].triangles.begin(), results[p].triangles.end());
    out.head.insert(out.head.end(), results[p].head.begin(), results[p].head.end());
    results[p] = {};
    outcome.collapses += collapses[p];
    outcome.flips += flips[p];
  }
  return out;
}

}  // namespace

DecimateOutcome decimate(TriangleMesh& mesh, double bound, double cell) {
  DecimateOutcome outcome;
  outcome.triangles_before = outcome.triangles_after = mesh.triangles.size();
  if (!(bound > 0) || !(cell > 0) || mesh.triangles.empty()) return outcome;
  const std::vector<Vec3f>& x = mesh.vertices;
  const std::size_t nv = x.size(), nt = mesh.triangles.size();
  Shared s{x,
           x,
           mesh.normals,
           mesh.attributes,
           {},
           {},
           std::vector<uint8_t>(nv, 0),
           {},
           std::vector<uint8_t>(nv, 0),
           float(kMargin * kMargin * bound * bound),
           {}};
  Owned current{{}, std::vector<uint32_t>(nt, kNone)};
  {
    const std::vector<Triangle>& tris = mesh.triangles;
    s.normal = vertex_normals(x, tris);
    // Each vertex's valence and first triangle; each triangle's first edge midpoint.
    std::vector<uint32_t> count(nv, 0), first(nv, kNone), mids(nt + 1, 0);
    for (uint32_t t = 0; t < nt; ++t) {
      const Triangle& c = tris[t];
      for (uint32_t v : c) ++count[v], first[v] = std::min(first[v], t);
      mids[t + 1] = mids[t] + uint32_t(c[0] < c[1]) + uint32_t(c[1] < c[2]) + uint32_t(c[2] < c[0]);
    }
    for (std::size_t v = 0; v < nv; ++v) s.floor_valence[v] = uint8_t(std::min<uint32_t>(kMinValence, count[v]));
    // The points: the vertices (each held by its first triangle), the triangles' centroids
    // (computed from the input's triangles, kept for near_input anyway) and the edges' midpoints
    // (each held by the triangle where the edge runs from the lower index).
    s.midpoints.resize(mids[nt]);
    s.next.assign(nv + nt + s.midpoints.size(), kNone);
    for_each_index(nt, 4096, [&](std::size_t t) {
      const Triangle& c = tris[t];
      uint32_t& head = current.head[t];
      const auto hold = [&](std::size_t p) {
        s.next[p] = head;
        head = uint32_t(p);
      };
      hold(nv + t);
      std::size_t mid = mids[t];
      for (int k = 0; k < 3; ++k) {
        const uint32_t from = c[std::size_t(k)], to = c[std::size_t((k + 1) % 3)];
        if (from < to) s.midpoints[mid] = (x[from] + x[to]) * 0.5f, hold(nv + nt + mid++);
      }
      for (uint32_t v : c)
        if (first[v] == t) hold(v);
    });
  }
  s.input = mesh.triangles;
  current.triangles = std::move(mesh.triangles);  // the simplification's input from here on
  for (int pass = 0; pass < kDecimatePasses; ++pass) {
    const std::size_t before = current.triangles.size();
    const double offset = std::fmod(pass * 0.6180339887498949, 1.0) * cell;
    current = simplify_pass(s, std::move(current), cell, offset, outcome);
    ++outcome.rounds;
    if (double(current.triangles.size()) > 0.98 * double(before)) break;
  }
  // The largest distance of a point from the triangle that holds it.
  std::vector<float> farthest(current.triangles.size(), 0);
  for_each_index(farthest.size(), 1024, [&](std::size_t t) {
    const Triangle& c = current.triangles[t];
    for (uint32_t p = current.head[t]; p != kNone; p = s.next[p])
      farthest[t] = std::max(farthest[t], distance2(s.point(p), s.pos[c[0]], s.pos[c[1]], s.pos[c[2]], s.reach2));
  });
  if (!farthest.empty()) outcome.max_error = std::sqrt(double(*std::max_element(farthest.begin(), farthest.end())));
  mesh.triangles.swap(current.triangles);
  mesh.vertices = std::move(s.pos);
  drop_unused_vertices(mesh);
  outcome.triangles_after = mesh.triangles.size();
  return outcome;
}

}  // namespace meniscus
