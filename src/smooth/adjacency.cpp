// meniscus — mesh adjacency (CSR rows of neighbours and of incident triangles).
#include "smooth/adjacency.hpp"

#include <algorithm>
#include <atomic>
#include <bit>
#include <numeric>

#include "common/huge_pages.hpp"
#include "common/for_each.hpp"

namespace meniscus {

Adjacency build_adjacency(std::size_t vertex_count, std::span<const Triangle> triangles) {
  Adjacency adj;
  const std::size_t nv = vertex_count;
  // Read at random (the rows by every sweep, the triangle lists by the operator's build): on huge
  // pages (huge_pages.hpp).
  // The triangle lists: counted and filled in parallel through atomic cursors, then each list
  // sorted — ascending, as a serial fill in triangle order would leave it.
  resize_huge(adj.tri_offsets, nv + 1);
  for_each_index(nv + 1, 65536, [&](std::size_t i) { adj.tri_offsets[i] = 0; });
  for_each_index(triangles.size(), 16384, [&](std::size_t f) {
    for (uint32_t v : triangles[f])
      std::atomic_ref<uint32_t>(adj.tri_offsets[v + 1]).fetch_add(1, std::memory_order_relaxed);
  });
  for (std::size_t i = 0; i < nv; ++i) adj.tri_offsets[i + 1] += adj.tri_offsets[i];
  resize_huge(adj.tri_ids, adj.tri_offsets[nv]);
  {
    UninitVector<uint32_t> fill;
    resize_huge(fill, nv);
    for_each_index(nv, 65536, [&](std::size_t i) { fill[i] = adj.tri_offsets[i]; });
    for_each_index(triangles.size(), 16384, [&](std::size_t f) {
      for (uint32_t v : triangles[f])
        adj.tri_ids[std::atomic_ref<uint32_t>(fill[v]).fetch_add(1, std::memory_order_relaxed)] = uint32_t(f);
    });
  }
  for_each_index(nv, 4096, [&](std::size_t i) {
    std::sort(adj.tri_ids.begin() + adj.tri_offsets[i], adj.tri_ids.begin() + adj.tri_offsets[i + 1]);
  });

  // Each vertex's neighbours come from its incident triangles: collect, sort, unique. A vertex
  // whose triangles close a fan (every vertex of a closed manifold mesh, such as the extraction's)
  // has as many neighbours as triangles, so the rows are first laid out on the triangle lists'
  // offsets and written in one pass; only if some vertex has another count (an open or pinched
  // fan) are they counted first and written again.
  auto gather = [&](uint32_t i, uint32_t* out) {
    uint32_t n = 0;
    for (uint32_t k = adj.tri_offsets[i]; k < adj.tri_offsets[i + 1]; ++k) {
      const Triangle& t = triangles[adj.tri_ids[k]];
      for (uint32_t v : t)
        if (v != i) out[n++] = v;
    }
    std::sort(out, out + n);
    return uint32_t(std::unique(out, out + n) - out);
  };
  // Calls row(i, entries, n) with each vertex's gathered row, in parallel.
  auto for_each_row = [&](auto&& row) {
    for_each_chunk(nv, 2048, [&](std::size_t begin, std::size_t end) {
      std::vector<uint32_t> scratch;
      for (std::size_t i = begin; i != end; ++i) {
        scratch.resize(2 * (adj.tri_offsets[i + 1] - adj.tri_offsets[i]));
        row(i, scratch.data(), gather(uint32_t(i), scratch.data()));
      }
    });
  };
  // Writes the rows at `offsets`; false if a row's length is not what they say.
  auto write_rows = [&](const UninitVector<uint32_t>& offsets) {
    std::atomic<bool> fits{true};
    for_each_row([&](std::size_t i, const uint32_t* row, uint32_t n) {
      if (n == offsets[i + 1] - offsets[i])
        std::copy(row, row + n, adj.neighbors.begin() + offsets[i]);
      else
        fits.store(false, std::memory_order_relaxed);
    });
    return fits.load();
  };
  resize_huge(adj.offsets, nv + 1);
  for_each_index(nv + 1, 65536, [&](std::size_t i) { adj.offsets[i] = adj.tri_offsets[i]; });
  resize_huge(adj.neighbors, adj.offsets[nv]);
  if (write_rows(adj.offsets)) return adj;

  std::vector<uint32_t> counts(nv + 1, 0);
  for_each_row([&](std::size_t i, const uint32_t*, uint32_t n) { counts[i + 1] = n; });
  adj.offsets[0] = 0;
  for (std::size_t i = 0; i < nv; ++i) adj.offsets[i + 1] = adj.offsets[i] + counts[i + 1];
  UninitVector<uint32_t>().swap(adj.neighbors);
  resize_huge(adj.neighbors, adj.offsets[nv]);
  write_rows(adj.offsets);
  return adj;
}

namespace {

/// adopt_corner_lists' lists, over the neighbour lists in either form.
template <class Neighbors>
void fill_corner_lists(Adjacency& adj, const Neighbors& neighbors, std::span<const Triangle> triangles) {
  const std::size_t nv = adj.vertex_count();
  resize_huge(adj.corner_offsets, nv + 1);
  adj.corner_offsets[0] = 0;
  for_each_index(nv, 65536,
                 [&](std::size_t i) { adj.corner_offsets[i + 1] = adj.tri_offsets[i + 1] - adj.tri_offsets[i]; });
  std::inclusive_scan(adj.corner_offsets.begin(), adj.corner_offsets.end(), adj.corner_offsets.begin());
  resize_huge(adj.corners, adj.corner_offsets[nv]);
  for_each_index(nv, 4096, [&](std::size_t i) {
    const uint32_t r = uint32_t(i);
    const uint32_t row_begin = adj.offsets[i], row_end = adj.offsets[i + 1];
    // The slot of v in row i, as cotan_row finds it; kNoSlot (i itself, in a degenerate triangle)
    // becomes kCornerSelf.
    auto slot_of = [&](uint32_t v) {
      const uint32_t slot = v == r ? kNoSlot : row_slot(neighbors, r, row_begin, row_end, v);
      return slot == kNoSlot ? kCornerSelf : uint8_t(slot);
    };
    CornerSlots* out = adj.corners.data() + adj.corner_offsets[i];
    for (uint32_t k = adj.tri_offsets[r]; k < adj.tri_offsets[r + 1]; ++k) {
      uint32_t j, l;
      corners_after(triangles[adj.tri_ids[k]].data(), r, &j, &l);
      *out++ = {slot_of(j), slot_of(l)};
    }
  });
}

}  // namespace

bool corner_lists_fit(const Adjacency& adj) {
  std::atomic<bool> fits{true};
  for_each_index(adj.vertex_count(), 65536, [&](std::size_t i) {
    if (adj.offsets[i + 1] - adj.offsets[i] > kMaxCornerRow) fits.store(false, std::memory_order_relaxed);
  });
  return fits.load();
}

bool adopt_corner_lists(Adjacency& adj, std::span<const Triangle> triangles) {
  if (adj.tri_offsets.empty() || !corner_lists_fit(adj)) return false;
  adj.with_neighbors([&](const auto& neighbors) { fill_corner_lists(adj, neighbors, triangles); });
  UninitVector<uint32_t>().swap(adj.tri_offsets);
  UninitVector<uint32_t>().swap(adj.tri_ids);
  return true;
}

}  // namespace meniscus
