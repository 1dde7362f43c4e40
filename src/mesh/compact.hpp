// meniscus — dropping triangles from a mesh, and with them the vertices no triangle uses, in
// parallel and in order (the void and blob removal, the weld's repeated-vertex triangles).
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "common/huge_pages.hpp"
#include "meniscus/mesh.hpp"

namespace meniscus {

namespace detail {

inline constexpr std::size_t kCompactChunk = std::size_t(1) << 15;

/// Per chunk of kCompactChunk indices of [0, n), the position of its first index with set(i)
/// among all such indices (an exclusive scan of the chunks' counts, in chunk order); returns the
/// total.
template <class Set>
std::size_t chunk_offsets(std::size_t n, Set&& set, std::vector<std::size_t>& offsets) {
  const std::size_t chunks = (n + kCompactChunk - 1) / kCompactChunk;
  offsets.assign(chunks + 1, 0);
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
    std::size_t count = 0;
    for (std::size_t i = c * kCompactChunk, end = std::min(n, i + kCompactChunk); i < end; ++i) count += set(i) ? 1 : 0;
    offsets[c + 1] = count;
  });
  for (std::size_t c = 0; c < chunks; ++c) offsets[c + 1] += offsets[c];
  return offsets[chunks];
}

/// Calls f(i, rank) for every index i of [0, n) with set(i), rank its position among them;
/// parallel over the chunks of `offsets` (as chunk_offsets made them for the same n and set).
template <class Set, class F>
void for_each_set(std::size_t n, Set&& set, const std::vector<std::size_t>& offsets, F&& f) {
  tbb::parallel_for(std::size_t(0), offsets.size() - 1, [&](std::size_t c) {
    std::size_t rank = offsets[c];
    for (std::size_t i = c * kCompactChunk, end = std::min(n, i + kCompactChunk); i < end; ++i)
      if (set(i)) f(i, rank++);
  });
}

/// The flags' versions: index i is set where flags[i] is.
inline std::size_t chunk_offsets(const std::vector<uint8_t>& flags, std::vector<std::size_t>& offsets) {
  return chunk_offsets(flags.size(), [&](std::size_t i) { return flags[i] != 0; }, offsets);
}
template <class F>
void for_each_set(const std::vector<uint8_t>& flags, const std::vector<std::size_t>& offsets, F&& f) {
  for_each_set(flags.size(), [&](std::size_t i) { return flags[i] != 0; }, offsets, std::forward<F>(f));
}

/// Moves the elements whose flag is set (groups of `per` values, flags.size() groups) to the front
/// of `values`, in order, and shrinks it to them; `offsets` as chunk_offsets made them. In place:
/// each chunk first packs its own elements to its front (parallel), then the packed chunks slide
/// down in chunk order (a chunk's target never reaches past its own start), so no second copy of
/// a mesh array is ever allocated — the arrays of a splash frame run to hundreds of MB, while
/// the components dropped are a few.
template <class T>
void compact_in_place(std::vector<T>& values, std::size_t per, const std::vector<uint8_t>& flags,
                      const std::vector<std::size_t>& offsets) {
  if (values.empty()) return;
  const std::size_t chunks = offsets.size() - 1;
  const auto at = [&](std::size_t i) { return values.begin() + std::ptrdiff_t(i * per); };
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
    std::size_t out = c * kCompactChunk;
    for (std::size_t i = c * kCompactChunk, end = std::min(flags.size(), i + kCompactChunk); i < end; ++i)
      if (flags[i]) {
        if (out != i) std::copy(at(i), at(i + 1), at(out));
        ++out;
      }
  });
  for (std::size_t c = 0; c < chunks; ++c) {
    const std::size_t from = c * kCompactChunk, to = offsets[c], count = offsets[c + 1] - offsets[c];
    if (from != to && count > 0)
      std::copy(at(from), at(from + count), at(to));  // to < from: a forward copy is safe
  }
  values.resize(offsets[chunks] * per);
}

/// Compacts the mesh to the triangles with kept[t] and the vertices with used[v] (which must be
/// every vertex a kept triangle uses), in order; returns the number of triangles dropped.
inline std::size_t compact_mesh(TriangleMesh& mesh, std::vector<uint8_t>& kept, const std::vector<uint8_t>& used) {
  const std::size_t nt = mesh.triangles.size(), nv = mesh.vertices.size();
  std::vector<std::size_t> offsets;
  const std::size_t new_nt = chunk_offsets(kept, offsets);
  if (new_nt == nt) return 0;
  compact_in_place(mesh.triangles, 1, kept, offsets);
  std::vector<uint8_t>().swap(kept);

  chunk_offsets(used, offsets);
  std::vector<uint32_t> remap;
  assign_populated(remap, nv, ~0u);
  for_each_set(used, offsets, [&](std::size_t v, std::size_t k) { remap[v] = uint32_t(k); });
  compact_in_place(mesh.vertices, 1, used, offsets);
  compact_in_place(mesh.normals, 1, used, offsets);
  for (Attribute& a : mesh.attributes) compact_in_place(a.values, std::size_t(a.components), used, offsets);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, new_nt, 4096), [&](const auto& r) {
    for (std::size_t t = r.begin(); t != r.end(); ++t)
      for (uint32_t& v : mesh.triangles[t]) v = remap[v];
  });
  return nt - new_nt;
}

}  // namespace detail

/// Keeps the triangles t with keep(t) (in order), then drops the vertices no kept triangle uses
/// (in order; normals and per-vertex attributes follow). Parallel and in place, and the result
/// does not depend on the thread count. Returns the number of triangles dropped (none: the mesh
/// is left as it is).
template <class Keep>
std::size_t keep_triangles(TriangleMesh& mesh, Keep&& keep) {
  const std::size_t nt = mesh.triangles.size(), nv = mesh.vertices.size();
  std::vector<uint8_t> kept, used;
  assign_populated(kept, nt, uint8_t(0));
  assign_populated(used, nv, uint8_t(0));
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nt, 4096), [&](const auto& r) {
    for (std::size_t t = r.begin(); t != r.end(); ++t)
      if (keep(mesh.triangles[t])) {
        kept[t] = 1;
        for (uint32_t v : mesh.triangles[t]) std::atomic_ref<uint8_t>(used[v]).store(1, std::memory_order_relaxed);
      }
  });
  return detail::compact_mesh(mesh, kept, used);
}

/// Keeps the vertices v with keep(v) and the triangles whose corners they are, where every
/// triangle's corners are all kept or all dropped (whole connected components, say) and every
/// vertex has a triangle: keep_triangles(mesh, keep(t[0])) without the scatter of each kept
/// triangle's corners (0.07 of the 0.15 s the void removal's drop took on splash 1M; the stage
/// 0.35 -> 0.32 s).
template <class Keep>
std::size_t keep_vertices(TriangleMesh& mesh, Keep&& keep) {
  const std::size_t nt = mesh.triangles.size(), nv = mesh.vertices.size();
  std::vector<uint8_t> kept, used;
  resize_populated(used, nv);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, 4096), [&](const auto& r) {
    for (std::size_t v = r.begin(); v != r.end(); ++v) used[v] = keep(uint32_t(v)) ? 1 : 0;
  });
  resize_populated(kept, nt);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nt, 4096), [&](const auto& r) {
    for (std::size_t t = r.begin(); t != r.end(); ++t) kept[t] = used[mesh.triangles[t][0]];
  });
  return detail::compact_mesh(mesh, kept, used);
}

}  // namespace meniscus
