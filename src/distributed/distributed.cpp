// meniscus — one frame over several processes: slabs, halos, owned pieces and their weld
// (include/meniscus/distributed.hpp).
#include "meniscus/distributed.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <tuple>

#include "common/primitives.hpp"
#include "extract/field_band.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/reconstruct.hpp"
#include "mesh/vertex_order_impl.hpp"
#include "pipeline/stage_plan.hpp"
#include "mesh/normals.hpp"

namespace meniscus {

double Decomposition::lo(int rank) const {
  return rank == 0 ? -std::numeric_limits<double>::infinity() : cuts.at(std::size_t(rank - 1));
}
double Decomposition::hi(int rank) const {
  return rank == ranks - 1 ? std::numeric_limits<double>::infinity() : cuts.at(std::size_t(rank));
}

double halo_width(const Params& p) {
  return local_reach(p) + 2 * longest_triangle_edge(p.extract, p.voxel_size) + p.spacing;
}

Reduce local_reduce() {
  return {[](std::vector<float>&) {}, [](std::vector<uint64_t>&) {}};
}

namespace {

/// A float's bits as an unsigned key in the floats' order (−0 before +0; NaN are not given).
uint32_t order_key(float x) {
  const uint32_t b = std::bit_cast<uint32_t>(x);
  return (b & 0x80000000u) ? ~b : (b | 0x80000000u);
}
float from_order_key(uint32_t k) {
  return std::bit_cast<float>((k & 0x80000000u) ? (k & 0x7fffffffu) : ~k);
}

}  // namespace

std::vector<float> select_parts(const std::vector<float>& values, const std::vector<uint64_t>& ks, const Reduce& reduce) {
  const std::size_t q = ks.size();
  std::vector<uint32_t> prefix(q, 0);
  std::vector<uint64_t> rank = ks;  // the rank still sought among the keys that match the prefix
  for (int shift = 24; shift >= 0; shift -= 8) {
    const uint32_t high = shift == 24 ? 0 : ~uint32_t(0) << (shift + 8);
    std::vector<uint64_t> counts(256 * q, 0);
    for (float v : values) {
      const uint32_t k = order_key(v);
      for (std::size_t i = 0; i < q; ++i)
        if ((k & high) == prefix[i]) ++counts[256 * i + ((k >> shift) & 255u)];
    }
    reduce.sum(counts);
    for (std::size_t i = 0; i < q; ++i) {
      uint32_t bucket = 0;
      while (bucket < 255 && rank[i] >= counts[256 * i + bucket]) rank[i] -= counts[256 * i + bucket++];
      prefix[i] |= bucket << shift;
    }
  }
  std::vector<float> out(q);
  for (std::size_t i = 0; i < q; ++i) out[i] = from_order_key(prefix[i]);
  return out;
}

Decomposition decompose(const ParticleSet& particles, const Params& p, int ranks) {
  return decompose_parts(particles, particles.size(), p, ranks, local_reduce());
}

Decomposition decompose_parts(const ParticleSet& part, std::size_t total, const Params& p, int ranks,
                              const Reduce& reduce) {
  if (ranks < 1) throw InvalidParameter(fmt::format("ranks = {}: must be ≥ 1", ranks));
  Decomposition d;
  d.ranks = ranks;
  d.halo = halo_width(p);
  if (ranks == 1 || total == 0) {
    d.cuts.assign(std::size_t(ranks - 1), 0.0);
    if (total == 0) return d;
  }
  std::vector<float> box(6, INFINITY);  // lo, −hi
  for (const Vec3f& x : part.positions)
    for (int c = 0; c < 3; ++c)
      box[std::size_t(c)] = std::min(box[std::size_t(c)], x[c]), box[std::size_t(c) + 3] = std::min(box[std::size_t(c) + 3], -x[c]);
  reduce.min(box);
  const Vec3f extent{-box[3] - box[0], -box[4] - box[1], -box[5] - box[2]};
  d.axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
  if (ranks == 1) return d;

  std::vector<float> along(part.size());
  for (std::size_t i = 0; i < along.size(); ++i) along[i] = part.positions[i][d.axis];
  std::vector<uint64_t> ks;
  for (int r = 1; r < ranks; ++r) ks.push_back(uint64_t(total) * uint64_t(r) / uint64_t(ranks));
  const std::vector<float> quantiles = select_parts(along, ks, reduce);
  // Aligned to the field's blocks, so a block (and a lattice cell) never straddles two slabs.
  const StagePlan plan = plan_stages(p);
  const double block = double(plan.lattice.cell_size) * plan.lattice.block_cells();
  double previous = -std::numeric_limits<double>::infinity();
  for (int r = 1; r < ranks; ++r) {
    const double cut = std::max(previous, std::round(double(quantiles[std::size_t(r - 1)]) / block) * block);
    d.cuts.push_back(cut);
    previous = cut;
  }
  return d;
}

ParticleSet slab_particles(const ParticleSet& particles, const Decomposition& d, int rank) {
  const double lo = d.lo(rank) - d.halo, hi = d.hi(rank) + d.halo;
  std::vector<std::size_t> keep;
  for (std::size_t i = 0; i < particles.size(); ++i) {
    const double x = particles.positions[i][d.axis];
    if (x >= lo && x < hi) keep.push_back(i);
  }
  ParticleSet out;
  out.positions.reserve(keep.size());
  for (std::size_t i : keep) out.positions.push_back(particles.positions[i]);
  for (const Attribute& a : particles.attributes) {
    Attribute b{a.name, a.components, a.integer, {}};
    const std::size_t k = std::size_t(a.components);
    b.values.reserve(keep.size() * k);
    for (std::size_t i : keep) b.values.insert(b.values.end(), a.values.begin() + std::ptrdiff_t(i * k),
                                               a.values.begin() + std::ptrdiff_t((i + 1) * k));
    out.attributes.push_back(std::move(b));
  }
  return out;
}

namespace {

/// The centroid of a triangle along `axis`, the same whatever the order of its corners.
double centroid(const TriangleMesh& mesh, const Triangle& t, int axis) {
  std::array<double, 3> c{mesh.vertices[t[0]][axis], mesh.vertices[t[1]][axis], mesh.vertices[t[2]][axis]};
  std::sort(c.begin(), c.end());
  return (c[0] + c[1] + c[2]) / 3;
}

/// A vertex's identity: its coordinates' bits, ordered by Z-order first.
struct VertexKey {
  uint32_t morton;
  std::array<uint32_t, 3> bits;
  auto operator<=>(const VertexKey&) const = default;
};

VertexKey key_of(Vec3f x, float inv_cell) {
  return {morton_key(x, inv_cell), {std::bit_cast<uint32_t>(x.x), std::bit_cast<uint32_t>(x.y), std::bit_cast<uint32_t>(x.z)}};
}

}  // namespace

int owner_of(const Decomposition& d, double c) {
  return int(std::upper_bound(d.cuts.begin(), d.cuts.end(), c) - d.cuts.begin());
}

void keep_owned(TriangleMesh& mesh, const Decomposition& d, int rank) {
  const double lo = d.lo(rank), hi = d.hi(rank);
  std::vector<uint32_t> new_index(mesh.vertices.size(), UINT32_MAX);
  std::size_t kept = 0;
  for (const Triangle& t : mesh.triangles) {
    const double c = centroid(mesh, t, d.axis);
    if (c < lo || c >= hi) continue;
    mesh.triangles[kept++] = t;
    for (uint32_t v : t) new_index[v] = 0;
  }
  mesh.triangles.resize(kept);
  // The vertices kept, moved down in place (a vertex's new index is never above its old one).
  uint32_t next = 0;
  const bool normals = mesh.normals.size() == mesh.vertices.size();
  for (uint32_t v = 0; v < mesh.vertices.size(); ++v) {
    if (new_index[v] == UINT32_MAX) continue;
    new_index[v] = next;
    mesh.vertices[next] = mesh.vertices[v];
    if (normals) mesh.normals[next] = mesh.normals[v];
    for (Attribute& a : mesh.attributes) {
      const std::size_t k = std::size_t(a.components);
      std::copy_n(a.values.begin() + std::ptrdiff_t(v * k), k, a.values.begin() + std::ptrdiff_t(next * k));
    }
    ++next;
  }
  for (Triangle& t : mesh.triangles)
    for (uint32_t& v : t) v = new_index[v];
  mesh.vertices.resize(next);
  mesh.vertices.shrink_to_fit();
  if (normals) mesh.normals.resize(next), mesh.normals.shrink_to_fit();
  for (Attribute& a : mesh.attributes) a.values.resize(std::size_t(next) * std::size_t(a.components)), a.values.shrink_to_fit();
  mesh.triangles.shrink_to_fit();
}

OrderedPart ordered_part(TriangleMesh mesh, std::vector<VertexOrderKey> keys, const Decomposition& d, int rank,
                         const std::array<double, 3>& origin) {
  const std::size_t nv = mesh.vertices.size();
  if (keys.size() != nv)
    throw std::logic_error(fmt::format("ordered_part: {} keys for {} vertices", keys.size(), nv));
  for (std::size_t v = 1; v < nv; ++v)
    if (!(keys[v - 1] < keys[v]))
      throw std::logic_error(fmt::format("ordered_part: vertices {} and {} are not in their keys' order", v - 1, v));
  const auto smallest = [](const Triangle& t) { return std::min({t[0], t[1], t[2]}); };
  // Per vertex: the lowest and highest rank that owns a triangle on it (the lowest writes it),
  // whether this rank owns one, and its run (the triangles whose smallest vertex it is).
  std::vector<int32_t> lowest(nv, INT32_MAX), highest(nv, -1);
  std::vector<uint8_t> used(nv, 0);
  std::vector<uint32_t> run_of(nv, 0);
  OrderedPart part;
  std::size_t kept = 0, run = 0;
  uint32_t before = 0;  // the previous triangle's smallest vertex (its slot may hold an owned one by now)
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const Triangle tri = mesh.triangles[t];
    const uint32_t first = smallest(tri);
    if (t > 0 && first < before)
      throw std::logic_error(fmt::format("ordered_part: triangle {} comes before triangle {} by its smallest vertex", t,
                                         t - 1));
    if (t > 0 && first != before) run = t;
    before = first;
    ++run_of[first];
    const int32_t owner = owner_of(d, centroid(mesh, tri, d.axis) + origin[std::size_t(d.axis)]);
    for (uint32_t v : tri) lowest[v] = std::min(lowest[v], owner), highest[v] = std::max(highest[v], owner);
    if (owner != rank) continue;
    for (uint32_t v : tri) used[v] = 1;
    // In place: the owned triangles move down, their ties and terms beside them.
    const std::vector<Vec3f>& x = mesh.vertices;
    part.crosses.push_back(cross(x[tri[1]] - x[tri[0]], x[tri[2]] - x[tri[0]]));
    part.ties.push_back(uint32_t(t - run));
    mesh.triangles[kept++] = tri;
  }
  mesh.triangles.resize(kept);
  // The written vertices move down in place, in order; the foreign ones get the indices after them.
  // (A foreign key is read before the written vertices' keys moving down reach its place.)
  const auto total_written = std::size_t(std::count(lowest.begin(), lowest.end(), rank));
  std::vector<uint32_t> index(nv, UINT32_MAX);
  uint32_t written = 0;
  for (uint32_t v = 0; v < nv; ++v) {
    if (used[v] && lowest[v] < rank) {
      index[v] = uint32_t(total_written + part.foreign.size());
      part.foreign.push_back(keys[v]);
      part.foreign_writer.push_back(lowest[v]);
    }
    if (lowest[v] != rank) continue;
    index[v] = written;
    mesh.vertices[written] = mesh.vertices[v];
    for (Attribute& a : mesh.attributes) {
      const std::size_t k = std::size_t(a.components);
      std::copy_n(a.values.begin() + std::ptrdiff_t(v * k), k, a.values.begin() + std::ptrdiff_t(written * k));
    }
    part.shared_up.push_back(highest[v] > rank);
    part.runs.push_back(run_of[v]);
    keys[written] = keys[v];
    ++written;
  }
  for (Triangle& t : mesh.triangles)
    for (uint32_t& v : t) v = index[v];
  std::vector<int32_t>().swap(lowest), std::vector<int32_t>().swap(highest), std::vector<uint32_t>().swap(index);
  std::vector<uint8_t>().swap(used), std::vector<uint32_t>().swap(run_of);
  // The normals are the gathered mesh's (gather_normals), not the slab's.
  std::vector<Vec3f>().swap(mesh.normals);
  mesh.vertices.resize(written);
  // Where the frame is: the slab was surfaced about the frame's local origin (its normals' terms
  // above too, as one process computes them), and is written back as one process writes it.
  if (origin[0] != 0 || origin[1] != 0 || origin[2] != 0)
    for (Vec3f& v : mesh.vertices)
      v = Vec3f{float(double(v.x) + origin[0]), float(double(v.y) + origin[1]), float(double(v.z) + origin[2])};
  mesh.vertices.shrink_to_fit();
  for (Attribute& a : mesh.attributes) a.values.resize(std::size_t(written) * std::size_t(a.components)), a.values.shrink_to_fit();
  keys.resize(written);
  keys.shrink_to_fit();
  part.triangles = std::move(mesh.triangles);
  part.triangles.shrink_to_fit();
  mesh.triangles = {};
  part.written = std::move(mesh);
  part.keys = std::move(keys);
  return part;
}

PlacedPart place_part(const OrderedPart& part, const VertexPlaces& own, const VertexPlaces& foreign) {
  const std::size_t written = part.keys.size(), nf = part.foreign.size();
  if (own.index.size() != written || own.first_triangle.size() != written || foreign.index.size() != nf ||
      foreign.first_triangle.size() != nf || part.runs.size() != written || part.ties.size() != part.triangles.size() ||
      part.crosses.size() != part.triangles.size() || part.foreign_writer.size() != nf)
    throw InvalidParameter(fmt::format("the gather: the places of {} own and {} foreign vertices for a part of {} and {}",
                                       own.index.size(), foreign.index.size(), written, nf));
  PlacedPart placed;
  placed.vertex_index = own.index;
  placed.triangles.resize(part.triangles.size());
  placed.triangle_index.resize(part.triangles.size());
  for (std::size_t t = 0; t < part.triangles.size(); ++t) {
    const Triangle& local = part.triangles[t];
    Triangle& global = placed.triangles[t];
    for (int c = 0; c < 3; ++c) {
      const uint32_t v = local[std::size_t(c)];
      if (v >= written + nf)
        throw InvalidParameter(fmt::format("the gather: a triangle on vertex {} of a part with {}", v, written + nf));
      global[std::size_t(c)] = v < written ? own.index[v] : foreign.index[v - written];
    }
    // Its smallest vertex: the corner first in the gathered mesh (own and foreign vertices are
    // numbered apart in the part).
    std::size_t corner = 0;
    for (std::size_t c = 1; c < 3; ++c)
      if (global[c] < global[corner]) corner = c;
    const uint32_t first = local[corner];
    if (first < written && part.ties[t] >= part.runs[first])
      throw InvalidParameter(
          fmt::format("the gather: triangle {} is tie {} of a run of {}", t, part.ties[t], part.runs[first]));
    const uint64_t place =
        uint64_t(first < written ? own.first_triangle[first] : foreign.first_triangle[first - written]) + part.ties[t];
    if (place >= UINT32_MAX) throw InvalidParameter("the gather: 2^32 or more triangles");
    placed.triangle_index[t] = uint32_t(place);
  }
  return placed;
}

void normal_chunk_bounds(const PlacedPart& placed, std::size_t triangles, std::vector<uint32_t>& lo,
                         std::vector<uint32_t>& hi) {
  const std::size_t chunks = (triangles + kNormalChunk - 1) / kNormalChunk;
  lo.assign(chunks, UINT32_MAX);
  hi.assign(chunks, 0);
  for (std::size_t t = 0; t < placed.triangles.size(); ++t) {
    const std::size_t c = placed.triangle_index[t] / kNormalChunk;
    if (c >= chunks)
      throw InvalidParameter(fmt::format("the gather: triangle {} of {}", placed.triangle_index[t], triangles));
    for (const uint32_t v : placed.triangles[t]) lo[c] = std::min(lo[c], v), hi[c] = std::max(hi[c], v);
  }
}

std::size_t normal_stride(const std::vector<uint32_t>& lo, const std::vector<uint32_t>& hi) {
  return normal_wave_stride(lo, hi);
}

namespace {

uint64_t term_order(uint32_t triangle, std::size_t stride) {
  return uint64_t(triangle / kNormalChunk % stride) << 32 | triangle;
}

}  // namespace

std::vector<std::vector<NormalTerm>> foreign_terms(const OrderedPart& part, const PlacedPart& placed,
                                                   std::size_t stride, int ranks) {
  std::vector<std::vector<NormalTerm>> out(static_cast<std::size_t>(ranks));
  const std::size_t written = part.keys.size();
  for (std::size_t t = 0; t < part.triangles.size(); ++t)
    for (const uint32_t v : part.triangles[t]) {
      if (v < written) continue;
      const int32_t writer = part.foreign_writer.at(v - written);
      if (writer < 0 || writer >= ranks)
        throw InvalidParameter(fmt::format("the gather: a vertex written by rank {}", writer));
      out[std::size_t(writer)].push_back({part.foreign[v - written], term_order(placed.triangle_index[t], stride),
                                          part.crosses[t], 0});
    }
  return out;
}

void gather_normals(OrderedPart& part, const PlacedPart& placed, std::size_t stride, std::vector<NormalTerm> received) {
  const std::size_t written = part.keys.size();
  struct Term {
    uint32_t vertex;
    uint64_t order;
    Vec3f cross;
  };
  std::vector<Term> terms;
  terms.reserve(3 * part.triangles.size() + received.size());
  for (std::size_t t = 0; t < part.triangles.size(); ++t)
    for (const uint32_t v : part.triangles[t])
      if (v < written) terms.push_back({v, term_order(placed.triangle_index[t], stride), part.crosses[t]});
  for (const NormalTerm& r : received) {
    const auto it = std::lower_bound(part.keys.begin(), part.keys.end(), r.vertex);
    if (it == part.keys.end() || *it != r.vertex)
      throw InvalidParameter(fmt::format("the gather: a normal's term at a vertex (order key {}, {}) this part does not write",
                                         r.vertex.morton, r.vertex.edge));
    terms.push_back({uint32_t(it - part.keys.begin()), r.order, r.cross});
  }
  std::vector<NormalTerm>().swap(received);
  std::sort(terms.begin(), terms.end(),
            [](const Term& a, const Term& b) { return std::tie(a.vertex, a.order) < std::tie(b.vertex, b.order); });
  // As vertex_normals: each sum from zero, its terms in order, then normalised.
  std::vector<Vec3f>& n = part.written.normals;
  n.assign(written, Vec3f{0, 0, 0});
  for (const Term& term : terms) n[term.vertex] += term.cross;
  for (Vec3f& normal : n) normal = normalized(normal);
}

OrderedGather::KeyChunk key_chunk(const OrderedPart& part, std::size_t first) {
  const std::size_t n = part.keys.size(), begin = std::min(first, n);
  const std::size_t end = std::min(n, first + OrderedGather::kChunk);
  const auto at = [](std::size_t i) { return std::ptrdiff_t(i); };
  return {{part.keys.begin() + at(begin), part.keys.begin() + at(end)},
          {part.shared_up.begin() + at(begin), part.shared_up.begin() + at(end)},
          {part.runs.begin() + at(begin), part.runs.begin() + at(end)}};
}

OrderedGather::VertexChunk vertex_chunk(const OrderedPart& part, const PlacedPart& placed, std::size_t first) {
  const TriangleMesh& w = part.written;
  const std::size_t n = w.vertices.size(), begin = std::min(first, n);
  const std::size_t end = std::min(n, first + OrderedGather::kChunk);
  const auto at = [](std::size_t i) { return std::ptrdiff_t(i); };
  OrderedGather::VertexChunk c;
  c.index.assign(placed.vertex_index.begin() + at(begin), placed.vertex_index.begin() + at(end));
  c.vertices.vertices.assign(w.vertices.begin() + at(begin), w.vertices.begin() + at(end));
  if (w.normals.size() == n && n > 0)
    c.vertices.normals.assign(w.normals.begin() + at(begin), w.normals.begin() + at(end));
  for (const Attribute& a : w.attributes) {
    const std::size_t k = std::size_t(a.components);
    c.vertices.attributes.push_back(
        {a.name, a.components, a.integer, {a.values.begin() + at(begin * k), a.values.begin() + at(end * k)}});
  }
  return c;
}

OrderedGather::TriangleChunk triangle_chunk(const PlacedPart& placed, std::size_t first) {
  const std::size_t n = placed.triangles.size(), begin = std::min(first, n);
  const std::size_t end = std::min(n, first + OrderedGather::kChunk);
  const auto at = [](std::size_t i) { return std::ptrdiff_t(i); };
  return {{placed.triangle_index.begin() + at(begin), placed.triangle_index.begin() + at(end)},
          {placed.triangles.begin() + at(begin), placed.triangles.begin() + at(end)}};
}

OrderedGather::OrderedGather(std::size_t parts) : parts_(parts) {}

namespace {

/// The parts whose current chunk is not used up, smallest head first (a binary heap over part
/// numbers with the parts' heads as keys).
template <class Key>
class Heads {
 public:
  explicit Heads(std::function<Key(std::size_t)> head) : head_(std::move(head)) {}
  void push(std::size_t part) {
    parts_.push_back(part);
    std::push_heap(parts_.begin(), parts_.end(), later());
  }
  bool empty() const { return parts_.empty(); }
  std::size_t pop() {
    std::pop_heap(parts_.begin(), parts_.end(), later());
    const std::size_t part = parts_.back();
    parts_.pop_back();
    return part;
  }

 private:
  auto later() const {
    return [this](std::size_t a, std::size_t b) { return head_(b) < head_(a); };
  }
  std::function<Key(std::size_t)> head_;
  std::vector<std::size_t> parts_;
};

bool same_layout(const TriangleMesh& a, const TriangleMesh& b) {
  if (a.attributes.size() != b.attributes.size()) return false;
  for (std::size_t i = 0; i < a.attributes.size(); ++i)
    if (a.attributes[i].name != b.attributes[i].name || a.attributes[i].components != b.attributes[i].components ||
        a.attributes[i].integer != b.attributes[i].integer)
      return false;
  return true;
}

/// Merges parts' chunks by the index of their elements, which must run 0, 1 … expected − 1 over
/// all the parts; `append(batch, chunk, i)` takes a chunk's element i, `check` each chunk as it
/// comes.
template <class Chunk, class Batch, class Append>
void merge_by_index(std::size_t parts, const std::function<Chunk(std::size_t)>& next, const char* what,
                    std::size_t expected, Batch batch, const std::function<void(const Batch&)>& emit, Append&& append,
                    const std::function<void(std::size_t, const Chunk&)>& check) {
  std::vector<Chunk> chunk(parts);
  std::vector<std::size_t> at(parts, 0);
  const auto take = [&](std::size_t p) {
    chunk[p] = next(p);
    at[p] = 0;
    check(p, chunk[p]);
    return !chunk[p].index.empty();
  };
  Heads<uint32_t> heads([&](std::size_t p) { return chunk[p].index[at[p]]; });
  for (std::size_t p = 0; p < parts; ++p)
    if (take(p)) heads.push(p);
  const Batch empty = batch;
  std::size_t count = 0, in_batch = 0;
  while (!heads.empty()) {
    const std::size_t p = heads.pop();
    const uint32_t index = chunk[p].index[at[p]];
    if (index != count)
      throw InvalidParameter(
          fmt::format("the gather: part {} gave {} {} where {} {} was expected", p, what, index, what, count));
    append(batch, chunk[p], at[p]);
    ++count;
    if (++at[p] == chunk[p].index.size()) {
      if (take(p)) heads.push(p);
    } else {
      heads.push(p);
    }
    if (++in_batch == OrderedGather::kChunk) {
      emit(batch);
      batch = empty, in_batch = 0;
    }
  }
  if (in_batch > 0) emit(batch);
  if (count != expected)
    throw InvalidParameter(fmt::format("the gather: the parts gave {} {}s of {}", count, what, expected));
}

}  // namespace

std::size_t OrderedGather::number_vertices(const std::function<KeyChunk(std::size_t)>& next,
                                           const std::function<void(std::size_t, VertexPlaces)>& placed) {
  std::vector<KeyChunk> chunk(parts_);
  std::vector<std::size_t> at(parts_, 0);
  std::vector<VertexPlaces> places(parts_);
  const auto take = [&](std::size_t p) {
    chunk[p] = next(p);
    at[p] = 0;
    const KeyChunk& c = chunk[p];
    if (c.shared_up.size() != c.keys.size() || c.runs.size() != c.keys.size())
      throw InvalidParameter(fmt::format("the gather: part {} sent {} keys with {} seam flags and {} runs", p,
                                         c.keys.size(), c.shared_up.size(), c.runs.size()));
    return !c.keys.empty();
  };
  Heads<VertexOrderKey> heads([&](std::size_t p) { return chunk[p].keys[at[p]]; });
  for (std::size_t p = 0; p < parts_; ++p)
    if (take(p)) heads.push(p);
  seams_.clear();
  vertices_ = triangles_ = 0;
  VertexOrderKey last;
  while (!heads.empty()) {
    const std::size_t p = heads.pop();
    const KeyChunk& c = chunk[p];
    const std::size_t i = at[p];
    const VertexOrderKey key = c.keys[i];
    if (vertices_ > 0 && !(last < key))
      throw InvalidParameter(fmt::format("the gather: part {}'s vertex (order key {}, {}) {} the vertex before it", p,
                                         key.morton, key.edge, key == last ? "was written already, as" : "comes before"));
    if (vertices_ >= UINT32_MAX || triangles_ + c.runs[i] >= UINT32_MAX)
      throw InvalidParameter("the gather: 2^32 or more vertices or triangles");
    last = key;
    const uint32_t index = uint32_t(vertices_++), first_triangle = uint32_t(triangles_);
    triangles_ += c.runs[i];
    if (c.shared_up[i]) seams_.push_back({key, index, first_triangle});
    places[p].index.push_back(index);
    places[p].first_triangle.push_back(first_triangle);
    if (++at[p] == c.keys.size()) {
      placed(p, std::move(places[p]));
      places[p] = {};
      if (take(p)) heads.push(p);
    } else {
      heads.push(p);
    }
  }
  std::sort(seams_.begin(), seams_.end(), [](const Seam& a, const Seam& b) { return a.key < b.key; });
  return vertices_;
}

VertexPlaces OrderedGather::seam_places(const std::vector<VertexOrderKey>& keys) const {
  VertexPlaces out;
  for (const VertexOrderKey& key : keys) {
    const auto it =
        std::lower_bound(seams_.begin(), seams_.end(), key, [](const Seam& s, const VertexOrderKey& k) { return s.key < k; });
    if (it == seams_.end() || it->key != key)
      throw InvalidParameter(
          fmt::format("the gather: a seam vertex (order key {}, {}) that no lower rank wrote", key.morton, key.edge));
    out.index.push_back(it->index);
    out.first_triangle.push_back(it->first_triangle);
  }
  return out;
}

void OrderedGather::merge_vertices(const std::function<VertexChunk(std::size_t)>& next,
                                   const std::function<void(const TriangleMesh&)>& emit) {
  // The layout (attribute names and components, normals or not) is the first chunk with vertices';
  // every chunk with vertices must have it. Without any vertex, a chunk's attribute names (a part
  // with none to write) still give the mesh's.
  bool vertex_layout = false;
  has_layout_ = false;
  layout_ = {};
  const auto check = [&](std::size_t p, const VertexChunk& c) {
    const std::size_t n = c.index.size();
    if (c.vertices.vertices.size() != n || (!c.vertices.normals.empty() && c.vertices.normals.size() != n))
      throw InvalidParameter(fmt::format("the gather: part {} sent {} indices for {} vertices and {} normals", p, n,
                                         c.vertices.vertices.size(), c.vertices.normals.size()));
    for (const Attribute& a : c.vertices.attributes)
      if (a.components < 1 || a.values.size() != n * std::size_t(a.components))
        throw InvalidParameter(fmt::format("the gather: part {}'s attribute '{}' has {} values for {} vertices", p,
                                           a.name, a.values.size(), n));
    const bool normals = !c.vertices.normals.empty();
    if (n > 0 && vertex_layout) {
      if (!same_layout(layout_, c.vertices) || normals != !layout_.normals.empty())
        throw InvalidParameter(fmt::format("the gather: part {}'s vertices do not have the other parts' attributes and normals", p));
    } else if (n > 0 || (!has_layout_ && !c.vertices.attributes.empty())) {
      layout_ = {};
      layout_.normals.resize(normals ? 1 : 0);
      for (const Attribute& a : c.vertices.attributes) layout_.attributes.push_back({a.name, a.components, a.integer, {}});
      has_layout_ = true, vertex_layout = n > 0;
    }
  };
  // The batch's layout is known once every part's first chunk is in: lay it out at the first vertex.
  TriangleMesh batch;
  bool laid_out = false;
  const auto append = [&](TriangleMesh& out, const VertexChunk& c, std::size_t i) {
    if (!laid_out) {
      for (const Attribute& a : layout_.attributes) out.attributes.push_back({a.name, a.components, a.integer, {}});
      laid_out = true;
    }
    out.vertices.push_back(c.vertices.vertices[i]);
    if (!layout_.normals.empty()) out.normals.push_back(c.vertices.normals[i]);
    for (std::size_t a = 0; a < out.attributes.size(); ++a) {
      const std::size_t k = std::size_t(out.attributes[a].components);
      const std::vector<float>& from = c.vertices.attributes[a].values;
      out.attributes[a].values.insert(out.attributes[a].values.end(), from.begin() + std::ptrdiff_t(i * k),
                                      from.begin() + std::ptrdiff_t((i + 1) * k));
    }
  };
  const std::function<void(const TriangleMesh&)> emit_batch = [&](const TriangleMesh& b) {
    emit(b);
    laid_out = false;
  };
  merge_by_index<VertexChunk, TriangleMesh>(parts_, next, "vertex", vertices_, batch, emit_batch, append, check);
}

void append_gathered_vertices(TriangleMesh& mesh, const TriangleMesh& batch) {
  if (mesh.attributes.empty())
    for (const Attribute& a : batch.attributes) mesh.attributes.push_back({a.name, a.components, a.integer, {}});
  mesh.vertices.insert(mesh.vertices.end(), batch.vertices.begin(), batch.vertices.end());
  mesh.normals.insert(mesh.normals.end(), batch.normals.begin(), batch.normals.end());
  for (std::size_t a = 0; a < mesh.attributes.size(); ++a)
    mesh.attributes[a].values.insert(mesh.attributes[a].values.end(), batch.attributes[a].values.begin(),
                                     batch.attributes[a].values.end());
}

void OrderedGather::merge_triangles(const std::function<TriangleChunk(std::size_t)>& next,
                                    const std::function<void(const std::vector<Triangle>&)>& emit) {
  const auto check = [](std::size_t p, const TriangleChunk& c) {
    if (c.triangles.size() != c.index.size())
      throw InvalidParameter(fmt::format("the gather: part {} sent {} indices for {} triangles", p, c.index.size(),
                                         c.triangles.size()));
  };
  const auto append = [](std::vector<Triangle>& out, const TriangleChunk& c, std::size_t i) { out.push_back(c.triangles[i]); };
  merge_by_index<TriangleChunk, std::vector<Triangle>>(parts_, next, "triangle", triangles_, {}, emit, append, check);
}

TriangleMesh gather_ordered(std::vector<OrderedPart> parts) {
  const std::size_t k = parts.size();
  OrderedGather gather(k);
  // Numbering: each part's places, then its foreign vertices' (the writers').
  std::vector<std::size_t> next_key(k, 0);
  std::vector<VertexPlaces> own(k);
  gather.number_vertices(
      [&](std::size_t p) {
        OrderedGather::KeyChunk c = key_chunk(parts[p], next_key[p]);
        next_key[p] += c.keys.size();
        return c;
      },
      [&](std::size_t p, VertexPlaces placed) {
        own[p].index.insert(own[p].index.end(), placed.index.begin(), placed.index.end());
        own[p].first_triangle.insert(own[p].first_triangle.end(), placed.first_triangle.begin(), placed.first_triangle.end());
      });
  std::vector<PlacedPart> placed(k);
  for (std::size_t p = 0; p < k; ++p) placed[p] = place_part(parts[p], own[p], gather.seam_places(parts[p].foreign));
  // The normals: the waves' stride over every part's chunks, then each term to its vertex's writer.
  std::vector<uint32_t> lo, hi;
  for (std::size_t p = 0; p < k; ++p) {
    std::vector<uint32_t> part_lo, part_hi;
    normal_chunk_bounds(placed[p], gather.triangles(), part_lo, part_hi);
    if (p == 0) lo = part_lo, hi = part_hi;
    for (std::size_t c = 0; c < lo.size(); ++c) lo[c] = std::min(lo[c], part_lo[c]), hi[c] = std::max(hi[c], part_hi[c]);
  }
  const std::size_t stride = normal_stride(lo, hi);
  std::vector<std::vector<NormalTerm>> received(k);
  for (std::size_t p = 0; p < k; ++p) {
    std::vector<std::vector<NormalTerm>> terms = foreign_terms(parts[p], placed[p], stride, int(k));
    for (std::size_t w = 0; w < k; ++w) received[w].insert(received[w].end(), terms[w].begin(), terms[w].end());
  }
  for (std::size_t p = 0; p < k; ++p) gather_normals(parts[p], placed[p], stride, std::move(received[p]));
  // The mesh, vertices then triangles.
  TriangleMesh out;
  std::vector<std::size_t> next_vertex(k, 0), next_triangle(k, 0);
  gather.merge_vertices(
      [&](std::size_t p) {
        OrderedGather::VertexChunk c = vertex_chunk(parts[p], placed[p], next_vertex[p]);
        next_vertex[p] += c.index.size();
        return c;
      },
      [&](const TriangleMesh& batch) { append_gathered_vertices(out, batch); });
  if (out.attributes.empty()) out.attributes = gather.layout().attributes;
  gather.merge_triangles(
      [&](std::size_t p) {
        OrderedGather::TriangleChunk c = triangle_chunk(placed[p], next_triangle[p]);
        next_triangle[p] += c.index.size();
        return c;
      },
      [&](const std::vector<Triangle>& batch) { out.triangles.insert(out.triangles.end(), batch.begin(), batch.end()); });
  return out;
}

TriangleMesh owned_piece(const TriangleMesh& mesh, const Decomposition& d, int rank) {
  TriangleMesh piece = mesh;
  keep_owned(piece, d, rank);
  return piece;
}

TriangleMesh weld_pieces(std::vector<TriangleMesh> pieces) {
  const bool normals = !pieces.empty() && std::all_of(pieces.begin(), pieces.end(), [](const TriangleMesh& m) {
    return m.normals.size() == m.vertices.size();
  });
  PieceWelder welder(pieces.size());
  for (std::size_t p = 0; p < pieces.size(); ++p) {
    std::vector<Vec3f>().swap(pieces[p].normals);  // computed again on the welded mesh
    welder.add_vertices(p, std::move(pieces[p].vertices));
  }
  welder.weld_vertices();
  std::size_t triangles = 0;
  for (const TriangleMesh& m : pieces) triangles += m.triangles.size();
  welder.reserve_triangles(triangles);
  for (std::size_t p = 0; p < pieces.size(); ++p) {
    welder.add_attributes(p, pieces[p].attributes);
    pieces[p].attributes.clear();
    welder.add_triangles(p, pieces[p].triangles);
    std::vector<Triangle>().swap(pieces[p].triangles);
  }
  return welder.finish(normals);
}

PieceWelder::PieceWelder(std::size_t pieces)
    : positions_(pieces), merged_of_(pieces), attributes_added_(pieces), triangles_added_(pieces) {}

void PieceWelder::add_vertices(std::size_t piece, std::vector<Vec3f> positions) {
  if (welded_) throw std::logic_error("PieceWelder::add_vertices after weld_vertices");
  positions_.at(piece) = std::move(positions);
}

void PieceWelder::weld_vertices() {
  if (welded_) throw std::logic_error("PieceWelder::weld_vertices called twice");
  welded_ = true;
  // The Z-order's grid: 1024 cells across the pieces' box, which does not depend on the cut.
  Vec3f lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
  for (const std::vector<Vec3f>& piece : positions_)
    for (const Vec3f& x : piece) lo = min(lo, x), hi = max(hi, x);
  const float extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z, 0.0f});
  const float inv_cell = extent > 0 && std::isfinite(extent) ? 1024.0f / extent : 1.0f;
  struct Entry {
    VertexKey key;
    uint32_t piece, index;
  };
  std::vector<Entry> all;
  std::size_t total = 0;
  for (const std::vector<Vec3f>& piece : positions_) total += piece.size();
  all.reserve(total);
  for (uint32_t p = 0; p < positions_.size(); ++p)
    for (uint32_t i = 0; i < positions_[p].size(); ++i) all.push_back({key_of(positions_[p][i], inv_cell), p, i});
  sort(Host{}, all.begin(), all.end(), [](const Entry& a, const Entry& b) {
    return std::tie(a.key, a.piece, a.index) < std::tie(b.key, b.piece, b.index);
  });

  // The merged vertices: one per distinct key, from the first piece that has it.
  for (std::size_t p = 0; p < positions_.size(); ++p) merged_of_[p].resize(positions_[p].size());
  for (std::size_t i = 0; i < all.size(); ++i) {
    const Entry& e = all[i];
    const Vec3f& x = positions_[e.piece][e.index];
    if (i > 0 && all[i - 1].key == e.key) {
      if (all[i - 1].piece == e.piece)
        throw InvalidParameter(fmt::format("weld_pieces: vertices {} and {} of piece {} coincide at ({}, {}, {}): the "
                                           "pieces cannot be welded by position",
                                           all[i - 1].index, e.index, e.piece, x.x, x.y, x.z));
    } else {
      out_.vertices.push_back(x);
      first_piece_.push_back(e.piece);
    }
    merged_of_[e.piece][e.index] = uint32_t(out_.vertices.size() - 1);
  }
  std::vector<Entry>().swap(all);
  for (std::vector<Vec3f>& piece : positions_) std::vector<Vec3f>().swap(piece);
  out_.vertices.shrink_to_fit();
  first_piece_.shrink_to_fit();
}

void PieceWelder::add_attributes(std::size_t piece, const std::vector<Attribute>& attributes) {
  if (!welded_ || attributes_added_.at(piece)) throw std::logic_error("PieceWelder::add_attributes out of order");
  attributes_added_[piece] = true;
  const std::vector<uint32_t>& merged = merged_of_[piece];
  if (!attributes_started_) {
    attributes_started_ = true;
    for (const Attribute& a : attributes) {
      out_.attributes.push_back({a.name, a.components, a.integer, {}});
      out_.attributes.back().values.resize(out_.vertices.size() * std::size_t(a.components));
    }
  }
  if (attributes.size() != out_.attributes.size())
    throw InvalidParameter(fmt::format("weld_pieces: piece {} has {} attributes, another has {}", piece,
                                       attributes.size(), out_.attributes.size()));
  for (std::size_t a = 0; a < attributes.size(); ++a) {
    Attribute& to = out_.attributes[a];
    const Attribute& from = attributes[a];
    if (from.name != to.name || from.components != to.components)
      throw InvalidParameter(fmt::format("weld_pieces: the pieces do not all have the attribute '{}'", to.name));
    const std::size_t k = std::size_t(to.components);
    if (from.values.size() != merged.size() * k)
      throw InvalidParameter(fmt::format("weld_pieces: piece {}'s attribute '{}' has {} values for {} vertices", piece,
                                         from.name, from.values.size(), merged.size()));
    for (std::size_t i = 0; i < merged.size(); ++i)
      if (first_piece_[merged[i]] == piece)
        std::copy_n(from.values.begin() + std::ptrdiff_t(i * k), k, to.values.begin() + std::ptrdiff_t(merged[i] * k));
  }
}

void PieceWelder::add_triangles(std::size_t piece, const std::vector<Triangle>& triangles) {
  if (!attributes_added_.at(piece) || triangles_added_[piece])
    throw std::logic_error("PieceWelder::add_triangles out of order");
  triangles_added_[piece] = true;
  const std::vector<uint32_t>& merged = merged_of_[piece];
  for (Triangle t : triangles) {
    for (uint32_t& v : t) {
      if (v >= merged.size())
        throw InvalidParameter(fmt::format("weld_pieces: piece {} has a triangle on vertex {} of {}", piece, v, merged.size()));
      v = merged[v];
    }
    // Turned to start at its smallest vertex (orientation kept).
    while (t[0] > t[1] || t[0] > t[2]) t = {t[1], t[2], t[0]};
    out_.triangles.push_back(t);
  }
  std::vector<uint32_t>().swap(merged_of_[piece]);
}

TriangleMesh PieceWelder::finish(bool normals) {
  if (!welded_ || std::find(triangles_added_.begin(), triangles_added_.end(), false) != triangles_added_.end())
    throw std::logic_error("PieceWelder::finish before every piece was added");
  std::vector<uint32_t>().swap(first_piece_);
  sort(Host{}, out_.triangles.begin(), out_.triangles.end());
  // The normals again, on the welded mesh: a vertex's sum over its triangles then runs in one
  // order whatever the cut (a piece's triangle order can tie-break differently).
  if (normals) out_.normals = vertex_normals(out_.vertices, out_.triangles);
  return std::move(out_);
}

}  // namespace meniscus
