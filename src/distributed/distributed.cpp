// meniscus — one frame over several processes: slabs, halos, owned pieces and their weld
// (include/meniscus/distributed.hpp).
#include "meniscus/distributed.hpp"

#include <fmt/format.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <tuple>

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

void keep_owned(TriangleMesh& mesh, const Decomposition& d, int rank, Seams* seams) {
  const double lo = d.lo(rank), hi = d.hi(rank);
  std::vector<uint32_t> new_index(mesh.vertices.size(), UINT32_MAX);
  // With seams: the lowest and highest owner of the triangles on each vertex.
  std::vector<int32_t> lowest, highest;
  if (seams) lowest.assign(mesh.vertices.size(), INT32_MAX), highest.assign(mesh.vertices.size(), -1);
  std::size_t kept = 0;
  for (const Triangle& t : mesh.triangles) {
    const double c = centroid(mesh, t, d.axis);
    if (seams) {
      const int32_t owner = owner_of(d, c);
      for (uint32_t v : t) lowest[v] = std::min(lowest[v], owner), highest[v] = std::max(highest[v], owner);
    }
    if (c < lo || c >= hi) continue;
    mesh.triangles[kept++] = t;
    for (uint32_t v : t) new_index[v] = 0;
  }
  if (seams) {
    seams->writer.clear(), seams->shared_up.clear();
    for (uint32_t v = 0; v < mesh.vertices.size(); ++v)
      if (new_index[v] != UINT32_MAX) {
        seams->writer.push_back(lowest[v]);
        seams->shared_up.push_back(highest[v] > rank);
      }
  }
  std::vector<int32_t>().swap(lowest), std::vector<int32_t>().swap(highest);
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

StreamPart stream_part(TriangleMesh piece, const Seams& seams, int rank) {
  const std::size_t n = piece.vertices.size();
  if (seams.writer.size() != n || seams.shared_up.size() != n)
    throw InvalidParameter(fmt::format("stream_part: seams for {} vertices, the piece has {}", seams.writer.size(), n));
  StreamPart part;
  std::vector<uint32_t> index(n);
  std::size_t written = 0;
  for (std::size_t v = 0; v < n; ++v)
    if (seams.writer[v] == rank) index[v] = uint32_t(written++);
  const bool normals = piece.normals.size() == n;
  part.written.vertices.reserve(written);
  if (normals) part.written.normals.reserve(written);
  for (const Attribute& a : piece.attributes) part.written.attributes.push_back({a.name, a.components, a.integer, {}});
  for (std::size_t v = 0; v < n; ++v) {
    if (seams.writer[v] != rank) {
      index[v] = uint32_t(written + part.foreign.size());
      part.foreign.push_back(piece.vertices[v]);
      continue;
    }
    part.written.vertices.push_back(piece.vertices[v]);
    if (normals) part.written.normals.push_back(piece.normals[v]);
    part.shared_up.push_back(seams.shared_up[v]);
    for (std::size_t a = 0; a < piece.attributes.size(); ++a) {
      const std::size_t k = std::size_t(piece.attributes[a].components);
      const auto& from = piece.attributes[a].values;
      part.written.attributes[a].values.insert(part.written.attributes[a].values.end(), from.begin() + std::ptrdiff_t(v * k),
                                               from.begin() + std::ptrdiff_t((v + 1) * k));
    }
  }
  part.triangles = std::move(piece.triangles);
  for (Triangle& t : part.triangles)
    for (uint32_t& v : t) v = index[v];
  return part;
}

std::size_t StreamIndex::add_written(const std::vector<Vec3f>& positions, const std::vector<uint8_t>& shared_up) {
  if (shared_up.size() != positions.size())
    throw InvalidParameter(fmt::format("StreamIndex: {} flags for {} vertices", shared_up.size(), positions.size()));
  const std::size_t first = next_;
  for (std::size_t v = 0; v < positions.size(); ++v)
    if (shared_up[v]) {
      const Vec3f x = positions[v];
      shared_.push_back({{std::bit_cast<uint32_t>(x.x), std::bit_cast<uint32_t>(x.y), std::bit_cast<uint32_t>(x.z)},
                         uint32_t(first + v)});
      sorted_ = false;
    }
  parts_.emplace_back(first, positions.size());
  next_ += positions.size();
  return first;
}

void StreamIndex::resolve(std::size_t part, std::vector<Triangle>& triangles, const std::vector<Vec3f>& foreign) {
  const auto by_bits = [](const Shared& a, const Shared& b) { return a.bits < b.bits; };
  if (!sorted_) std::sort(shared_.begin(), shared_.end(), by_bits), sorted_ = true;
  const auto [first, count] = parts_.at(part);
  std::vector<uint32_t> global(foreign.size());
  for (std::size_t j = 0; j < foreign.size(); ++j) {
    const Vec3f x = foreign[j];
    const Shared key{{std::bit_cast<uint32_t>(x.x), std::bit_cast<uint32_t>(x.y), std::bit_cast<uint32_t>(x.z)}, 0};
    const auto it = std::lower_bound(shared_.begin(), shared_.end(), key, by_bits);
    if (it == shared_.end() || it->bits != key.bits || it->index >= first)
      throw InvalidParameter(fmt::format("the gather: piece {}'s seam vertex ({}, {}, {}) was not written by a piece "
                                         "before it",
                                         part, x.x, x.y, x.z));
    global[j] = it->index;
  }
  for (Triangle& t : triangles)
    for (uint32_t& v : t) {
      if (v < count) {
        v = uint32_t(first + v);
      } else if (v - count < global.size()) {
        v = global[v - count];
      } else {
        throw InvalidParameter(fmt::format("the gather: piece {} has a triangle on vertex {} of {}", part, v,
                                           count + global.size()));
      }
    }
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
  tbb::parallel_sort(all.begin(), all.end(), [](const Entry& a, const Entry& b) {
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
  tbb::parallel_sort(out_.triangles.begin(), out_.triangles.end());
  // The normals again, on the welded mesh: a vertex's sum over its triangles then runs in one
  // order whatever the cut (a piece's triangle order can tie-break differently).
  if (normals) out_.normals = vertex_normals(out_.vertices, out_.triangles);
  return std::move(out_);
}

}  // namespace meniscus
