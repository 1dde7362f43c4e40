// meniscus — eigen-decomposition of a symmetric 3×3 matrix by cyclic Jacobi rotations (Golub &
// Van Loan, "Matrix Computations" §8.5), shared by the CPU and CUDA backends. Jacobi rather than
// the closed-form (trigonometric) solution: it keeps full relative accuracy for the small
// eigenvalues of the nearly flat covariances of surface particles, where the closed form loses
// digits to cancellation.
#pragma once

#include <cmath>

#include "meniscus/vec.hpp"

namespace meniscus {

/// A symmetric 3×3 matrix stored as its upper triangle: xx, xy, xz, yy, yz, zz.
struct SymMat3 {
  float xx = 0, xy = 0, xz = 0, yy = 0, yz = 0, zz = 0;
};

MENISCUS_HD inline Vec3f operator*(const SymMat3& m, Vec3f v) {
  return {m.xx * v.x + m.xy * v.y + m.xz * v.z, m.xy * v.x + m.yy * v.y + m.yz * v.z,
          m.xz * v.x + m.yz * v.y + m.zz * v.z};
}

/// Eigenvalues in descending order and the matching orthonormal eigenvectors.
template <class T>
struct Eigen3 {
  T values[3];
  T vectors[3][3];  ///< vectors[k] is the eigenvector of values[k]
};

/// Eigen-decomposition of the symmetric matrix a (a[i][j] == a[j][i] is assumed; only the upper
/// triangle is read). Cyclic Jacobi: sweeps of the three off-diagonal rotations until the
/// off-diagonal part is below 1e-30 of the norm or `max_sweeps` sweeps (6–8 suffice in float,
/// 10 in double; quadratic convergence).
template <class T>
MENISCUS_HD Eigen3<T> eigen_sym3(const T (&in)[3][3], int max_sweeps = 12) {
  T a[3][3] = {{in[0][0], in[0][1], in[0][2]}, {in[0][1], in[1][1], in[1][2]}, {in[0][2], in[1][2], in[2][2]}};
  T v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};  // columns are the eigenvectors
  for (int sweep = 0; sweep < max_sweeps; ++sweep) {
    const T off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
    const T diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
    if (off <= T(1e-30) * diag || off == T(0)) break;
    for (int p = 0; p < 2; ++p)
      for (int q = p + 1; q < 3; ++q) {
        if (a[p][q] == T(0)) continue;
        // The rotation that zeroes a[p][q]: t = tan θ, the smaller root (stable form).
        const T theta = (a[q][q] - a[p][p]) / (T(2) * a[p][q]);
        const T t = (theta >= T(0) ? T(1) : T(-1)) / (std::fabs(theta) + std::sqrt(theta * theta + T(1)));
        const T c = T(1) / std::sqrt(t * t + T(1)), s = t * c;
        for (int k = 0; k < 3; ++k) {  // a ← a J (columns p, q)
          const T akp = a[k][p], akq = a[k][q];
          a[k][p] = c * akp - s * akq;
          a[k][q] = s * akp + c * akq;
        }
        for (int k = 0; k < 3; ++k) {  // a ← Jᵀ a (rows p, q)
          const T apk = a[p][k], aqk = a[q][k];
          a[p][k] = c * apk - s * aqk;
          a[q][k] = s * apk + c * aqk;
        }
        a[p][q] = a[q][p] = T(0);
        for (int k = 0; k < 3; ++k) {  // v ← v J
          const T vkp = v[k][p], vkq = v[k][q];
          v[k][p] = c * vkp - s * vkq;
          v[k][q] = s * vkp + c * vkq;
        }
      }
  }
  int order[3] = {0, 1, 2};
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2 - i; ++j)
      if (a[order[j]][order[j]] < a[order[j + 1]][order[j + 1]]) {
        const int tmp = order[j];
        order[j] = order[j + 1];
        order[j + 1] = tmp;
      }
  Eigen3<T> out{};
  for (int k = 0; k < 3; ++k) {
    out.values[k] = a[order[k]][order[k]];
    for (int r = 0; r < 3; ++r) out.vectors[k][r] = v[r][order[k]];
  }
  return out;
}

}  // namespace meniscus
