// meniscus — connected components, small interior voids and unsupported blobs written once over
// the backend tag (mesh/voids.hpp, mesh/components.hpp): components by parallel hooking
// (min-label union-find), their signed volumes, and the dropping of the small ones.
//
// The device runs it (voids_device.cu); the CPU runs mesh/voids.cpp and components.cpp, which
// keep each component's triangles as runs and sum its volume in triangle order, and a unit test
// holds the two equal with this one run on Host{}. Here the volumes are summed by atomic adds, in
// an order that depends on the threads (docs/gpu.md lists it): a component whose volume lies within
// rounding of a threshold could be judged differently from run to run.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>

#include "common/atomic.hpp"
#include "common/buffer.hpp"
#include "grid/grid_buffers.hpp"
#include "mesh/mesh_buffers.hpp"
#include "mesh/ray_parity_impl.hpp"
#include "mesh/volume_impl.hpp"

namespace meniscus {

namespace voids_backend {

MENISCUS_HD inline uint32_t find_root(uint32_t* parent, uint32_t x) {
  for (uint32_t p = load_relaxed(parent + x); p != x; p = load_relaxed(parent + x)) x = p;  // others hook meanwhile
  return x;
}

struct InitParent {
  uint32_t* parent;
  MENISCUS_HD void operator()(uint64_t v) const { parent[v] = uint32_t(v); }
};

/// Hooks the roots of each triangle's corners onto the smallest (min-label connected components).
struct Hook {
  const uint32_t* tris;
  uint32_t* parent;
  uint32_t* changed;
  MENISCUS_HD void operator()(uint64_t t) const {
    uint32_t r[3];
    for (int k = 0; k < 3; ++k) r[k] = find_root(parent, tris[3 * t + k]);
    uint32_t m = r[0] < r[1] ? r[0] : r[1];
    m = m < r[2] ? m : r[2];
    for (int k = 0; k < 3; ++k)
      if (r[k] != m) {
        atomic_min(parent + r[k], m);
        store_relaxed(changed, 1u);
      }
  }
};

struct Compress {
  uint32_t* parent;
  MENISCUS_HD void operator()(uint64_t v) const { store_relaxed(parent + v, find_root(parent, uint32_t(v))); }
};

/// Each triangle's signed volume onto its component's root, and the root marked as having triangles.
struct Volumes {
  const uint32_t* tris;
  const Vec3f* x;
  const uint32_t* root;
  double* volume;
  uint32_t* has;
  MENISCUS_HD void operator()(uint64_t t) const {
    const Vec3f a = x[tris[3 * t]], b = x[tris[3 * t + 1]], c = x[tris[3 * t + 2]];
    const uint32_t r = root[tris[3 * t]];
    atomic_add(volume + r, signed_volume6(a, b, c) / 6.0);
    store_relaxed(has + r, 1u);
  }
};

/// Flags the roots of the small voids (volume in (−max_volume, 0]) and counts them.
struct VoidFlags {
  const uint32_t* root;
  const double* volume;
  const uint32_t* has;
  double max_volume;
  uint8_t* drop;
  unsigned long long* removed;
  MENISCUS_HD void operator()(uint64_t v) const {
    const bool d = root[v] == v && has[v] && volume[v] <= 0.0 && volume[v] > -max_volume;
    drop[v] = d ? 1 : 0;
    if (d) atomic_add(removed, 1ull);
  }
};

/// keep[t]: the triangle's component stays; used[v]: a kept triangle uses the vertex.
struct KeepFlags {
  const uint32_t* tris;
  const uint32_t* root;
  const uint8_t* drop;
  uint32_t* keep;
  uint32_t* used;
  MENISCUS_HD void operator()(uint64_t t) const {
    const bool k = !drop[root[tris[3 * t]]];
    keep[t] = k ? 1u : 0u;
    if (k)
      for (int j = 0; j < 3; ++j) store_relaxed(used + tris[3 * t + j], 1u);
  }
};

/// The kept triangles (renumbered) and used vertices at their scanned positions; index i is
/// triangle i and vertex i.
struct Compact {
  const uint32_t* tris;
  uint64_t nt;
  const uint32_t* keep;
  const uint32_t* tri_pos;
  const uint32_t* used;
  const uint32_t* vertex_pos;
  const Vec3f* x;
  uint64_t nv;
  uint32_t* new_tris;
  Vec3f* new_x;
  MENISCUS_HD void operator()(uint64_t i) const {
    if (i < nt && keep[i])
      for (int j = 0; j < 3; ++j) new_tris[3 * uint64_t(tri_pos[i]) + j] = vertex_pos[tris[3 * i + j]];
    if (i < nv && used[i]) new_x[vertex_pos[i]] = x[i];
  }
};

/// Flags the small outward components' roots (volume in (0, max_volume]).
struct BlobCandidates {
  const uint32_t* root;
  const double* volume;
  const uint32_t* has;
  double max_volume;
  uint32_t* flag;
  MENISCUS_HD void operator()(uint64_t v) const {
    flag[v] = root[v] == v && has[v] && volume[v] > 0.0 && volume[v] <= max_volume ? 1u : 0u;
  }
};

/// The candidates' roots in root order (slot: the flags' exclusive scan).
struct CandidateList {
  const uint32_t* flag;
  const uint32_t* slot;
  uint32_t* candidates;
  MENISCUS_HD void operator()(uint64_t v) const {
    if (flag[v]) candidates[slot[v]] = uint32_t(v);
  }
};

/// Counts the triangles of each candidate.
struct BlobCounts {
  const uint32_t* tris;
  const uint32_t* root;
  const uint32_t* flag;
  const uint32_t* slot;
  uint32_t* counts;
  MENISCUS_HD void operator()(uint64_t t) const {
    const uint32_t r = root[tris[3 * t]];
    if (flag[r]) atomic_add(counts + slot[r], 1u);
  }
};

/// Buckets the candidates' triangles (any order within a bucket: the blob test does not depend on it).
struct BlobFill {
  const uint32_t* tris;
  const uint32_t* root;
  const uint32_t* flag;
  const uint32_t* slot;
  const uint32_t* start;
  uint32_t* cursor;
  uint32_t* ids;
  MENISCUS_HD void operator()(uint64_t t) const {
    const uint32_t r = root[tris[3 * t]];
    if (flag[r]) ids[start[slot[r]] + atomic_add(cursor + slot[r], 1u)] = uint32_t(t);
  }
};

/// One candidate: dropped when smaller than the inner ball or enclosing no particle.
struct BlobTest {
  GridView grid;
  const uint32_t* tris;
  const Vec3f* x;
  const uint32_t* candidates;
  const uint32_t* start;
  const uint32_t* ids;
  const double* volume;
  double min_volume;
  uint8_t* drop;
  unsigned long long* removed;
  MENISCUS_HD void operator()(uint64_t k) const {
    const uint32_t r = candidates[k];
    const bool empty = volume[r] <= min_volume || !encloses_a_point(grid, tris, ids + start[k], start[k + 1] - start[k], x);
    if (empty) {
      drop[r] = 1;
      atomic_add(removed, 1ull);
    }
  }
};

}  // namespace voids_backend

/// The CPU backend's blob tests: a candidate is a few dozen triangles and a ray cast, so one task
/// takes several.
inline void blob_tests(Host, std::size_t candidates, const voids_backend::BlobTest& test) {
  for_each_index(candidates, 16, test);
}

/// The components of a mesh on backend B (components.hpp's mesh_components): each vertex's root
/// (the component's smallest vertex), and per root the signed volume and whether it has triangles.
template <class B>
struct ComponentBuffers {
  BufferOf<B, uint32_t> root;
  BufferOf<B, double> volume;
  BufferOf<B, uint32_t> has;
};

template <class B>
ComponentBuffers<B> mesh_components(B b, const MeshBuffers<B>& mesh) {
  using namespace voids_backend;
  const uint64_t nv = mesh.vertex_count, nt = mesh.triangle_count;
  ComponentBuffers<B> c;
  c.root.resize(nv);
  for_each_index(b, nv, InitParent{c.root.data()});
  BufferOf<B, uint32_t> changed(1);
  for (;;) {
    changed.zero();
    for_each_index(b, nt, Hook{mesh.triangles.data(), c.root.data(), changed.data()});
    for_each_index(b, nv, Compress{c.root.data()});
    if (changed.get(0) == 0) break;
  }
  c.volume.resize(nv);
  c.has.resize(nv);
  c.volume.zero();
  c.has.zero();
  for_each_index(b, nt, Volumes{mesh.triangles.data(), mesh.vertices.data(), c.root.data(), c.volume.data(), c.has.data()});
  return c;
}

/// Drops the triangles of the components whose root has drop[root] set, then the vertices no
/// triangle uses (order otherwise preserved), as the CPU's drop_components.
template <class B>
void drop_components(B b, MeshBuffers<B>& mesh, const BufferOf<B, uint32_t>& root, const BufferOf<B, uint8_t>& drop) {
  using namespace voids_backend;
  const uint64_t nv = mesh.vertex_count, nt = mesh.triangle_count;
  BufferOf<B, uint32_t> keep(nt), tri_pos(nt + 1), used(nv), vertex_pos(nv + 1);
  used.zero();
  for_each_index(b, nt, KeepFlags{mesh.triangles.data(), root.data(), drop.data(), keep.data(), used.data()});
  exclusive_sum(b, keep.data(), tri_pos.data(), nt);
  exclusive_sum(b, used.data(), vertex_pos.data(), nv);
  const uint32_t new_nt = tri_pos.get(nt), new_nv = vertex_pos.get(nv);
  BufferOf<B, uint32_t> new_tris(3 * std::size_t(new_nt));
  BufferOf<B, Vec3f> new_x(new_nv);
  for_each_index(b, nt > nv ? nt : nv,
                 Compact{mesh.triangles.data(), nt, keep.data(), tri_pos.data(), used.data(), vertex_pos.data(),
                         mesh.vertices.data(), nv, new_tris.data(), new_x.data()});
  mesh.triangles = std::move(new_tris);
  mesh.vertices = std::move(new_x);
  mesh.triangle_count = new_nt;
  mesh.vertex_count = new_nv;
}

/// remove_small_voids() (voids.hpp) on backend B; returns the number of voids removed.
template <class B>
std::size_t remove_small_voids(B b, MeshBuffers<B>& mesh, double max_volume) {
  using namespace voids_backend;
  const uint64_t nv = mesh.vertex_count, nt = mesh.triangle_count;
  if (nv == 0 || nt == 0) return 0;
  const ComponentBuffers<B> c = mesh_components(b, mesh);
  BufferOf<B, uint8_t> drop(nv);
  BufferOf<B, unsigned long long> removed(1);
  removed.zero();
  for_each_index(b, nv, VoidFlags{c.root.data(), c.volume.data(), c.has.data(), max_volume, drop.data(), removed.data()});
  const std::size_t count = std::size_t(removed.get(0));
  if (count > 0) drop_components(b, mesh, c.root, drop);
  return count;
}

/// remove_unsupported_blobs() (voids.hpp) on backend B, against the points of `grid`; returns the
/// number of components removed.
template <class B>
std::size_t remove_unsupported_blobs(B b, MeshBuffers<B>& mesh, const GridBuffers<B>& grid, double max_volume,
                                     double min_volume) {
  using namespace voids_backend;
  const uint64_t nv = mesh.vertex_count, nt = mesh.triangle_count;
  if (nv == 0 || nt == 0) return 0;
  const ComponentBuffers<B> c = mesh_components(b, mesh);
  BufferOf<B, uint32_t> flag(nv), slot(nv + 1);
  for_each_index(b, nv, BlobCandidates{c.root.data(), c.volume.data(), c.has.data(), max_volume, flag.data()});
  exclusive_sum(b, flag.data(), slot.data(), nv);
  const uint32_t candidates = slot.get(nv);
  if (candidates == 0) return 0;
  BufferOf<B, uint32_t> list(candidates), counts(candidates), start(std::size_t(candidates) + 1), cursor(candidates);
  for_each_index(b, nv, CandidateList{flag.data(), slot.data(), list.data()});
  counts.zero();
  for_each_index(b, nt, BlobCounts{mesh.triangles.data(), c.root.data(), flag.data(), slot.data(), counts.data()});
  exclusive_sum(b, counts.data(), start.data(), candidates);
  BufferOf<B, uint32_t> ids(start.get(candidates));
  cursor.zero();
  for_each_index(b, nt,
                 BlobFill{mesh.triangles.data(), c.root.data(), flag.data(), slot.data(), start.data(), cursor.data(),
                          ids.data()});
  BufferOf<B, uint8_t> drop(nv);
  drop.zero();
  BufferOf<B, unsigned long long> removed(1);
  removed.zero();
  blob_tests(b, candidates,
             BlobTest{grid.view(), mesh.triangles.data(), mesh.vertices.data(), list.data(), start.data(), ids.data(),
                      c.volume.data(), min_volume, drop.data(), removed.data()});
  const std::size_t count = std::size_t(removed.get(0));
  if (count > 0) drop_components(b, mesh, c.root, drop);
  return count;
}

}  // namespace meniscus
