// meniscus — mesh adjacency (CSR) and greedy graph colouring.
#include "smooth/adjacency.hpp"

#include <tbb/parallel_for.h>
#include <tbb/parallel_scan.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <numeric>

#include "common/huge_pages.hpp"
#include "common/parallel_index.hpp"

namespace meniscus {

Adjacency build_adjacency(std::size_t vertex_count, std::span<const Triangle> triangles) {
  Adjacency adj;
  const std::size_t nv = vertex_count;
  // Read at random (the rows by every sweep, the triangle lists by the operator's build): on huge
  // pages (huge_pages.hpp).
  // The triangle lists: counted and filled in parallel through atomic cursors, then each list
  // sorted — ascending, as a serial fill in triangle order would leave it.
  resize_huge(adj.tri_offsets, nv + 1);
  parallel_for_index(nv + 1, 65536, [&](std::size_t i) { adj.tri_offsets[i] = 0; });
  parallel_for_index(triangles.size(), 16384, [&](std::size_t f) {
    for (uint32_t v : triangles[f]) std::atomic_ref<uint32_t>(adj.tri_offsets[v + 1]).fetch_add(1, std::memory_order_relaxed);
  });
  for (std::size_t i = 0; i < nv; ++i) adj.tri_offsets[i + 1] += adj.tri_offsets[i];
  resize_huge(adj.tri_ids, adj.tri_offsets[nv]);
  {
    UninitVector<uint32_t> fill;
    resize_huge(fill, nv);
    parallel_for_index(nv, 65536, [&](std::size_t i) { fill[i] = adj.tri_offsets[i]; });
    parallel_for_index(triangles.size(), 16384, [&](std::size_t f) {
      for (uint32_t v : triangles[f])
        adj.tri_ids[std::atomic_ref<uint32_t>(fill[v]).fetch_add(1, std::memory_order_relaxed)] = uint32_t(f);
    });
  }
  parallel_for_index(nv, 4096, [&](std::size_t i) {
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
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, 2048), [&](const auto& r) {
      std::vector<uint32_t> scratch;
      for (std::size_t i = r.begin(); i != r.end(); ++i) {
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
  parallel_for_index(nv + 1, 65536, [&](std::size_t i) { adj.offsets[i] = adj.tri_offsets[i]; });
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
void fill_corner_lists(Adjacency& adj, const Neighbors& neighbors, std::span<const Triangle> triangles,
                       std::span<const uint32_t> rank) {
  const std::size_t nv = adj.vertex_count();
  auto list_of = [&](std::size_t i) { return adj.tri_row.empty() ? i : std::size_t(adj.tri_row[i]); };
  resize_huge(adj.corner_offsets, nv + 1);
  adj.corner_offsets[0] = 0;
  parallel_for_index(nv, 65536, [&](std::size_t i) {
    const std::size_t r = list_of(i);
    adj.corner_offsets[i + 1] = adj.tri_offsets[r + 1] - adj.tri_offsets[r];
  });
  std::inclusive_scan(adj.corner_offsets.begin(), adj.corner_offsets.end(), adj.corner_offsets.begin());
  resize_huge(adj.corners, adj.corner_offsets[nv]);
  parallel_for_index(nv, 4096, [&](std::size_t i) {
    const uint32_t r = uint32_t(list_of(i)), i32 = uint32_t(i);  // r: vertex i in the triangles' numbering
    const uint32_t row_begin = adj.offsets[i], row_end = adj.offsets[i + 1];
    // The slot of v (triangles' numbering) in row i, as cotan_row finds it; kNoSlot (i itself, in
    // a degenerate triangle) becomes kCornerSelf.
    auto slot_of = [&](uint32_t v) {
      const uint32_t slot = v == r ? kNoSlot : row_slot(neighbors, i32, row_begin, row_end, rank.empty() ? v : rank[v]);
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
  parallel_for_index(adj.vertex_count(), 65536, [&](std::size_t i) {
    if (adj.offsets[i + 1] - adj.offsets[i] > kMaxCornerRow) fits.store(false, std::memory_order_relaxed);
  });
  return fits.load();
}

bool adopt_corner_lists(Adjacency& adj, std::span<const Triangle> triangles, std::span<const uint32_t> rank) {
  if (adj.tri_offsets.empty() || !corner_lists_fit(adj)) return false;
  adj.with_neighbors([&](const auto& neighbors) { fill_corner_lists(adj, neighbors, triangles, rank); });
  UninitVector<uint32_t>().swap(adj.tri_offsets);
  UninitVector<uint32_t>().swap(adj.tri_ids);
  std::vector<uint32_t>().swap(adj.tri_row);
  return true;
}


namespace {

/// The CSR rows of `offsets` in a new order, row n being old row order[n], entry k of old row r
/// given by entry(r, k), into (out_offsets, out_values). The row lengths in parallel (the array's
/// first touch), then their running sum, then the rows.
template <class T, class Entry>
void permute_rows(const UninitVector<uint32_t>& offsets, std::span<const uint32_t> order,
                  UninitVector<uint32_t>& out_offsets, UninitVector<T>& out_values, Entry&& entry) {
  const std::size_t nv = order.size();
  resize_huge(out_offsets, nv + 1);
  out_offsets[0] = 0;
  parallel_for_index(nv, 65536, [&](std::size_t n) { out_offsets[n + 1] = offsets[order[n] + 1] - offsets[order[n]]; });
  std::inclusive_scan(out_offsets.begin(), out_offsets.end(), out_offsets.begin());
  resize_huge(out_values, offsets[nv]);
  parallel_for_index(nv, 4096, [&](std::size_t n) {
    T* row = out_values.data() + out_offsets[n];
    const uint32_t r = order[n], b = offsets[r], e = offsets[r + 1];
    for (uint32_t k = b; k < e; ++k) row[k - b] = entry(r, k);
  });
}

}  // namespace

Adjacency renumber_adjacency(Adjacency&& adj, std::vector<uint32_t> order) {
  const std::size_t nv = adj.vertex_count();
  UninitVector<uint32_t> rank;
  resize_huge(rank, nv);
  parallel_for_index(nv, 4096, [&](std::size_t n) { rank[order[n]] = uint32_t(n); });
  Adjacency out;
  // Rows of old vertex order[n], in new order, their entries relabelled (compact lists read in
  // their old rows, then compacted again in the new numbering, below).
  const bool compact = !adj.compact.empty();
  adj.with_neighbors([&](const auto& neighbors) {
    permute_rows(adj.offsets, order, out.offsets, out.neighbors,
                 [&](uint32_t r, uint32_t k) { return rank[neighbor_at(neighbors, r, k)]; });
  });
  UninitVector<uint32_t>().swap(adj.neighbors);  // room for the corner lists' copy
  adj.compact = {};
  UninitVector<uint32_t>().swap(rank);
  // The slots index a row's entries, which keep their order: the corner lists move with their rows.
  if (!adj.corner_offsets.empty()) {
    permute_rows(adj.corner_offsets, order, out.corner_offsets, out.corners,
                 [&](uint32_t, uint32_t k) { return adj.corners[k]; });
    UninitVector<uint32_t>().swap(adj.corner_offsets);
    UninitVector<CornerSlots>().swap(adj.corners);
  }
  if (compact) out.compact_neighbors();
  if (!adj.tri_offsets.empty()) {
    out.tri_offsets = std::move(adj.tri_offsets);
    out.tri_ids = std::move(adj.tri_ids);
    // Composed with an earlier renumbering's, if any.
    if (!adj.tri_row.empty()) parallel_for_index(nv, 65536, [&](std::size_t n) { order[n] = adj.tri_row[order[n]]; });
    out.tri_row = std::move(order);
  }
  return out;
}

Coloring color_vertices(const Adjacency& adj, int distance) { return group_by_color(greedy_colors(adj, distance)); }

namespace {

/// greedy_colors over the neighbour lists in either form (neighbor_at).
template <class Neighbors>
std::vector<uint16_t> greedy_colors_of(const Adjacency& adj, const Neighbors& neighbors, int distance) {
  const std::size_t nv = adj.vertex_count();
  const uint32_t* offsets = adj.offsets.data();
  std::vector<uint16_t> color(nv);
  // Vertex i takes the smallest colour of no vertex within `distance` coloured before it (the
  // lower-numbered ones). The first 64 colours are tracked in a register bit set (a distance-2
  // ring has some forty entries; a marks array and a branch per entry took half as long again on
  // splash 1M); only a vertex that finds all 64 taken counts again over every colour.
  std::vector<uint32_t> mark;  // the slow path: mark[c] == i + 1 when colour c is taken for i
  for (uint32_t i = 0; i < nv; ++i) {
    // Calls f(k) for every vertex k within `distance` of i (some more than once, i itself too).
    auto for_each_in_reach = [&](auto&& f) {
      for (uint32_t e = offsets[i]; e < offsets[i + 1]; ++e) {
        const uint32_t j = neighbor_at(neighbors, i, e);
        f(j);
        if (distance >= 2)
          for (uint32_t g = offsets[j]; g < offsets[j + 1]; ++g) f(neighbor_at(neighbors, j, g));
      }
    };
    // Branch-free: whether k < i is a coin toss to the branch predictor (color is zero-initialised,
    // so the read is defined for every k).
    uint64_t taken = 0;
    for_each_in_reach([&](uint32_t k) {
      const uint32_t c = color[k];
      taken |= (uint64_t(k < i) & uint64_t(c < 64)) << (c & 63);
    });
    if (taken != ~uint64_t(0)) {
      color[i] = uint16_t(std::countr_one(taken));
      continue;
    }
    for_each_in_reach([&](uint32_t k) {
      if (k < i) {
        if (mark.size() <= color[k]) mark.resize(std::size_t(color[k]) + 1, 0);
        mark[color[k]] = i + 1;
      }
    });
    uint16_t c = 64;
    while (c < mark.size() && mark[c] == i + 1) ++c;
    color[i] = c;
  }
  return color;
}

}  // namespace

std::vector<uint16_t> greedy_colors(const Adjacency& adj, int distance) {
  return adj.with_neighbors([&](const auto& neighbors) { return greedy_colors_of(adj, neighbors, distance); });
}

Coloring group_by_color(std::span<const uint16_t> color) {
  const std::size_t nv = color.size();
  const std::size_t ncolors = nv == 0 ? 0 : std::size_t(*std::max_element(color.begin(), color.end())) + 1;
  Coloring out;
  out.offsets.assign(std::size_t(ncolors) + 1, 0);
  for (uint16_t c : color) ++out.offsets[std::size_t(c) + 1];
  for (std::size_t c = 0; c < ncolors; ++c) out.offsets[c + 1] += out.offsets[c];
  resize_huge(out.vertices, nv);
  std::vector<uint32_t> fill(out.offsets.begin(), out.offsets.end() - 1);
  for (uint32_t i = 0; i < nv; ++i) out.vertices[fill[color[i]]++] = i;
  return out;
}

}  // namespace meniscus
