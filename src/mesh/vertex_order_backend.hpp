// meniscus — reorder_vertices_spatially() written once over the backend tag (Host or cuda::Device):
// Morton keys (vertex_order_impl.hpp), stable sorts by the backend's sort_pairs, a gather of the
// vertices and of the triangles. The device runs it (mesh/vertex_order_device.cu); the CPU keeps
// its memory-tuned version (vertex_order.cpp: packed keys, no permutation array, the triangles
// sorted in place), which tests/unit/test_vertex_order.cpp holds to this one bit for bit.
#pragma once

#include <algorithm>
#include <cstdint>
#include <utility>

#include "common/buffer.hpp"
#include "meniscus/vec.hpp"
#include "mesh/mesh_buffers.hpp"
#include "mesh/vertex_order_impl.hpp"

namespace meniscus {

namespace vertex_order {

/// keys[i] = vertex i's Morton key, ids[i] = i.
struct MortonKeys {
  const Vec3f* x;
  float inv_cell;
  uint32_t* keys;
  uint32_t* ids;
  MENISCUS_HD void operator()(uint64_t i) const {
    keys[i] = morton_key(x[i], inv_cell);
    ids[i] = uint32_t(i);
  }
};

/// out[i] = x[old_of_new[i]] and new_of_old, the inverse permutation.
struct PermuteVertices {
  const Vec3f* x;
  const uint32_t* old_of_new;
  Vec3f* out;
  uint32_t* new_of_old;
  MENISCUS_HD void operator()(uint64_t i) const {
    out[i] = x[old_of_new[i]];
    new_of_old[old_of_new[i]] = uint32_t(i);
  }
};

/// Triangle t renumbered in place; keys[t] = its smallest new corner, ids[t] = t.
struct RemapTriangles {
  uint32_t* tris;
  const uint32_t* new_of_old;
  uint32_t* keys;
  uint32_t* ids;
  MENISCUS_HD void operator()(uint64_t t) const {
    uint32_t* tri = tris + 3 * t;
    const uint32_t a = new_of_old[tri[0]], b = new_of_old[tri[1]], c = new_of_old[tri[2]];
    tri[0] = a;
    tri[1] = b;
    tri[2] = c;
    const uint32_t ab = a < b ? a : b;
    keys[t] = ab < c ? ab : c;
    ids[t] = uint32_t(t);
  }
};

/// out's triangle t = tris' triangle order[t].
struct GatherTriangles {
  const uint32_t* tris;
  const uint32_t* order;
  uint32_t* out;
  MENISCUS_HD void operator()(uint64_t t) const {
    const uint32_t* src = tris + 3 * uint64_t(order[t]);
    out[3 * t] = src[0];
    out[3 * t + 1] = src[1];
    out[3 * t + 2] = src[2];
  }
};

}  // namespace vertex_order

/// reorder_vertices_spatially() (mesh/vertex_order.hpp: the contract) on backend B's arrays:
/// the vertices in the Z order of their cells of size `cell` (ties keep the old order), the
/// triangles renumbered and sorted stably by their smallest new corner.
template <class B>
void reorder_vertices_spatially(B backend, MeshBuffers<B>& mesh, float cell) {
  using namespace vertex_order;
  const std::size_t nv = mesh.vertex_count, nt = mesh.triangle_count;
  if (nv < 2) return;

  BufferOf<B, uint32_t> keys(std::max(nv, nt)), ids(std::max(nv, nt)), new_of_old(nv);
  for_each_index(backend, nv, MortonKeys{mesh.vertices.data(), 1.0f / cell, keys.data(), ids.data()});
  sort_pairs(backend, keys.data(), ids.data(), nv, 0, 30);  // stable: ties keep the old order
  BufferOf<B, Vec3f> sorted(nv);
  for_each_index(backend, nv, PermuteVertices{mesh.vertices.data(), ids.data(), sorted.data(), new_of_old.data()});
  mesh.vertices = std::move(sorted);
  if (nt == 0) return;

  for_each_index(backend, nt, RemapTriangles{mesh.triangles.data(), new_of_old.data(), keys.data(), ids.data()});
  sort_pairs(backend, keys.data(), ids.data(), nt, 0, 32);
  BufferOf<B, uint32_t> tris(3 * nt);
  for_each_index(backend, nt, GatherTriangles{mesh.triangles.data(), ids.data(), tris.data()});
  mesh.triangles = std::move(tris);
}

}  // namespace meniscus
