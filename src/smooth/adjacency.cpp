// meniscus — mesh adjacency (CSR) and greedy graph colouring.
#include "smooth/adjacency.hpp"

#include <tbb/parallel_for.h>
#include <tbb/parallel_scan.h>

#include <algorithm>
#include <atomic>

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
  assign_huge(adj.tri_offsets, nv + 1, 0u);
  parallel_for_index(triangles.size(), 16384, [&](std::size_t f) {
    for (uint32_t v : triangles[f]) std::atomic_ref<uint32_t>(adj.tri_offsets[v + 1]).fetch_add(1, std::memory_order_relaxed);
  });
  for (std::size_t i = 0; i < nv; ++i) adj.tri_offsets[i + 1] += adj.tri_offsets[i];
  resize_huge(adj.tri_ids, adj.tri_offsets[nv]);
  {
    std::vector<uint32_t> fill(adj.tri_offsets.begin(), adj.tri_offsets.end() - 1);
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
  auto write_rows = [&](const std::vector<uint32_t>& offsets) {
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
  std::copy(adj.tri_offsets.begin(), adj.tri_offsets.end(), adj.offsets.begin());
  resize_huge(adj.neighbors, adj.offsets[nv]);
  if (write_rows(adj.offsets)) return adj;

  std::vector<uint32_t> counts(nv + 1, 0);
  for_each_row([&](std::size_t i, const uint32_t*, uint32_t n) { counts[i + 1] = n; });
  adj.offsets[0] = 0;
  for (std::size_t i = 0; i < nv; ++i) adj.offsets[i + 1] = adj.offsets[i] + counts[i + 1];
  std::vector<uint32_t>().swap(adj.neighbors);
  resize_huge(adj.neighbors, adj.offsets[nv]);
  write_rows(adj.offsets);
  return adj;
}

Adjacency renumber_adjacency(const Adjacency& adj, std::span<const uint32_t> order) {
  const std::size_t nv = adj.vertex_count();
  std::vector<uint32_t> rank(nv);
  parallel_for_index(nv, 4096, [&](std::size_t n) { rank[order[n]] = uint32_t(n); });
  // Rows of old vertex order[n], in new order; the neighbour entries relabelled, in place.
  auto permute_rows = [&](const std::vector<uint32_t>& offsets, const std::vector<uint32_t>& entries,
                          std::vector<uint32_t>& new_offsets, std::vector<uint32_t>& new_entries, bool relabel) {
    resize_huge(new_offsets, nv + 1);
    new_offsets[0] = 0;
    for (std::size_t n = 0; n < nv; ++n)
      new_offsets[n + 1] = new_offsets[n] + (offsets[order[n] + 1] - offsets[order[n]]);
    resize_huge(new_entries, entries.size());
    parallel_for_index(nv, 4096, [&](std::size_t n) {
      uint32_t* out = new_entries.data() + new_offsets[n];
      const uint32_t b = offsets[order[n]], e = offsets[order[n] + 1];
      for (uint32_t k = b; k < e; ++k) out[k - b] = relabel ? rank[entries[k]] : entries[k];
    });
  };
  Adjacency out;
  permute_rows(adj.offsets, adj.neighbors, out.offsets, out.neighbors, true);
  if (!adj.tri_offsets.empty()) permute_rows(adj.tri_offsets, adj.tri_ids, out.tri_offsets, out.tri_ids, false);
  return out;
}

Coloring color_vertices(const Adjacency& adj, int distance) { return group_by_color(greedy_colors(adj, distance)); }

std::vector<uint16_t> greedy_colors(const Adjacency& adj, int distance) {
  const std::size_t nv = adj.vertex_count();
  std::vector<uint16_t> color(nv, 0xFFFF);
  std::vector<uint32_t> mark;  // mark[c] == i + 1: colour c is taken for vertex i
  uint16_t ncolors = 0;
  for (uint32_t i = 0; i < nv; ++i) {
    auto take = [&](uint32_t j) {
      const uint16_t c = color[j];
      if (c != 0xFFFF) mark[c] = i + 1;
    };
    mark.resize(std::size_t(ncolors) + 1, 0);
    for (uint32_t j : adj.row(i)) {
      take(j);
      if (distance >= 2)
        for (uint32_t k : adj.row(j))
          if (k != i) take(k);
    }
    uint16_t c = 0;
    while (c < ncolors && mark[c] == i + 1) ++c;
    color[i] = c;
    if (c == ncolors) ++ncolors;
  }
  return color;
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
