// meniscus — the per-vertex rows of the smoothing operators (Williams 2008 §4; Desbrun et al. 1999
// for the cotangent form) over raw CSR arrays, written once for the CPU (operators.cpp, smooth.cpp)
// and the CUDA backend, in the same order of float operations.
#pragma once

#include <cstddef>
#include <cstdint>

#include "meniscus/vec.hpp"
#include "smooth/cotangent_impl.hpp"

namespace meniscus {

/// CSR rows of a mesh: neighbours of i at neighbors[offsets[i] .. offsets[i+1]) (distinct), incident
/// triangles at tri_ids[tri_offsets[i] .. tri_offsets[i+1]) (ascending); triangles as index triples.
struct MeshRows {
  const uint32_t* offsets;
  const uint32_t* neighbors;
  const uint32_t* tri_offsets;
  const uint32_t* tri_ids;
  const uint32_t* triangles;  ///< 3 per triangle
};

/// The row functions below read the neighbour of entry e of row i as neighbor_at(neighbors, i, e):
/// `neighbors` is the CSR column array (here; the CUDA backend's) or, on the CPU, the sweeps'
/// 16-bit form (CompactNeighbors, smooth/compact_neighbors.hpp), found by argument-dependent lookup.
MENISCUS_HD inline uint32_t neighbor_at(const uint32_t* neighbors, uint32_t /*row*/, uint32_t e) { return neighbors[e]; }

/// Mean of i's neighbours (x_i itself for an isolated vertex).
template <class Neighbors>
MENISCUS_HD inline Vec3f neighbour_mean_row(const uint32_t* offsets, const Neighbors& neighbors, const Vec3f* x,
                                            uint32_t i) {
  const uint32_t b = offsets[i], e = offsets[i + 1];
  if (b == e) return x[i];
  Vec3f sum{0, 0, 0};
  for (uint32_t k = b; k < e; ++k) sum += x[neighbor_at(neighbors, i, k)];
  return sum / float(e - b);
}

/// W_ii = −Σ_j W_ij of row i, summed over its entries in cotan_row_from's order: the same bits as
/// the diagonal it returned.
MENISCUS_HD inline float w_diagonal_row(const uint32_t* offsets, const float* w, uint32_t i) {
  float sum = 0;
  for (uint32_t k = offsets[i]; k < offsets[i + 1]; ++k) sum += w[k];
  return -sum;
}
/// W_ii from the stored diagonal `diag` or, where the caller keeps none (null: the CPU's sweeps,
/// 4 bytes a vertex less), summed again from the row.
MENISCUS_HD inline float w_diagonal(const uint32_t* offsets, const float* w, const float* diag, uint32_t i) {
  return diag != nullptr ? diag[i] : w_diagonal_row(offsets, w, i);
}
/// (W x)_i = W_ii x_i + Σ_j W_ij x_j (`diag`: as w_diagonal takes it).
template <class Neighbors>
MENISCUS_HD inline Vec3f apply_w_row(const uint32_t* offsets, const Neighbors& neighbors, const float* w,
                                     const float* diag, const Vec3f* x, uint32_t i) {
  Vec3f acc = x[i] * w_diagonal(offsets, w, diag, i);
  for (uint32_t k = offsets[i]; k < offsets[i + 1]; ++k) acc += x[neighbor_at(neighbors, i, k)] * w[k];
  return acc;
}

/// (B x)_i given wx = W x: Σ_k W_ik / D_k (W x)_k over i and its ring (`diag`: as w_diagonal
/// takes it).
template <class Neighbors>
MENISCUS_HD inline Vec3f bilaplacian_row_from_wx(const uint32_t* offsets, const Neighbors& neighbors, const float* w,
                                                 const float* diag, const float* area, const Vec3f* wx, uint32_t i) {
  Vec3f out = wx[i] * (w_diagonal(offsets, w, diag, i) / area[i]);
  for (uint32_t e = offsets[i]; e < offsets[i + 1]; ++e) {
    const uint32_t k = neighbor_at(neighbors, i, e);
    out += wx[k] * (w[e] / area[k]);
  }
  return out;
}

/// One incident triangle (i, j, l) of a vertex i, its corners in the triangle's order, with the
/// slots of j and l in i's row (kNoSlot: the corner is i itself, in a degenerate triangle).
struct CotanCorners {
  uint32_t j, l;
  uint32_t slot_j, slot_l;
};
inline constexpr uint32_t kNoSlot = 0xffffffffu;

/// Row i of W (w[row_begin .. row_end), overwritten) from i's `count` incident triangles, the k-th
/// given by corners(k) (a CotanCorners); returns W_ii = −Σ_j W_ij in *diag and the third of the
/// clamped incident area in *area. The arithmetic of both ways of listing the triangles below
/// (the same float operations in the same order: the same bits).
template <class Corners>
MENISCUS_HD inline void cotan_row_from(uint32_t row_begin, uint32_t row_end, uint32_t count, Corners&& corners,
                                       const Vec3f* x, uint32_t i, float* w, float* diag, float* area) {
  float* wrow = w + row_begin;
  for (uint32_t e = 0; e < row_end - row_begin; ++e) wrow[e] = 0.0f;
  float a = 0;
  for (uint32_t k = 0; k < count; ++k) {
    const CotanCorners c = corners(k);
    const Vec3f pi = x[i], pj = x[c.j], pl = x[c.l];
    // Edge (i, j) is opposite the angle at l; edge (i, l) is opposite the angle at j.
    const float cot_l = clamped_cotangent(pl, pi, pj);
    const float cot_j = clamped_cotangent(pj, pi, pl);
    if (c.slot_j != kNoSlot) wrow[c.slot_j] += cot_l;
    if (c.slot_l != kNoSlot) wrow[c.slot_l] += cot_j;
    a += clamped_area(pi, pj, pl);
  }
  float sum = 0;
  for (uint32_t k = 0; k < row_end - row_begin; ++k) sum += wrow[k];
  *diag = -sum;
  *area = a / 3.0f;
}

/// v's slot in row i, entries [row_begin .. row_end) of `neighbors` in either form (neighbor_at;
/// six or seven entries), kNoSlot when it is not there (the vertex itself, a corner repeated in a
/// degenerate triangle).
template <class Neighbors>
MENISCUS_HD inline uint32_t row_slot(const Neighbors& neighbors, uint32_t i, uint32_t row_begin, uint32_t row_end,
                                     uint32_t v) {
  for (uint32_t e = row_begin; e < row_end; ++e)
    if (neighbor_at(neighbors, i, e) == v) return e - row_begin;
  return kNoSlot;
}

/// The corners of triangle t after its corner i, in the triangle's order: *j then *l.
MENISCUS_HD inline void corners_after(const uint32_t* t, uint32_t i, uint32_t* j, uint32_t* l) {
  const int c = t[0] == i ? 0 : (t[1] == i ? 1 : 2);
  *j = t[(c + 1) % 3];
  *l = t[(c + 2) % 3];
}

/// Row i of W from i's incident triangles in MeshRows' lists (the CUDA backend's; the CPU's
/// reference for the corner lists below).
MENISCUS_HD inline void cotan_row(const MeshRows& m, const Vec3f* x, uint32_t i, float* w, float* diag, float* area) {
  const uint32_t row_begin = m.offsets[i], row_end = m.offsets[i + 1];
  const uint32_t first = m.tri_offsets[i];
  cotan_row_from(row_begin, row_end, m.tri_offsets[i + 1] - first, [&](uint32_t k) {
    CotanCorners c;
    corners_after(m.triangles + 3 * std::size_t(m.tri_ids[first + k]), i, &c.j, &c.l);
    c.slot_j = row_slot(m.neighbors, i, row_begin, row_end, c.j);
    c.slot_l = row_slot(m.neighbors, i, row_begin, row_end, c.l);
    return c;
  }, x, i, w, diag, area);
}

/// An incident triangle of a vertex as the slots, in the vertex's row, of its two other corners
/// (in the triangle's order after the vertex); kCornerSelf for a corner that is the vertex itself.
struct CornerSlots {
  uint8_t j, l;
};
inline constexpr uint8_t kCornerSelf = 0xff;
/// Rows up to this long have corner lists (a slot fits a byte, kCornerSelf apart).
inline constexpr uint32_t kMaxCornerRow = 0xfe;

/// Row i of W from its corner lists: incident triangles corners[corner_offsets[i] ..
/// corner_offsets[i+1]), in the order of MeshRows' lists — the same row as cotan_row there.
template <class Neighbors>
MENISCUS_HD inline void cotan_row_corners(const uint32_t* offsets, const Neighbors& neighbors,
                                          const uint32_t* corner_offsets, const CornerSlots* corners, const Vec3f* x,
                                          uint32_t i, float* w, float* diag, float* area) {
  const uint32_t row_begin = offsets[i], row_end = offsets[i + 1];
  const CornerSlots* list = corners + corner_offsets[i];
  auto corner = [&](uint8_t slot, uint32_t& v) {
    if (slot == kCornerSelf) {
      v = i;
      return kNoSlot;
    }
    v = neighbor_at(neighbors, i, row_begin + slot);
    return uint32_t(slot);
  };
  cotan_row_from(row_begin, row_end, corner_offsets[i + 1] - corner_offsets[i], [&](uint32_t k) {
    CotanCorners c;
    c.slot_j = corner(list[k].j, c.j);
    c.slot_l = corner(list[k].l, c.l);
    return c;
  }, x, i, w, diag, area);
}

/// B_ii = W_ii² / D_i + Σ_k W_ik² / D_k, each term as (W_ik / D_k) · W_ik — the quotient (B x)_i
/// also takes (bilaplacian_row_and_diagonal sums both in one pass, to the same bits); a unit
/// diagonal for an isolated or broken row (`diag`: as w_diagonal takes it).
MENISCUS_HD inline float bilaplacian_diagonal_or_one(float b) { return b > 0 && b - b == 0.0f ? b : 1.0f; }
template <class Neighbors>
MENISCUS_HD inline float bilaplacian_diagonal_row(const uint32_t* offsets, const Neighbors& neighbors, const float* w,
                                                  const float* diag, const float* area, uint32_t i) {
  const float d = w_diagonal(offsets, w, diag, i);
  float b = d / area[i] * d;
  for (uint32_t k = offsets[i]; k < offsets[i + 1]; ++k) {
    const float wik = w[k];
    b += wik / area[neighbor_at(neighbors, i, k)] * wik;
  }
  return bilaplacian_diagonal_or_one(b);
}
/// (B x)_i given wx = W x and W_ii (bilaplacian_row_from_wx), and B_ii in *b_ii
/// (bilaplacian_diagonal_row), in one pass over the row: the CPU's sweeps keep no B_ii (4 bytes a
/// vertex), for the cost of a multiply-add an entry.
template <class Neighbors>
MENISCUS_HD inline Vec3f bilaplacian_row_and_diagonal(const uint32_t* offsets, const Neighbors& neighbors,
                                                      const float* w, float w_ii, const float* area, const Vec3f* wx,
                                                      uint32_t i, float* b_ii) {
  const float t_i = w_ii / area[i];
  Vec3f out = wx[i] * t_i;
  float b = t_i * w_ii;
  for (uint32_t e = offsets[i]; e < offsets[i + 1]; ++e) {
    const uint32_t k = neighbor_at(neighbors, i, e);
    const float t = w[e] / area[k];
    out += wx[k] * t;
    b += t * w[e];
  }
  *b_ii = bilaplacian_diagonal_or_one(b);
  return out;
}
/// The damping of vertex i's B sweeps, ω_i = min(relax_b, 0.9 · 2 B_ii / G_i) with G_i a bound on the
/// absolute sum of row i of B (Σ_k |W_ik| / D_k · 2|W_kk| over i and its ring, ≥ Σ_j |B_ij|: the
/// off-diagonal W_kj are ≥ 0, so Σ_j |W_kj| = 2|W_kk|). Jacobi sweeps x ← x − P⁻¹ B x with
/// P = diag(B_ii / ω_i) converge when 2P − B is positive definite, which these rows guarantee by
/// Gershgorin's theorem — so the B sweeps cannot diverge, and each vertex's damping depends on its
/// two rings alone (on a regular mesh ω_i ≈ 0.52). `diag`: as w_diagonal takes it.
template <class Neighbors>
MENISCUS_HD inline float b_stable_damping(const uint32_t* offsets, const Neighbors& neighbors, const float* w,
                                          const float* diag, const float* area, uint32_t i, float relax_b) {
  const float d = w_diagonal(offsets, w, diag, i);
  const float ad = d < 0 ? -d : d;
  float b = d / area[i] * d, g = ad / area[i] * (2.0f * ad);
  for (uint32_t e = offsets[i]; e < offsets[i + 1]; ++e) {
    const uint32_t k = neighbor_at(neighbors, i, e);
    const float wik = w[e], dk = w_diagonal(offsets, w, diag, k);
    b += wik / area[k] * wik;
    g += (wik < 0 ? -wik : wik) / area[k] * (2.0f * (dk < 0 ? -dk : dk));
  }
  b = bilaplacian_diagonal_or_one(b);
  const float limit = 1.8f * b / g;
  return g > 0 && limit < relax_b ? limit : relax_b;
}

/// One vertex's term of the energy xᵀBx = Σ_k |(W x)_k|² / D_k.
MENISCUS_HD inline double energy_term(Vec3f wx, float area) { return double(length2(wx)) / double(area); }

/// The grain of the fixed tree (deterministic_sum, common/primitives.hpp and cuda/primitives.hpp)
/// in which both backends sum the energies the stats report (xᵀBx before and after the B sweeps;
/// they decide nothing): the same value on any thread count and on either backend.
inline constexpr std::size_t kSumTreeGrain = 4096;

}  // namespace meniscus
