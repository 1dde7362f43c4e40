// meniscus — a mesh's directed edges as sorted 64-bit keys: which edges are open (no triangle runs
// them the other way), for the clip's cap and the decimation's border and manifold checks.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "common/for_each.hpp"
#include "common/primitives.hpp"
#include "meniscus/mesh.hpp"

namespace meniscus {

/// The edge a → b: a in the high word.
using EdgeKey = uint64_t;
inline EdgeKey directed_edge(uint32_t a, uint32_t b) { return uint64_t(a) << 32 | b; }
inline EdgeKey reversed(EdgeKey e) { return e << 32 | e >> 32; }
inline uint32_t edge_from(EdgeKey e) { return uint32_t(e >> 32); }
inline uint32_t edge_to(EdgeKey e) { return uint32_t(e); }

/// The directed edges of `triangles` (three each, in their corners' order), sorted.
inline std::vector<EdgeKey> sorted_directed_edges(const std::vector<Triangle>& triangles) {
  std::vector<EdgeKey> edges(3 * triangles.size());
  for_each_chunk(triangles.size(), 4096, [&](std::size_t begin, std::size_t end) {
    for (std::size_t t = begin; t != end; ++t)
      for (std::size_t k = 0; k < 3; ++k) edges[3 * t + k] = directed_edge(triangles[t][k], triangles[t][(k + 1) % 3]);
  });
  sort(Host{}, edges.begin(), edges.end());
  return edges;
}

inline bool contains(const std::vector<EdgeKey>& sorted, EdgeKey e) {
  return std::binary_search(sorted.begin(), sorted.end(), e);
}

/// The edges of `sorted` (sorted_directed_edges) whose reverse is not there, sorted.
inline std::vector<EdgeKey> open_edges(const std::vector<EdgeKey>& sorted) {
  std::vector<EdgeKey> open;
  for (const EdgeKey e : sorted)
    if (!contains(sorted, reversed(e))) open.push_back(e);
  return open;
}

}  // namespace meniscus
