// meniscus — block-parallel two-pass marching (Williams 2008; Edespong 2010 §4.3).
#include "extract/block_marching.hpp"
#include "common/for_each.hpp"
#include "common/huge_pages.hpp"
#include "common/primitives.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstring>
#include <memory>
#include <span>
#include <stdexcept>
#include <vector>

#include "meniscus/errors.hpp"

namespace meniscus {

namespace {

/// Every cell a block's kernels read or key an edge from lies within 2 cells of the block (one
/// cell of halo, and an edge's far end one more cell away), and the ghost blocks next to an
/// allocated block are marched too: so an allocated block, widened by one block and 2 cells on
/// each side, must fit the edge key.
void check_key_range(const SparseField& field, Vec3i block) {
  const int n = field.lattice().block_cells();
  for (int a = 0; a < 3; ++a) {
    const int64_t first = int64_t(block[a]) * n, last = first + n - 1;
    if (first - n - 2 < -kEdgeKeyMaxCoord || last + n + 2 > kEdgeKeyMaxCoord)
      throw ResourceError(fmt::format(
          "extract_surface: field block ({}, {}, {}) covers cells {}..{} on axis {}, too close to or outside the "
          "limit of the extractor's 64-bit edge keys (|cell| <= {}, less one block and 2 cells of margin); "
          "the surface spans too many cells: use a larger voxel size or move the particles closer to the origin",
          block.x, block.y, block.z, first, last, "xyz"[a], kEdgeKeyMaxCoord));
  }
}

/// Merges one block's corners on the same edge, through a table indexed by the edge's code
/// (BlockEdgeCodes: base cell relative to the block, and type; 64 KB, cache-resident, no sort, no
/// hash): the weld then sorts only the blocks' distinct edges — about a fifth of the corners — and
/// never reads a corner's key.
class BlockWeld {
 public:
  BlockWeld() = default;
  explicit BlockWeld(BlockEdgeCodes codes) : entry_(codes.count(), kUnused) {
    if (codes.count() > (std::size_t(1) << 16)) throw std::logic_error("march_blocks: block edge codes exceed 16 bits");
  }

  /// Writes the distinct codes of `codes` to `edges` in first-use order and each code's index
  /// among them to `corner_edges`; returns how many there are.
  uint32_t weld(std::span<const uint16_t> codes, uint16_t* edges, uint16_t* corner_edges) {
    if (codes.size() >= kUnused) throw std::logic_error("march_blocks: a block has too many corners for 16-bit indices");
    const std::size_t code_count = entry_.size();
    uint16_t count = 0;
    for (std::size_t c = 0; c < codes.size(); ++c) {
      const uint16_t code = codes[c];
      // The kernels' edges lie within 2 cells of their block (block_marching.hpp's static checks):
      // a code past the table is a broken kernel, not bad input.
      if (code >= code_count) throw std::logic_error("march_blocks: an edge lies more than 2 cells outside its block");
      uint16_t e = entry_[code];
      if (e == kUnused) {
        e = count++;
        entry_[code] = e;
        edges[e] = code;
      }
      corner_edges[c] = e;
    }
    for (uint16_t e = 0; e < count; ++e) entry_[edges[e]] = kUnused;  // the edges are the touched slots
    return count;
  }

 private:
  static constexpr uint16_t kUnused = 0xFFFF;
  std::vector<uint16_t> entry_;  // per code: the edge's index in the block, kUnused when unused
};

}  // namespace

CrossingTable::CrossingTable(const LatticeEdge* types, uint64_t used, int padded) {
  for (int t = 0; t < 64; ++t) {
    if (!(used >> t & 1)) continue;
    const LatticeEdge& e = types[t];
    const int offset = (e.dz * padded + e.dy) * padded + e.dx;
    int k = 0;
    while (k < count_ && offset_[k] != offset) ++k;
    if (k == count_) {
      if (count_ == kMaxOffsets) throw std::logic_error("CrossingTable: more far-cell offsets than a canonical edge has");
      offset_[count_++] = offset;
    }
    for (int m = 0; m < 256; ++m) {
      if (m >> e.s0 & 1) near_[m] |= uint64_t(1) << t;
      if (m >> e.s1 & 1) far_[k][m] |= uint64_t(1) << t;
    }
  }
}

std::vector<uint8_t> cell_inside_masks(const SparseField& field, float iso) {
  const int spc = field.lattice().samples_per_cell();
  const std::size_t cells = std::size_t(kBlockSamples / spc);
  std::vector<uint8_t> masks;
  resize_populated(masks, field.block_count() * cells);
  for_each_chunk(field.block_count(), 1, [&](std::size_t begin, std::size_t end) {
    for (std::size_t b = begin; b != end; ++b) {
      // SparseField::local_index is cell-major with a cell's samples adjacent,
      // so cell c's samples are v[c·spc, (c+1)·spc).
      const float* v = field.block_values(b).data();
      uint8_t* m = masks.data() + b * cells;
      // The next blocks' values, ahead of the loads (common/prefetch.hpp).
      if (b + 1 < end)
        for (std::size_t line = 0; line < kBlockSamples * sizeof(float); line += 64)
          __builtin_prefetch(reinterpret_cast<const char*>(v + kBlockSamples) + line);
      for (std::size_t c = 0; c < cells; ++c, v += spc) {
        unsigned bits = 0;
        for (int s = 0; s < spc; ++s) bits |= unsigned(v[s] < iso) << s;
        m[c] = uint8_t(bits);
      }
    }
  });
  return masks;
}

std::vector<Vec3i> blocks_to_march(const SparseField& field, std::span<const uint8_t> cell_masks, bool full_stencil) {
  const std::size_t count = field.block_count();
  for (std::size_t b = 0; b < count; ++b) check_key_range(field, field.block_coords(b));
  const std::size_t cells = count == 0 ? 0 : cell_masks.size() / count;

  // A cell of block G reads cells up to one away; it reaches into allocated block B when G is
  // B's neighbour on the side the stencil looks from: any side for the A15 tile, the lower side
  // for cubes (which read their cell and the +1 neighbours).
  std::vector<Vec3i> ghost_offsets;
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        if (dx == 0 && dy == 0 && dz == 0) continue;
        if (!full_stencil && (dx > 0 || dy > 0 || dz > 0)) continue;
        ghost_offsets.push_back({dx, dy, dz});
      }

  PerThread<std::vector<uint64_t>> ghosts;
  for_each_chunk(count, 1, [&](std::size_t begin, std::size_t end) {
    std::vector<uint64_t>& local = ghosts.local();
    for (std::size_t b = begin; b != end; ++b) {
      const auto first = cell_masks.begin() + std::ptrdiff_t(b * cells);
      // Ghosts matter only next to inside samples: unallocated space is all outside.
      if (std::all_of(first, first + std::ptrdiff_t(cells), [](uint8_t m) { return m == 0; })) continue;
      const Vec3i c = field.block_coords(b);
      for (const Vec3i d : ghost_offsets) {
        const Vec3i g = c + d;
        if (field.find_block(g) == kNotFound) local.push_back(pack_coords(g.x, g.y, g.z));
      }
    }
  });

  std::vector<uint64_t> keys(field.block_keys().begin(), field.block_keys().end());
  for (const std::vector<uint64_t>& local : ghosts) keys.insert(keys.end(), local.begin(), local.end());
  std::sort(keys.begin(), keys.end());  // deterministic order, whatever the threads did
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());

  std::vector<Vec3i> blocks(keys.size());
  for (std::size_t i = 0; i < keys.size(); ++i) blocks[i] = unpack_coords(keys[i]);
  return blocks;
}

bool gather_inside_masks(const SparseField& field, std::span<const uint8_t> cell_masks, Vec3i block,
                         PaddedMasks& masks) {
  const int n = field.lattice().block_cells();
  const int spc = field.lattice().samples_per_cell();
  const std::size_t cells = std::size_t(n) * n * n;
  const uint8_t all_inside = uint8_t((1u << spc) - 1);
  masks.cells = n;
  masks.padded = n + 2;
  masks.origin = {block.x * n, block.y * n, block.z * n};
  std::fill_n(masks.mask.begin(), masks.padded * masks.padded * masks.padded, uint8_t(0));

  bool any_inside = false, any_outside = false;
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const uint32_t index = field.find_block(block + Vec3i{dx, dy, dz});
        if (index == kNotFound) {
          any_outside = true;  // its halo cells stay 0: background is outside
          continue;
        }
        const uint8_t* source = cell_masks.data() + std::size_t(index) * cells;
        // The neighbour's cells that fall in the halo: its last layer (d = −1), all (d = 0) or its
        // first layer (d = +1); they land at local coordinate source + d·n. Rows along x are
        // contiguous on both sides.
        auto lo = [n](int d) { return d < 0 ? n - 1 : 0; };
        auto hi = [n](int d) { return d > 0 ? 0 : n - 1; };
        const int x0 = lo(dx), width = hi(dx) - x0 + 1;
        for (int z = lo(dz); z <= hi(dz); ++z)
          for (int y = lo(dy); y <= hi(dy); ++y) {
            const uint8_t* row = source + (z * n + y) * n + x0;
            uint8_t* target = masks.at(x0 + dx * n, y + dy * n, z + dz * n);
            for (int x = 0; x < width; ++x) {
              target[x] = row[x];
              any_inside |= row[x] != 0;
              any_outside |= row[x] != all_inside;
            }
          }
      }
  return any_inside && any_outside;
}

MarchedCorners march_blocks(const SparseField& field, float iso, bool full_stencil, BlockKernel kernel,
                            uint32_t max_triangles_per_cell, uint64_t used_types) {
  const std::vector<uint8_t> cell_masks = cell_inside_masks(field, iso);
  const std::vector<Vec3i> blocks = blocks_to_march(field, cell_masks, full_stencil);
  MarchedCorners out;
  out.block_cells = field.lattice().block_cells();
  out.codes = BlockEdgeCodes::of(field.lattice());
  const bool a15 = field.lattice().kind == SampleLattice::Kind::a15;
  out.edge_types = a15 ? kA15EdgeTable.types : kKuhnEdgeTable.types;
  out.used_types = used_types;
  out.crossing_bytes = a15 ? 8 : 1;
  const int n = out.block_cells;
  const CrossingTable crossing(out.edge_types, used_types, n + 2);
  const std::size_t crossing_block = std::size_t(n) * std::size_t(n) * std::size_t(n) * std::size_t(out.crossing_bytes);
  constexpr std::size_t kCrossingPage = std::size_t(1) << 20;
  out.origins.resize(blocks.size());
  for (std::size_t b = 0; b < blocks.size(); ++b) out.origins[b] = {blocks[b].x * n, blocks[b].y * n, blocks[b].z * n};

  // One pass: each thread marches a block into its scratch, welds the block's corners there (see
  // BlockWeld) and appends the block's distinct edges and corner indices to its own pages, each
  // block contiguous within a page (a page is started when the worst case of a block no longer
  // fits). The block order — the mesh's triangle order — comes from the offsets, not from where
  // the records landed, so the result does not depend on the threads.
  const std::size_t block_max = 3 * std::size_t(max_triangles_per_cell) * std::size_t(n) * std::size_t(n) * std::size_t(n);
  const std::size_t page_size = std::max<std::size_t>(std::size_t(1) << 20, 8 * block_max);
  struct Writer {
    std::vector<std::unique_ptr<uint16_t[]>> edge_pages;
    std::vector<std::unique_ptr<uint16_t[]>> corner_pages;
    std::vector<std::unique_ptr<uint8_t[]>> crossing_pages;
    std::size_t edges_used = 0, corners_used = 0, crossings_used = 0;
    std::vector<uint16_t> codes;  // the block's corner codes as its kernel wrote them
    BlockWeld weld;
  };
  PerThread<Writer> writers([&] {
    Writer w;
    w.codes.resize(block_max);
    w.weld = BlockWeld(out.codes);
    return w;
  });
  out.block_edges.assign(blocks.size(), nullptr);
  out.block_corners.assign(blocks.size(), nullptr);
  out.block_crossings.assign(blocks.size(), nullptr);
  std::vector<uint64_t> triangle_offsets(blocks.size() + 1, 0), edge_offsets(blocks.size() + 1, 0);
  for_each_chunk(blocks.size(), 1, [&](std::size_t begin, std::size_t end) {
    PaddedMasks masks;  // one per task, on the stack: no allocation in the loop
    Writer& w = writers.local();
    for (std::size_t b = begin; b != end; ++b) {
      if (!gather_inside_masks(field, cell_masks, blocks[b], masks)) continue;
      // The crossing edges of the block's own cells (their far ends lie in the halo), written to
      // the page as they come and kept only if one crosses: a block without triangles may still
      // own edges its neighbours' tetrahedra cross.
      if (w.crossing_pages.empty() || w.crossings_used + crossing_block > kCrossingPage) {
        w.crossing_pages.push_back(std::make_unique_for_overwrite<uint8_t[]>(kCrossingPage));
        w.crossings_used = 0;
      }
      uint8_t* cross = w.crossing_pages.back().get() + w.crossings_used;
      uint64_t any = 0;
      for (int z = 0, cell = 0; z < n; ++z)
        for (int y = 0; y < n; ++y)
          for (int x = 0; x < n; ++x, ++cell) {
            const uint64_t bits = crossing(masks.at(x, y, z));
            any |= bits;
            if (a15)
              std::memcpy(cross + 8 * cell, &bits, 8);
            else
              cross[cell] = uint8_t(bits);
          }
      if (any != 0) {
        out.block_crossings[b] = cross;
        w.crossings_used += crossing_block;
      }
      const uint32_t triangles = kernel(masks, w.codes.data());
      if (triangles > max_triangles_per_cell * uint32_t(n * n * n))
        throw std::logic_error("march_blocks: a block wrote more triangles than its cells can have");
      if (triangles == 0) continue;
      const std::size_t corners = 3 * std::size_t(triangles);
      // A block has at most as many distinct edges as corners.
      if (w.edge_pages.empty() || w.edges_used + corners > page_size) {
        w.edge_pages.push_back(std::make_unique_for_overwrite<uint16_t[]>(page_size));
        w.edges_used = 0;
      }
      if (w.corner_pages.empty() || w.corners_used + corners > page_size) {
        w.corner_pages.push_back(std::make_unique_for_overwrite<uint16_t[]>(page_size));
        w.corners_used = 0;
      }
      uint16_t* edges = w.edge_pages.back().get() + w.edges_used;
      uint16_t* corner_edges = w.corner_pages.back().get() + w.corners_used;
      const uint32_t count = w.weld.weld(std::span(w.codes.data(), corners), edges, corner_edges);
      out.block_edges[b] = edges;
      out.block_corners[b] = corner_edges;
      triangle_offsets[b + 1] = triangles;
      edge_offsets[b + 1] = count;
      w.edges_used += count;
      w.corners_used += corners;
    }
  });
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    triangle_offsets[b + 1] += triangle_offsets[b];
    edge_offsets[b + 1] += edge_offsets[b];
  }
  out.triangle_offsets = std::move(triangle_offsets);
  out.edge_offsets = std::move(edge_offsets);
  for (Writer& w : writers) {
    for (auto& page : w.edge_pages) out.edge_pages.push_back(std::move(page));
    for (auto& page : w.corner_pages) out.corner_pages.push_back(std::move(page));
    for (auto& page : w.crossing_pages) out.crossing_pages.push_back(std::move(page));
  }
  return out;
}

std::vector<uint64_t> MarchedCorners::flatten() const {
  std::vector<uint64_t> keys(corner_count());
  for_each_index(block_edges.size(), [&](std::size_t b) {
    const std::span<const uint16_t> e = edges(b);
    uint64_t* out = keys.data() + 3 * triangle_offsets[b];
    for (const uint16_t c : corners(b)) *out++ = edge_key(b, e[c]);
  });
  return keys;
}

}  // namespace meniscus
