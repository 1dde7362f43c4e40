// meniscus — a triangle mesh and its connectivity as arrays of either backend (BufferOf<B, T>):
// the form the stages written once over the backend tag pass between them. The CPU's stages
// work on TriangleMesh and Adjacency (smooth/adjacency.hpp), which hold the same arrays.
#pragma once

#include <cstddef>
#include <cstdint>

#include "common/buffer.hpp"
#include "meniscus/vec.hpp"

namespace meniscus {

template <class B>
struct MeshBuffers {
  BufferOf<B, Vec3f> vertices;
  BufferOf<B, uint32_t> triangles;  ///< 3 per triangle
  std::size_t vertex_count = 0, triangle_count = 0;
};

/// Vertex rows (CSR): each vertex's neighbours, sorted, and the triangles around it, ascending.
template <class B>
struct AdjacencyBuffers {
  BufferOf<B, uint32_t> offsets, neighbors, tri_offsets, tri_ids;
};

}  // namespace meniscus
