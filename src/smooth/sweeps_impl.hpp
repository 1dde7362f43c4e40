// meniscus — the per-vertex work of the smoothing sweeps (smooth/schedule.hpp), written once for
// both backends: each struct is a MENISCUS_HD callable of the vertex index that for_each_index
// runs on the CPU (smooth.cpp) and in the shared sweeps the device runs (sweeps_backend.hpp). The formulas are those of
// schedule.hpp and operators_impl.hpp; the backends differ only in how a vertex is projected onto
// the constraint (Project: the CPU's cached particle lists, the device's grid queries).
#pragma once

#include <cstdint>

#include "common/atomic_impl.hpp"
#include "meniscus/vec.hpp"
#include "smooth/operators_impl.hpp"
#include "smooth/schedule.hpp"

namespace meniscus {

/// The rows the sweeps read: the neighbour lists (`Neighbors`: the CSR column array or the CPU's
/// compact view, as operators_impl.hpp's row functions take them), the operator W (`diag`: its
/// diagonal, or null to sum it from the row) and D (`area`), and the velocity weighting's factor
/// per vertex (null: 1).
template <class Neighbors>
struct SweepRows {
  const uint32_t* offsets = nullptr;
  Neighbors neighbors{};
  const float* w = nullptr;
  const float* diag = nullptr;
  const float* area = nullptr;
  const float* vertex_relax = nullptr;

  MENISCUS_HD float factor(uint32_t i) const { return vertex_relax != nullptr ? vertex_relax[i] : 1.0f; }
};

/// A sweep without a constraint: the moved position stays.
struct NoProjection {
  MENISCUS_HD Vec3f operator()(uint32_t /*i*/, Vec3f moved, Vec3f /*from*/) const { return moved; }
};

/// An A sweep (Chebyshev weight `weight`): x⁽ˢ⁺¹⁾ of vertex i into `other`, which holds x⁽ˢ⁻¹⁾
/// (read by vertex i alone), projected from x⁽ˢ⁾ where `constrained`.
template <class Neighbors, class Project>
struct ASweep {
  SweepRows<Neighbors> rows;
  const Vec3f* x;
  Vec3f* other;
  float relax, weight;
  bool constrained;
  Project project;

  MENISCUS_HD void operator()(uint64_t k) const {
    const uint32_t i = uint32_t(k);
    const Vec3f y = a_sweep_position(x[i], neighbour_mean_row(rows.offsets, rows.neighbors, x, i), other[i], relax,
                                     rows.factor(i), weight);
    other[i] = constrained ? project(i, y, x[i]) : y;
  }
};

/// Vertex i's B damping ω_i (b_stable_damping), counting those below relax_b into `damped`.
template <class Neighbors>
struct BDamping {
  SweepRows<Neighbors> rows;
  float relax_b;
  float* omega;
  unsigned long long* damped;

  MENISCUS_HD void operator()(uint64_t k) const {
    const uint32_t i = uint32_t(k);
    omega[i] = b_stable_damping(rows.offsets, rows.neighbors, rows.w, rows.diag, rows.area, i, relax_b);
    if (omega[i] < relax_b) count_one(damped);
  }
};

/// (W x)_i of the current iterate.
template <class Neighbors>
struct ApplyW {
  SweepRows<Neighbors> rows;
  const Vec3f* x;
  Vec3f* wx;

  MENISCUS_HD void operator()(uint64_t k) const {
    wx[k] = apply_w_row(rows.offsets, rows.neighbors, rows.w, rows.diag, x, uint32_t(k));
  }
};

/// A B sweep: vertex i moves from the W x of its ring (which no move of the sweep changes), and is
/// projected from where it was where `constrained`.
template <class Neighbors, class Project>
struct BSweep {
  SweepRows<Neighbors> rows;
  const Vec3f* wx;
  const float* omega;
  Vec3f* x;
  bool constrained;
  Project project;

  MENISCUS_HD void operator()(uint64_t k) const {
    const uint32_t i = uint32_t(k);
    const Vec3f from = x[i];
    float b_ii;
    const Vec3f bx = bilaplacian_row_and_diagonal(rows.offsets, rows.neighbors, rows.w,
                                                  w_diagonal(rows.offsets, rows.w, rows.diag, i), rows.area, wx, i, &b_ii);
    const Vec3f moved = b_sweep_position(from, bx, b_ii, omega[i], rows.factor(i));
    x[i] = constrained ? project(i, moved, from) : moved;
  }
};

}  // namespace meniscus
