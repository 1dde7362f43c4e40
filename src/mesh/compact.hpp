// meniscus — dropping triangles from a mesh, and with them the vertices no triangle uses, in
// parallel and in order (the void and blob removal, the weld's repeated-vertex triangles).
#pragma once

#include <algorithm>
#include <atomic>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "common/for_each.hpp"
#include "common/primitives.hpp"
#include "common/huge_pages.hpp"
#include "meniscus/mesh.hpp"

namespace meniscus {

namespace detail {

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
  for_each_index(chunks, [&](std::size_t c) {
    std::size_t out = c * kOffsetChunk;
    for (std::size_t i = c * kOffsetChunk, end = std::min(flags.size(), i + kOffsetChunk); i < end; ++i)
      if (flags[i]) {
        if (out != i) std::copy(at(i), at(i + 1), at(out));
        ++out;
      }
  });
  for (std::size_t c = 0; c < chunks; ++c) {
    const std::size_t from = c * kOffsetChunk, to = offsets[c], count = offsets[c + 1] - offsets[c];
    if (from != to && count > 0)
      std::copy(at(from), at(from + count), at(to));  // to < from: a forward copy is safe
  }
  values.resize(offsets[chunks] * per);
}

/// Drops the vertices without used[v] (in order; normals and attributes follow) and renumbers the
/// triangles' corners, which must all be used vertices.
inline void compact_vertices(TriangleMesh& mesh, const std::vector<uint8_t>& used) {
  std::vector<std::size_t> offsets;
  if (chunk_offsets(used, offsets) == mesh.vertices.size()) return;
  std::vector<uint32_t> remap;
  assign_populated(remap, mesh.vertices.size(), ~0u);
  for_each_set(used, offsets, [&](std::size_t v, std::size_t k) { remap[v] = uint32_t(k); });
  compact_in_place(mesh.vertices, 1, used, offsets);
  compact_in_place(mesh.normals, 1, used, offsets);
  for (Attribute& a : mesh.attributes) compact_in_place(a.values, std::size_t(a.components), used, offsets);
  for_each_chunk(mesh.triangles.size(), 4096, [&](std::size_t begin, std::size_t end) {
    for (std::size_t t = begin; t != end; ++t)
      for (uint32_t& v : mesh.triangles[t]) v = remap[v];
  });
}

/// Compacts the mesh to the triangles with kept[t] and the vertices with used[v] (which must be
/// every vertex a kept triangle uses), in order; returns the number of triangles dropped.
inline std::size_t compact_mesh(TriangleMesh& mesh, std::vector<uint8_t>& kept, const std::vector<uint8_t>& used) {
  const std::size_t nt = mesh.triangles.size();
  std::vector<std::size_t> offsets;
  const std::size_t new_nt = chunk_offsets(kept, offsets);
  if (new_nt == nt) return 0;
  compact_in_place(mesh.triangles, 1, kept, offsets);
  std::vector<uint8_t>().swap(kept);
  compact_vertices(mesh, used);
  return nt - new_nt;
}

/// Removes from `values` (groups of `per` values) the groups whose indices `gone` lists (sorted,
/// distinct, in range; few against the array), keeping the order, calls map(group) on each kept
/// group at its new place, and shrinks the array. In place and in parallel, in one pass that
/// touches each kept group once: chunks of at least twice the drops each move their groups down
/// by the drops before them, so the next chunk overwrites at most the last `gone.size()` groups of
/// a chunk, which that chunk copies aside first (compact_in_place instead packs each chunk and
/// then slides the packed chunks down one after the other, on one thread).
template <class T, class Map>
void remove_sorted(std::vector<T>& values, std::size_t per, std::span<const uint32_t> gone, Map&& map) {
  const std::size_t n = values.size() / per, d = gone.size();
  if (d == 0 || n == 0) return;
  const std::size_t chunks = std::clamp<std::size_t>(n / std::max<std::size_t>(2 * d, 4096), 1, 64);
  const std::size_t size = (n + chunks - 1) / chunks;
  const auto first = [&](std::size_t c) { return std::min(n, c * size); };
  // before[c]: drops ahead of chunk c; chunk c + 1 overwrites chunk c's last before[c + 1] groups
  // (≤ d ≤ size / 2 where there is a next chunk), kept in `tails` from tail[c].
  std::vector<std::size_t> before(chunks + 1), tail(chunks + 1, 0);
  for (std::size_t c = 0; c <= chunks; ++c)
    before[c] = std::size_t(std::lower_bound(gone.begin(), gone.end(), first(c)) - gone.begin());
  for (std::size_t c = 0; c < chunks; ++c) tail[c + 1] = tail[c] + (c + 1 < chunks ? before[c + 1] : 0);
  std::vector<T> tails(tail[chunks] * per);
  const auto group = [&](std::size_t i) { return values.begin() + std::ptrdiff_t(i * per); };
  for_each_index(chunks, [&](std::size_t c) {
    const std::size_t count = tail[c + 1] - tail[c];
    std::copy(group(first(c + 1) - count), group(first(c + 1)), tails.begin() + std::ptrdiff_t(tail[c] * per));
  });
  for_each_index(chunks, [&](std::size_t c) {
    const std::size_t end = first(c + 1), tail_begin = end - (tail[c + 1] - tail[c]);
    // The groups from `from` on, up to `to`, land from `out` on (from the copies for the tail).
    // In pieces of kPiece groups, each mapped while it is still in the cache from its copy (a
    // run between two drops can hold millions of groups: copied whole, then mapped, it was read
    // from memory twice).
    const auto move = [&](std::size_t from, std::size_t to, std::size_t out) {
      constexpr std::size_t kPiece = 1024;
      for (std::size_t a = from; a < to; a += kPiece) {
        const std::size_t b = std::min(to, a + kPiece), o = out + (a - from);
        const std::size_t split = std::clamp(tail_begin, a, b);
        if (o != a) std::copy(group(a), group(split), group(o));  // o < a: forward is safe
        if (b > split)
          std::copy(tails.begin() + std::ptrdiff_t((tail[c] + split - tail_begin) * per),
                    tails.begin() + std::ptrdiff_t((tail[c] + b - tail_begin) * per), group(o + split - a));
        for (std::size_t i = o; i < o + (b - a); ++i) map(&*group(i));
      }
    };
    // Between two drops the groups move together, by the drops before them.
    std::size_t from = first(c), out = first(c) - before[c];
    for (std::size_t next = before[c]; from < end; ++next) {
      const std::size_t to = next < d ? std::min<std::size_t>(gone[next], end) : end;
      move(from, to, out);
      out += to - from;
      from = to + 1;  // past the drop (or the chunk)
    }
  });
  values.resize((n - d) * per);
}

/// A vertex's index once the sorted vertices `gone` are removed: v − (drops below v), from a count
/// per 64 vertices and, in the few words with a drop, one bit per vertex (12 bytes per 64
/// vertices, against 4 bytes a vertex for a remap array).
class RenumberAfterDrops {
 public:
  RenumberAfterDrops(std::size_t n, std::span<const uint32_t> gone) : bits_(n / 64 + 1, 0), below_(n / 64 + 2, 0) {
    for (const uint32_t v : gone) bits_[v / 64] |= uint64_t(1) << (v % 64);
    for (std::size_t w = 0; w < bits_.size(); ++w) below_[w + 1] = below_[w] + uint32_t(std::popcount(bits_[w]));
  }
  uint32_t operator()(uint32_t v) const {
    const std::size_t w = v / 64;
    const uint32_t below = below_[w];
    if (below_[w + 1] == below) return v - below;  // no drop in v's word: the usual case
    return v - below - uint32_t(std::popcount(bits_[w] & ((uint64_t(1) << (v % 64)) - 1)));
  }

 private:
  std::vector<uint64_t> bits_;
  std::vector<uint32_t> below_;
};

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
  for_each_chunk(nt, 4096, [&](std::size_t begin, std::size_t end) {
    for (std::size_t t = begin; t != end; ++t)
      if (keep(mesh.triangles[t])) {
        kept[t] = 1;
        for (uint32_t v : mesh.triangles[t]) std::atomic_ref<uint8_t>(used[v]).store(1, std::memory_order_relaxed);
      }
  });
  return detail::compact_mesh(mesh, kept, used);
}

/// Drops the vertices no triangle uses (in order; normals and attributes follow) and renumbers
/// the triangles' corners: after a stage that replaced the triangles (clip, decimate).
inline void drop_unused_vertices(TriangleMesh& mesh) {
  std::vector<uint8_t> used(mesh.vertices.size(), 0);
  for (const Triangle& t : mesh.triangles)
    for (uint32_t v : t) used[v] = 1;
  detail::compact_vertices(mesh, used);
}

/// Removes the triangles `triangles` and the vertices `vertices` (both sorted, distinct, in range)
/// where those vertices are exactly the ones no other triangle uses — whole connected components,
/// say — and renumbers the kept triangles' corners; order, normals and attributes as in
/// keep_triangles. For a few drops among many (a splash frame's voids: thousands of its 26 M
/// triangles), where this reads and writes each kept element once, without keep_triangles' flags,
/// prefix scans and remap array. Returns the number of triangles dropped.
inline std::size_t drop_sorted(TriangleMesh& mesh, std::span<const uint32_t> triangles,
                               std::span<const uint32_t> vertices) {
  const auto check = [](std::span<const uint32_t> list, std::size_t n, const char* what) {
    for (std::size_t i = 0; i < list.size(); ++i)
      if (list[i] >= n || (i > 0 && list[i] <= list[i - 1]))
        throw std::logic_error(std::string("drop_sorted: the ") + what + " to drop are not sorted, distinct and in range");
  };
  check(triangles, mesh.triangles.size(), "triangles");
  check(vertices, mesh.vertices.size(), "vertices");
  const auto nothing = [](auto*) {};
  if (!vertices.empty()) {
    const detail::RenumberAfterDrops renumber(mesh.vertices.size(), vertices);
    detail::remove_sorted(mesh.triangles, 1, triangles, [&](Triangle* t) {
      for (uint32_t& v : *t) v = renumber(v);
    });
  } else {
    detail::remove_sorted(mesh.triangles, 1, triangles, nothing);
  }
  detail::remove_sorted(mesh.vertices, 1, vertices, nothing);
  if (!mesh.normals.empty()) detail::remove_sorted(mesh.normals, 1, vertices, nothing);
  for (Attribute& a : mesh.attributes)
    if (!a.values.empty()) detail::remove_sorted(a.values, std::size_t(a.components), vertices, nothing);
  return triangles.size();
}

}  // namespace meniscus
