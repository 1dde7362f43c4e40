// meniscus — A and B operators (Williams 2008 §4; Desbrun et al. 1999 for the cotangent form).
#include "smooth/operators.hpp"

#include <algorithm>
#include <cmath>

#include "common/huge_pages.hpp"
#include "common/for_each.hpp"
#include "common/primitives.hpp"
#include "smooth/cotangent_impl.hpp"
#include "smooth/operators_impl.hpp"

namespace meniscus {

CotanOperator build_cotan_operator(std::span<const Vec3f> x, std::span<const Triangle> triangles,
                                   const Adjacency& adj, float area_floor) {
  const std::size_t nv = adj.vertex_count();
  CotanOperator op;
  // Every entry is written below, first by the parallel passes (no serial zeroing).
  resize_huge(op.w, adj.entry_count());
  resize_huge(op.area, nv);
  // Each vertex assembles its own row from its incident triangles: no two threads write the
  // same entry, so no atomics are needed. From the corner lists when the adjacency has them (the
  // triangles are then not read), else from the triangle lists.
  auto for_each_row = [&](auto&& row) {
    for_each_chunk(nv, 1024, [&](std::size_t begin, std::size_t end) {
      float diag;  // summed again where needed (w_diagonal)
      for (std::size_t iv = begin; iv != end; ++iv) row(uint32_t(iv), &diag, &op.area[iv]);
    });
  };
  if (!adj.corner_offsets.empty()) {
    adj.with_neighbors([&](const auto& neighbors) {
      for_each_row([&](uint32_t i, float* diag, float* area) {
        cotan_row_corners(adj.offsets.data(), neighbors, adj.corner_offsets.data(), adj.corners.data(), x.data(), i,
                          op.w.data(), diag, area);
      });
    });
  } else {
    // (An adjacency is compacted only once it has corner lists.)
    const MeshRows rows{adj.offsets.data(), adj.neighbors.data(), adj.tri_offsets.data(), adj.tri_ids.data(),
                        triangles.empty() ? nullptr : triangles.data()->data()};
    for_each_row([&](uint32_t i, float* diag, float* area) { cotan_row(rows, x.data(), i, op.w.data(), diag, area); });
  }
  // Vertices that collapsed onto a neighbour have no area; a floor keeps D invertible without
  // changing any healthy vertex. A constant of the parameters (from h), not of the mesh: a vertex's
  // operator row depends on its ring alone.
  for_each_index(nv, 16384, [&](std::size_t i) { op.area[i] = std::max(op.area[i], area_floor); });
  return op;
}

void apply_w(const Adjacency& adj, const CotanOperator& op, std::span<const Vec3f> x, std::span<Vec3f> y) {
  adj.with_neighbors([&](const auto& neighbors) {
    for_each_chunk(x.size(), 2048, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i != end; ++i)
        y[i] = apply_w_row(adj.offsets.data(), neighbors, op.w.data(), nullptr, x.data(), uint32_t(i));
    });
  });
}

double bilaplacian_energy(const CotanOperator& op, std::span<const Vec3f> wx) {
  // In the fixed tree the CUDA backend sums in too: the same value whatever the thread scheduling,
  // on both backends (it is reported, and decides nothing).
  return deterministic_sum(Host{}, wx.size(), kSumTreeGrain,
                           [&](std::size_t k) { return energy_term(wx[k], op.area[k]); });
}

Vec3f bilaplacian_row(const Adjacency& adj, const CotanOperator& op, std::span<const Vec3f> x, uint32_t i) {
  return adj.with_neighbors([&](const auto& neighbors) {
    auto wx = [&](uint32_t k) {
      return apply_w_row(adj.offsets.data(), neighbors, op.w.data(), nullptr, x.data(), k);
    };
    Vec3f out = wx(i) * (w_diagonal(adj, op, i) / op.area[i]);
    for (uint32_t e = adj.offsets[i]; e < adj.offsets[i + 1]; ++e) {
      const uint32_t k = neighbor_at(neighbors, i, e);
      out += wx(k) * (op.w[e] / op.area[k]);
    }
    return out;
  });
}

}  // namespace meniscus
