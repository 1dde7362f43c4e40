// meniscus — the mesh adjacency (mesh_buffers.hpp's AdjacencyBuffers: each vertex's neighbours,
// sorted and distinct, and its incident triangles, ascending) written once over the backend tag
// (Host or cuda::Device): the triangle corners sorted stably by vertex, each vertex's triangle list
// found in them by binary search, no atomics, so nothing depends on the threads. The device runs it
// (smooth/smooth_device.cu); the CPU keeps build_adjacency of smooth/adjacency.cpp (counted
// through atomic cursors, rows written on the triangle lists' offsets when every fan is closed:
// no sort of the corners, no scratch per corner), which tests/unit/test_smooth_operators.cpp holds
// to this one array for array.
#pragma once

#include <cstdint>

#include "common/buffer.hpp"
#include "meniscus/vec.hpp"
#include "mesh/mesh_buffers.hpp"

namespace meniscus {

namespace adjacency {

/// keys[c] = corner c's vertex, tri_of[c] = its triangle.
struct CornerKeys {
  const uint32_t* tris;
  uint32_t* keys;
  uint32_t* tri_of;
  MENISCUS_HD void operator()(uint64_t c) const {
    keys[c] = tris[c];
    tri_of[c] = uint32_t(c / 3);
  }
};

/// The first of the n sorted keys that is not below v (n if none).
MENISCUS_HD inline uint64_t lower_bound_of(const uint32_t* keys, uint64_t n, uint64_t v) {
  uint64_t lo = 0, hi = n;
  while (lo < hi) {
    const uint64_t mid = lo + (hi - lo) / 2;
    if (keys[mid] < v) lo = mid + 1; else hi = mid;
  }
  return lo;
}

/// Vertex i's sorted, distinct neighbours gathered from its triangles into out (room for 2 per
/// triangle); returns their count.
MENISCUS_HD inline uint32_t gather_neighbours(const uint32_t* tris, const uint32_t* tri_ids, uint64_t begin, uint64_t end,
                                              uint32_t i, uint32_t* out) {
  uint32_t n = 0;
  for (uint64_t k = begin; k < end; ++k) {
    const uint32_t* t = tris + 3 * uint64_t(tri_ids[k]);
    for (int j = 0; j < 3; ++j)
      if (t[j] != i) out[n++] = t[j];
  }
  for (uint32_t a = 1; a < n; ++a) {  // insertion sort: rows are short
    const uint32_t v = out[a];
    uint32_t b = a;
    while (b > 0 && out[b - 1] > v) out[b] = out[b - 1], --b;
    out[b] = v;
  }
  uint32_t m = 0;
  for (uint32_t a = 0; a < n; ++a)
    if (m == 0 || out[a] != out[m - 1]) out[m++] = out[a];
  return m;
}

/// Vertex i's triangle list, tri_ids[tri_offsets[i] .. tri_offsets[i + 1]), found in the stably
/// sorted corner keys (its first corner is the first key not below i; the last vertex also writes
/// the end), and counts[i] = its neighbour count, its row gathered into scratch at
/// 2 · tri_offsets[i].
struct CountNeighbours {
  const uint32_t* tris;
  const uint32_t* keys;  ///< the corners' vertices, sorted
  uint64_t corners, nv;
  const uint32_t* tri_ids;
  uint32_t* tri_offsets;
  uint32_t* scratch;
  uint32_t* counts;
  MENISCUS_HD void operator()(uint64_t i) const {
    const uint64_t begin = lower_bound_of(keys, corners, i), end = lower_bound_of(keys, corners, i + 1);
    tri_offsets[i] = uint32_t(begin);
    if (i + 1 == nv) tri_offsets[nv] = uint32_t(end);
    counts[i] = gather_neighbours(tris, tri_ids, begin, end, uint32_t(i), scratch + 2 * begin);
  }
};

/// Vertex i's row copied from scratch to neighbors[offsets[i] ..).
struct WriteNeighbours {
  const uint32_t* tri_offsets;
  const uint32_t* scratch;
  const uint32_t* offsets;
  uint32_t* neighbors;
  MENISCUS_HD void operator()(uint64_t i) const {
    const uint32_t* s = scratch + 2 * uint64_t(tri_offsets[i]);
    for (uint32_t k = 0; k < offsets[i + 1] - offsets[i]; ++k) neighbors[offsets[i] + k] = s[k];
  }
};

}  // namespace adjacency

/// The adjacency of `mesh` on backend B (needs B's sort_pairs and exclusive_sum: include
/// common/primitives.hpp or cuda/primitives.hpp first).
template <class B>
AdjacencyBuffers<B> build_adjacency(B backend, const MeshBuffers<B>& mesh) {
  using namespace adjacency;
  AdjacencyBuffers<B> adj;
  const uint64_t nv = mesh.vertex_count, corners = 3 * uint64_t(mesh.triangle_count);
  if (nv == 0) {
    adj.offsets.resize(1);
    adj.offsets.zero();
    adj.tri_offsets.resize(1);
    adj.tri_offsets.zero();
    return adj;
  }
  BufferOf<B, uint32_t> keys(corners);
  adj.tri_ids.resize(corners);
  adj.tri_offsets.resize(nv + 1);
  for_each_index(backend, corners, CornerKeys{mesh.triangles.data(), keys.data(), adj.tri_ids.data()});
  sort_pairs(backend, keys.data(), adj.tri_ids.data(), corners, 0, 32);  // stable: each vertex's triangles ascending
  BufferOf<B, uint32_t> scratch(2 * corners), counts(nv);
  for_each_index(backend, nv,
                 CountNeighbours{mesh.triangles.data(), keys.data(), corners, nv, adj.tri_ids.data(),
                                 adj.tri_offsets.data(), scratch.data(), counts.data()});
  keys.resize(0);
  adj.offsets.resize(nv + 1);
  exclusive_sum(backend, static_cast<const uint32_t*>(counts.data()), adj.offsets.data(), nv);
  adj.neighbors.resize(adj.offsets.get(nv));
  for_each_index(backend, nv,
                 WriteNeighbours{adj.tri_offsets.data(), scratch.data(), adj.offsets.data(), adj.neighbors.data()});
  return adj;
}

}  // namespace meniscus
