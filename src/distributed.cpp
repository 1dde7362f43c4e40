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
#include <tuple>

#include "extract/field_band.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/reconstruct.hpp"
#include "mesh/vertex_order_impl.hpp"
#include "stage_plan.hpp"
#include "transfer/normals.hpp"

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

Decomposition decompose(const ParticleSet& particles, const Params& p, int ranks) {
  if (ranks < 1) throw InvalidParameter(fmt::format("ranks = {}: must be ≥ 1", ranks));
  Decomposition d;
  d.ranks = ranks;
  d.halo = halo_width(p);
  if (ranks == 1 || particles.size() == 0) {
    d.cuts.assign(std::size_t(ranks - 1), 0.0);
    if (particles.size() == 0) return d;
  }
  Vec3f lo = particles.positions[0], hi = lo;
  for (const Vec3f& x : particles.positions) lo = min(lo, x), hi = max(hi, x);
  const Vec3f extent = hi - lo;
  d.axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
  if (ranks == 1) return d;

  std::vector<float> along(particles.size());
  for (std::size_t i = 0; i < along.size(); ++i) along[i] = particles.positions[i][d.axis];
  // Aligned to the field's blocks, so a block (and a lattice cell) never straddles two slabs.
  const StagePlan plan = plan_stages(p);
  const double block = double(plan.lattice.cell_size) * plan.lattice.block_cells();
  double previous = -std::numeric_limits<double>::infinity();
  for (int r = 1; r < ranks; ++r) {
    const std::size_t k = along.size() * std::size_t(r) / std::size_t(ranks);
    std::nth_element(along.begin(), along.begin() + std::ptrdiff_t(k), along.end());
    const double cut = std::max(previous, std::round(double(along[k]) / block) * block);
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

TriangleMesh owned_piece(const TriangleMesh& mesh, const Decomposition& d, int rank) {
  TriangleMesh piece = mesh;
  keep_owned(piece, d, rank);
  return piece;
}

TriangleMesh weld_pieces(std::vector<TriangleMesh> pieces) {
  // Memory: the pieces' arrays are freed as soon as they are copied (on the rank that gathers,
  // the pieces and the welded mesh are the frame's whole surface twice over).
  const bool normals = !pieces.empty() && std::all_of(pieces.begin(), pieces.end(), [](const TriangleMesh& m) {
    return m.normals.size() == m.vertices.size();
  });
  for (TriangleMesh& m : pieces) std::vector<Vec3f>().swap(m.normals);  // computed again below
  // The Z-order's grid: 1024 cells across the pieces' box, which does not depend on the cut.
  Vec3f lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
  for (const TriangleMesh& m : pieces)
    for (const Vec3f& x : m.vertices) lo = min(lo, x), hi = max(hi, x);
  const float extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z, 0.0f});
  const float inv_cell = extent > 0 && std::isfinite(extent) ? 1024.0f / extent : 1.0f;
  struct Entry {
    VertexKey key;
    uint32_t piece, index;
  };
  std::vector<Entry> all;
  std::size_t total = 0;
  for (const TriangleMesh& m : pieces) total += m.vertices.size();
  all.reserve(total);
  for (uint32_t p = 0; p < pieces.size(); ++p)
    for (uint32_t i = 0; i < pieces[p].vertices.size(); ++i) all.push_back({key_of(pieces[p].vertices[i], inv_cell), p, i});
  tbb::parallel_sort(all.begin(), all.end(), [](const Entry& a, const Entry& b) {
    return std::tie(a.key, a.piece, a.index) < std::tie(b.key, b.piece, b.index);
  });

  // The merged vertices: one per distinct key, from the first piece that has it.
  std::vector<std::vector<uint32_t>> merged_of(pieces.size());
  for (std::size_t p = 0; p < pieces.size(); ++p) merged_of[p].resize(pieces[p].vertices.size());
  std::vector<std::pair<uint32_t, uint32_t>> source;  // (piece, index) of each merged vertex
  source.reserve(all.size());
  for (std::size_t i = 0; i < all.size(); ++i) {
    const Entry& e = all[i];
    if (i > 0 && all[i - 1].key == e.key) {
      if (all[i - 1].piece == e.piece)
        throw InvalidParameter(fmt::format("weld_pieces: vertices {} and {} of piece {} coincide at ({}, {}, {}): the "
                                           "pieces cannot be welded by position",
                                           all[i - 1].index, e.index, e.piece, pieces[e.piece].vertices[e.index].x,
                                           pieces[e.piece].vertices[e.index].y, pieces[e.piece].vertices[e.index].z));
    } else {
      source.push_back({e.piece, e.index});
    }
    merged_of[e.piece][e.index] = uint32_t(source.size() - 1);
  }
  std::vector<Entry>().swap(all);

  TriangleMesh out;
  out.vertices.reserve(source.size());
  for (const auto& [p, i] : source) out.vertices.push_back(pieces[p].vertices[i]);
  if (!pieces.empty())
    for (std::size_t a = 0; a < pieces[0].attributes.size(); ++a) {
      const Attribute& first = pieces[0].attributes[a];
      Attribute merged{first.name, first.components, first.integer, {}};
      const std::size_t k = std::size_t(first.components);
      for (const TriangleMesh& m : pieces)
        if (m.attributes.size() != pieces[0].attributes.size() || m.attributes[a].name != first.name ||
            m.attributes[a].components != first.components)
          throw InvalidParameter(fmt::format("weld_pieces: the pieces do not all have the attribute '{}'", first.name));
      merged.values.reserve(source.size() * k);
      for (const auto& [p, i] : source) {
        const auto& values = pieces[p].attributes[a].values;
        merged.values.insert(merged.values.end(), values.begin() + std::ptrdiff_t(i * k),
                             values.begin() + std::ptrdiff_t((i + 1) * k));
      }
      out.attributes.push_back(std::move(merged));
    }
  std::vector<std::pair<uint32_t, uint32_t>>().swap(source);
  for (TriangleMesh& m : pieces) {
    std::vector<Vec3f>().swap(m.vertices);
    m.attributes.clear();
  }

  // Triangles: renumbered, turned to start at their smallest vertex (orientation kept), sorted.
  std::size_t triangles = 0;
  for (const TriangleMesh& m : pieces) triangles += m.triangles.size();
  out.triangles.reserve(triangles);
  for (std::size_t p = 0; p < pieces.size(); ++p) {
    for (Triangle t : pieces[p].triangles) {
      for (uint32_t& v : t) v = merged_of[p][v];
      while (t[0] > t[1] || t[0] > t[2]) t = {t[1], t[2], t[0]};
      out.triangles.push_back(t);
    }
    std::vector<Triangle>().swap(pieces[p].triangles);
    std::vector<uint32_t>().swap(merged_of[p]);
  }
  tbb::parallel_sort(out.triangles.begin(), out.triangles.end());
  // The normals again, on the welded mesh: a vertex's sum over its triangles then runs in one
  // order whatever the cut (a piece's triangle order can tie-break differently).
  if (normals) out.normals = vertex_normals(out.vertices, out.triangles);
  return out;
}

}  // namespace meniscus
