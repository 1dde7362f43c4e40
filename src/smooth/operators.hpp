// meniscus — the smoothing operators of Williams 2008 §4: A, the unweighted graph Laplacian,
// and B = W D⁻¹ W, the quadratic approximation of the surface bilaplacian (W the cotangent
// Laplacian, D the vertex areas). Both are applied matrix-free from the adjacency (CSR).
#pragma once

#include <span>
#include <vector>

#include "common/huge_pages.hpp"
#include "smooth/adjacency.hpp"
#include "smooth/operators_impl.hpp"

namespace meniscus {

/// W and D on the CSR pattern of an Adjacency: w[k] = W_ij for the k-th entry of row i
/// (W_ij = cot α_ij + cot β_ij, clamped), area[i] = D_ii (a third of the clamped areas of the
/// incident triangles). The diagonals W_ii = −Σ_j W_ij and B_ii = Σ_k W_ik² / D_k are not stored
/// (8 bytes a vertex of the B sweeps): they are summed again from the row where needed, to the bits
/// the CUDA backend stores (w_diagonal, b_diagonal, bilaplacian_row_and_diagonal).
struct CotanOperator {
  UninitVector<float> w, area;  ///< written whole by build_cotan_operator's parallel passes
};

/// W_ii = −Σ_j W_ij of row i.
inline float w_diagonal(const Adjacency& adjacency, const CotanOperator& op, uint32_t i) {
  return w_diagonal_row(adjacency.offsets.data(), op.w.data(), i);
}

/// B_ii (bilaplacian_diagonal_row).
inline float b_diagonal(const Adjacency& adjacency, const CotanOperator& op, uint32_t i) {
  return adjacency.with_neighbors([&](const auto& neighbors) {
    return bilaplacian_diagonal_row(adjacency.offsets.data(), neighbors, op.w.data(), nullptr, op.area.data(), i);
  });
}

/// Builds W and D for the current positions (parallel over vertices, no atomics), from
/// the adjacency's corner lists when it has them (`triangles` unused), else from its triangle lists
/// of `triangles`. D_i is at least `area_floor` (collapsed vertices).
CotanOperator build_cotan_operator(std::span<const Vec3f> x, std::span<const Triangle> triangles,
                                   const Adjacency& adjacency, float area_floor);

/// y = W x.
void apply_w(const Adjacency& adjacency, const CotanOperator& op, std::span<const Vec3f> x, std::span<Vec3f> y);

/// Energy xᵀ B x = Σ_k |(W x)_k|² / D_k (given y = W x), summed in the fixed tree of
/// operators_impl.hpp.
double bilaplacian_energy(const CotanOperator& op, std::span<const Vec3f> wx);

/// (B x)_i for one vertex given wx = W x: Σ_k W_ik / D_k (W x)_k over i and its ring; `neighbors`
/// as Adjacency::with_neighbors gives them.
template <class Neighbors>
Vec3f bilaplacian_row_from_wx(const Adjacency& adj, const Neighbors& neighbors, const CotanOperator& op,
                              std::span<const Vec3f> wx, uint32_t i) {
  return bilaplacian_row_from_wx(adj.offsets.data(), neighbors, op.w.data(), nullptr, op.area.data(), wx.data(), i);
}

/// (B x)_i for one vertex from the current x (two rings).
Vec3f bilaplacian_row(const Adjacency& adjacency, const CotanOperator& op, std::span<const Vec3f> x, uint32_t i);

}  // namespace meniscus
