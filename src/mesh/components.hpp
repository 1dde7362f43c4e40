// meniscus — connected components of a triangle mesh by shared vertices: the void and blob
// removal weigh them, the smoothing runs on batches of whole components.
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

}  // namespace meniscus
