// meniscus — A and B operators (Williams 2008 §4; Desbrun et al. 1999 for the cotangent form).
#include "smooth/operators.hpp"

#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>

#include "smooth/cotangent_impl.hpp"

namespace meniscus {

CotanOperator build_cotan_operator(std::span<const Vec3f> x, std::span<const Triangle> triangles,
                                   const Adjacency& adj) {
  const std::size_t nv = adj.vertex_count();
  CotanOperator op;
  op.w.assign(adj.neighbors.size(), 0.0f);
  op.diag.assign(nv, 0.0f);
  op.area.assign(nv, 0.0f);
  op.b_diag.assign(nv, 0.0f);
  // Each vertex assembles its own row from its incident triangles: no two threads write the
  // same entry, so no atomics are needed.
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, 1024), [&](const auto& r) {
    for (std::size_t iv = r.begin(); iv != r.end(); ++iv) {
      const uint32_t i = uint32_t(iv);
      const auto row = adj.row(i);
      float* wrow = op.w.data() + adj.offsets[i];
      float area = 0;
      for (uint32_t k = adj.tri_offsets[i]; k < adj.tri_offsets[i + 1]; ++k) {
        const Triangle& t = triangles[adj.tri_ids[k]];
        const int c = t[0] == i ? 0 : (t[1] == i ? 1 : 2);
        const uint32_t j = t[(c + 1) % 3], l = t[(c + 2) % 3];
        const Vec3f pi = x[i], pj = x[j], pl = x[l];
        // Edge (i, j) is opposite the angle at l; edge (i, l) is opposite the angle at j.
        const float cot_l = clamped_cotangent(pl, pi, pj);
        const float cot_j = clamped_cotangent(pj, pi, pl);
        const auto at = [&](uint32_t v) { return std::size_t(std::lower_bound(row.begin(), row.end(), v) - row.begin()); };
        wrow[at(j)] += cot_l;
        wrow[at(l)] += cot_j;
        area += clamped_area(pi, pj, pl);
      }
      float sum = 0;
      for (std::size_t k = 0; k < row.size(); ++k) sum += wrow[k];
      op.diag[i] = -sum;
      op.area[i] = area / 3.0f;
    }
  });
  // Vertices that collapsed onto a neighbour have no area; a floor relative to the mean area
  // keeps D invertible without changing any healthy vertex.
  double mean_area = 0;
  for (float a : op.area) mean_area += a;
  mean_area /= double(std::max<std::size_t>(nv, 1));
  const float area_floor = float(std::max(mean_area * 1e-6, 1e-30));
  for (float& a : op.area) a = std::max(a, area_floor);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, 1024), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      float b = op.diag[i] * op.diag[i] / op.area[i];
      const auto row = adj.row(uint32_t(i));
      for (std::size_t k = 0; k < row.size(); ++k) {
        const float wik = op.w[adj.offsets[i] + k];
        b += wik * wik / op.area[row[k]];
      }
      // An isolated vertex has no B row; a unit diagonal leaves it in place (its row is zero).
      op.b_diag[i] = b > 0 && std::isfinite(b) ? b : 1.0f;
    }
  });
  return op;
}

void apply_w(const Adjacency& adj, const CotanOperator& op, std::span<const Vec3f> x, std::span<Vec3f> y) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, x.size(), 2048), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      Vec3f acc = x[i] * op.diag[i];
      for (uint32_t k = adj.offsets[i]; k < adj.offsets[i + 1]; ++k) acc += x[adj.neighbors[k]] * op.w[k];
      y[i] = acc;
    }
  });
}

double bilaplacian_energy(const CotanOperator& op, std::span<const Vec3f> wx) {
  // Deterministic: the energy decides whether a sweep is redone with a smaller ω, so the same
  // input must give the same sum whatever the thread scheduling.
  return tbb::parallel_deterministic_reduce(
      tbb::blocked_range<std::size_t>(0, wx.size(), 4096), 0.0,
      [&](const auto& r, double e) {
        for (std::size_t k = r.begin(); k != r.end(); ++k) e += double(length2(wx[k])) / double(op.area[k]);
        return e;
      },
      std::plus<>());
}

Vec3f bilaplacian_row(const Adjacency& adj, const CotanOperator& op, std::span<const Vec3f> x, uint32_t i) {
  auto wx = [&](uint32_t k) {
    Vec3f acc = x[k] * op.diag[k];
    for (uint32_t e = adj.offsets[k]; e < adj.offsets[k + 1]; ++e) acc += x[adj.neighbors[e]] * op.w[e];
    return acc;
  };
  Vec3f out = wx(i) * (op.diag[i] / op.area[i]);
  for (uint32_t e = adj.offsets[i]; e < adj.offsets[i + 1]; ++e) {
    const uint32_t k = adj.neighbors[e];
    out += wx(k) * (op.w[e] / op.area[k]);
  }
  return out;
}

}  // namespace meniscus
