// meniscus — connected components of a triangle mesh by shared vertices: the void and blob
// removal and the strays (post/strays.hpp) weigh and drop them, the smoothing runs on batches of
// whole components.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "meniscus/mesh.hpp"

namespace meniscus {

/// Each vertex's component root: the smallest vertex of its connected component (triangles that
/// share a vertex join; a vertex no triangle uses is its own root). Lock-free union-find in
/// parallel; the result does not depend on the thread count.
std::vector<uint32_t> component_roots(std::size_t vertex_count, std::span<const Triangle> triangles);

/// A connected component that has triangles: its root (smallest vertex) and signed enclosed volume.
struct Component {
  uint32_t root;
  double volume;
};

/// A run of consecutive triangles of one component: [first, end) and their volume.
struct Run {
  uint32_t root, first, end;
  double volume;
};

/// Connected components by shared vertices: each vertex's root, the components with triangles in
/// root order (a list, not a per-vertex array: a splash frame has millions of vertices and a few
/// thousand components), and the runs of triangles of each component, by root and then in
/// triangle order (a component's triangles, for dropping it without reading the others).
struct MeshComponents {
  std::vector<uint32_t> root;
  std::vector<Component> components;
  std::vector<Run> runs;
};

/// The components of `mesh`, their signed volumes summed in triangle order (the same for any
/// thread count).
MeshComponents mesh_components(const TriangleMesh& mesh);

/// The triangles of the components whose roots `roots` lists (in root order), from their runs:
/// component k's, in triangle order, are triangles[start[k], start[k + 1]).
struct ComponentTriangles {
  std::vector<uint32_t> start{0};
  std::vector<uint32_t> triangles;
};

ComponentTriangles triangles_of(const MeshComponents& c, std::span<const uint32_t> roots);

/// Removes the components whose roots `roots` lists (in root order) with their triangles and
/// vertices (order otherwise preserved; normals and attributes follow if present): the triangles
/// from the components' runs, the vertices as their corners, and one pass over what is kept
/// (drop_sorted) instead of flags over the whole mesh (keep_triangles): the removed components are
/// few and small next to the mesh.
void drop_components(TriangleMesh& mesh, const MeshComponents& c, const std::vector<uint32_t>& roots);

}  // namespace meniscus
