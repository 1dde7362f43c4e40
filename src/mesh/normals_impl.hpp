// meniscus — the per-element work of vertex normals and erosion (docs/method.md), written once for
// both backends as MENISCUS_HD callables of the element index that for_each_index runs on the CPU
// (mesh/normals.cpp) and by the shared stages (mesh/normals_backend.hpp) the device runs. Triangles are read through
// corners_of(tris, f): the device's flat index array or the CPU's Triangle array.
#pragma once

#include <cstdint>

#include "common/atomic_impl.hpp"
#include "meniscus/mesh.hpp"
#include "meniscus/vec.hpp"

namespace meniscus {

MENISCUS_HD inline const uint32_t* corners_of(const uint32_t* tris, uint64_t f) { return tris + 3 * f; }
inline const uint32_t* corners_of(const Triangle* tris, uint64_t f) { return tris[f].data(); }

/// Triangle t's cross product (x1 − x0) × (x2 − x0): twice its area along its normal.
MENISCUS_HD inline Vec3f face_cross(const Vec3f* x, const uint32_t* t) { return cross(x[t[1]] - x[t[0]], x[t[2]] - x[t[0]]); }

/// Vertex i's unit area-weighted normal, gathered from its triangles (tri_ids[tri_offsets[i] ..
/// tri_offsets[i+1]), ascending: the order in which the CPU's scatter adds them, so the sums are
/// the same bits). The CPU scatters instead (vertex_normals: no incidence lists to build); a test
/// holds the two to the same bits.
template <class Tris>
struct GatherNormal {
  const Vec3f* x;
  Tris tris;
  const uint32_t* tri_offsets;
  const uint32_t* tri_ids;
  Vec3f* n;

  MENISCUS_HD void operator()(uint64_t i) const {
    Vec3f sum{0, 0, 0};
    for (uint32_t k = tri_offsets[i]; k < tri_offsets[i + 1]; ++k) sum += face_cross(x, corners_of(tris, tri_ids[k]));
    n[i] = normalized(sum);
  }
};

/// Erosion's first pass: every triangle's cross product before the move.
template <class Tris>
struct FaceCross {
  const Vec3f* x;
  Tris tris;
  Vec3f* out;

  MENISCUS_HD void operator()(uint64_t f) const { out[f] = face_cross(x, corners_of(tris, f)); }
};

/// Erosion's move: x_i ← x_i − e·n_i.
struct MoveAlongNormal {
  Vec3f* x;
  const Vec3f* n;
  float distance;

  MENISCUS_HD void operator()(uint64_t i) const { x[i] -= n[i] * distance; }
};

/// Counts the triangles whose orientation the move flipped (a sign of self-intersection).
template <class Tris>
struct CountFlipped {
  const Vec3f* x;
  Tris tris;
  const Vec3f* before;
  unsigned long long* flipped;

  MENISCUS_HD void operator()(uint64_t f) const {
    if (dot(face_cross(x, corners_of(tris, f)), before[f]) < 0.0f) count_one(flipped);
  }
};

/// Erosion after the normals: moves the nv vertices x inwards by `distance` along `normals` and
/// adds the flipped triangles of the nt to `flipped` (zeroed by the caller); `before` holds nt
/// vectors. On the backend named by its tag (Host, cuda::Device).
template <class Backend, class Tris>
void erode_along(Backend backend, Vec3f* x, Tris tris, uint64_t nv, uint64_t nt, const Vec3f* normals, Vec3f* before,
                 float distance, unsigned long long* flipped) {
  for_each_index(backend, nt, FaceCross<Tris>{x, tris, before});
  for_each_index(backend, nv, MoveAlongNormal{x, normals, distance});
  for_each_index(backend, nt, CountFlipped<Tris>{x, tris, before, flipped});
}

}  // namespace meniscus
