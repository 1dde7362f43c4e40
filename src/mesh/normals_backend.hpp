// meniscus — area-weighted vertex normals and erosion along them (docs/method.md) written once over
// the backend tag (Host or cuda::Device) and the arrays of mesh_buffers.hpp: the normals gathered
// per vertex from its triangle lists (GatherNormal), erosion's passes (erode_along). The device
// runs them (mesh/normals_device.cu). The CPU keeps its scatter (normals.cpp: no vertex → triangle
// lists to build, waves of chunks that share no vertex), which tests/unit/test_transfer.cpp holds
// to the gather bit for bit.
#pragma once

#include <cstddef>
#include <cstdint>

#include "common/buffer.hpp"
#include "mesh/mesh_buffers.hpp"
#include "mesh/normals_impl.hpp"

namespace meniscus {

/// Unit area-weighted normals of `mesh`'s vertices ((0,0,0) for a vertex without triangles), from
/// the triangle lists of its adjacency `adj`.
template <class B>
BufferOf<B, Vec3f> vertex_normals(B backend, const MeshBuffers<B>& mesh, const AdjacencyBuffers<B>& adj) {
  BufferOf<B, Vec3f> n(mesh.vertex_count);
  for_each_index(backend, mesh.vertex_count,
                 GatherNormal<const uint32_t*>{mesh.vertices.data(), mesh.triangles.data(), adj.tri_offsets.data(),
                                               adj.tri_ids.data(), n.data()});
  return n;
}

/// Moves every vertex of `mesh` inwards by `distance` along its normal (x ← x − e·n); returns the
/// number of triangles whose orientation flipped (a sign of self-intersection).
template <class B>
std::size_t erode(B backend, MeshBuffers<B>& mesh, const AdjacencyBuffers<B>& adj, float distance) {
  if (mesh.vertex_count == 0) return 0;
  const BufferOf<B, Vec3f> n = vertex_normals(backend, mesh, adj);
  BufferOf<B, Vec3f> before(mesh.triangle_count);
  BufferOf<B, unsigned long long> flipped(1);
  flipped.zero();
  erode_along(backend, mesh.vertices.data(), static_cast<const uint32_t*>(mesh.triangles.data()), mesh.vertex_count,
              mesh.triangle_count, n.data(), before.data(), distance, flipped.data());
  return std::size_t(flipped.get(0));
}

}  // namespace meniscus
