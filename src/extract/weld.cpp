// meniscus — edge weld by radix sort + unique on lattice-edge keys (Williams 2008; Edespong 2010 §4.3).
#include "extract/weld.hpp"
#include "common/for_each.hpp"
#include "common/huge_pages.hpp"
#include "common/primitives.hpp"
#include "mesh/compact.hpp"
#include "system/memory_scope.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <climits>
#include <functional>
#include <bit>
#include <stdexcept>
#include <vector>

#include "common/radix_sort.hpp"
#include "extract/tile_table.hpp"
#include "meniscus/errors.hpp"

namespace meniscus {

namespace {

/// Maps edge keys onto dense integers in the same order: ((z·NY + y)·NX + x)·64 + type with the
/// base cell taken relative to the smallest one used. Edge keys spread their 19-bit axis fields
/// over 63 bits (and offset coordinates flip every high bit at 0), so a radix sort would need all
/// its passes; the dense key of a field spanning a few hundred cells needs 3. Always fits 64 bits:
/// each axis spans at most 2^19 cells, (2^19)³ · 64 = 2^63.
struct DenseEdgeKeys {
  Vec3i lo;
  uint64_t nx = 1, ny = 1;
  int bits = 1;  ///< every dense key is < 2^bits

  struct Box {
    Vec3i lo{kEdgeKeyMaxCoord, kEdgeKeyMaxCoord, kEdgeKeyMaxCoord};
    Vec3i hi{-kEdgeKeyMaxCoord, -kEdgeKeyMaxCoord, -kEdgeKeyMaxCoord};
    void add(Vec3i a, Vec3i b) {
      lo = {std::min(lo.x, a.x), std::min(lo.y, a.y), std::min(lo.z, a.z)};
      hi = {std::max(hi.x, b.x), std::max(hi.y, b.y), std::max(hi.z, b.z)};
    }
    void add(std::span<const uint64_t> keys) {
      for (uint64_t k : keys) {
        const Vec3i c = edge_key_cell(k);
        add(c, c);
      }
    }
  };
  /// The box of the base cells of `chunk_count` chunks of keys (chunk(i) → span), in parallel.
  template <class Chunk>
  DenseEdgeKeys(std::size_t chunk_count, Chunk&& chunk) : DenseEdgeKeys(box_of(chunk_count, chunk)) {}
  template <class Chunk>
  static Box box_of(std::size_t chunk_count, Chunk&& chunk) {
    return reduce(
        chunk_count, 1, Box{},
        [&](std::size_t begin, std::size_t end, Box b) {
          for (std::size_t i = begin; i != end; ++i) b.add(chunk(i));
          return b;
        },
        [](Box a, const Box& b) {
          a.add(b.lo, b.hi);
          return a;
        });
  }
  /// Dense keys for base cells in `box` (any box that holds them: the order is the key order).
  explicit DenseEdgeKeys(const Box& box) {
    if (box.lo.x > box.hi.x) return;  // no keys
    lo = box.lo;
    nx = uint64_t(int64_t(box.hi.x) - box.lo.x + 1);
    ny = uint64_t(int64_t(box.hi.y) - box.lo.y + 1);
    const uint64_t nz = uint64_t(int64_t(box.hi.z) - box.lo.z + 1);
    bits = int(std::bit_width(nx * ny * nz * 64 - 1));
  }
  explicit DenseEdgeKeys(std::span<const uint64_t> keys)
      : DenseEdgeKeys((keys.size() + kChunk - 1) / kChunk, [&](std::size_t i) {
          return keys.subspan(i * kChunk, std::min(kChunk, keys.size() - i * kChunk));
        }) {}
  static constexpr std::size_t kChunk = 4096;
  uint64_t dense(uint64_t key) const {
    const Vec3i c = edge_key_cell(key);
    const uint64_t cell = (uint64_t(c.z - lo.z) * ny + uint64_t(c.y - lo.y)) * nx + uint64_t(c.x - lo.x);
    return cell * 64 + uint64_t(edge_key_type(key));
  }
  uint64_t key(uint64_t dense_key) const {
    const uint64_t cell = dense_key / 64;
    const Vec3i c{lo.x + int32_t(cell % nx), lo.y + int32_t(cell / nx % ny), lo.z + int32_t(cell / nx / ny)};
    return edge_key(c, int(dense_key % 64));
  }
};

/// Binary search in two levels: first among every 64th key (an array small enough to stay in
/// cache), then within one run of 64 — two or three cache misses per lookup instead of ~20.
class SortedKeyIndex {
 public:
  explicit SortedKeyIndex(const std::vector<uint64_t>& sorted) : sorted_(sorted) {
    for (std::size_t i = 0; i < sorted.size(); i += kRun) sampled_.push_back(sorted[i]);
  }
  /// Index of `key`, which must be present.
  std::size_t find(uint64_t key) const {
    const std::size_t run = std::size_t(std::upper_bound(sampled_.begin(), sampled_.end(), key) - sampled_.begin()) - 1;
    const auto first = sorted_.begin() + std::ptrdiff_t(run * kRun);
    const auto last = sorted_.begin() + std::ptrdiff_t(std::min(sorted_.size(), (run + 1) * kRun));
    return std::size_t(std::lower_bound(first, last, key) - sorted_.begin());
  }

 private:
  static constexpr std::size_t kRun = 64;
  const std::vector<uint64_t>& sorted_;
  std::vector<uint64_t> sampled_;
};

/// Distinct values of a sorted array, in parallel: count run heads per chunk, prefix-sum, copy.
std::vector<uint64_t> unique_sorted(const std::vector<uint64_t>& sorted) {
  auto is_head = [&](std::size_t i) { return i == 0 || sorted[i] != sorted[i - 1]; };
  std::vector<std::size_t> offsets;
  std::vector<uint64_t> unique(chunk_offsets(sorted.size(), is_head, offsets));
  for_each_set(sorted.size(), is_head, offsets, [&](std::size_t i, std::size_t k) { unique[k] = sorted[i]; });
  return unique;
}

/// The field's samples for compute_vertices, remembering the last two blocks it found: vertices
/// come in key order (z, y, x of the base cell), so consecutive edges read the same one or two
/// blocks, and most of the hash lookups (two a vertex) are saved.
class CachedFieldReader {
 public:
  explicit CachedFieldReader(const SparseField& field) : field_(field) {}
  /// Where the value of sample s of `cell` is.
  const float* address(Vec3i cell, int s) {
    const Vec3i b = field_.block_of(cell);
    uint32_t index;
    if (b == block_[0]) {
      index = index_[0];
    } else if (b == block_[1]) {
      index = index_[1];
    } else {
      index = field_.find_block(b);
      block_[next_] = b;
      index_[next_] = index;
      next_ ^= 1;
    }
    return field_.address_in(index, b, cell, s);
  }

 private:
  const SparseField& field_;
  // Block coordinates no field reaches (|coord| ≤ 2^20 in pack_coords), so the first lookups miss.
  Vec3i block_[2] = {Vec3i{INT32_MIN, 0, 0}, Vec3i{INT32_MIN, 0, 0}};
  uint32_t index_[2] = {kNotFound, kNotFound};
  int next_ = 0;
};

/// The two samples of an edge: where their values are, and their positions.
struct EdgeSamples {
  const float* v0;
  const float* v1;
  Vec3f p0, p1;
};

EdgeSamples edge_samples(uint64_t key, const SampleLattice& lattice, CachedFieldReader& reader) {
  Vec3i c0, c1;
  int s0 = 0, s1 = 0;
  edge_key_samples(key, lattice.kind == SampleLattice::Kind::a15, &c0, &s0, &c1, &s1);
  return {reader.address(c0, s0), reader.address(c1, s1), lattice.sample_position(c0, s0),
          lattice.sample_position(c1, s1)};
}

/// Removes triangles with a repeated vertex (keeping the order) and the vertices nothing uses
/// any more. Never reached by the marching stages (a triangle's corners lie on distinct edges of
/// one cell, hence have distinct keys); kept so the weld's contract holds for any input.
std::size_t drop_repeated(TriangleMesh& mesh) {
  return keep_triangles(mesh, [](const Triangle& t) { return t[0] != t[1] && t[1] != t[2] && t[0] != t[2]; });
}

void check_vertex_count(std::size_t vertices) {
  if (vertices >= kNotFound)
    throw ResourceError(
        fmt::format("extract_surface: {} vertices exceed the 32-bit vertex index of TriangleMesh", vertices));
}

/// Vertex positions, one per distinct dense key: where {φ = iso} crosses the key's edge. The field
/// values are read kAhead vertices after their addresses are found and prefetched: their loads
/// were this loop's main stall, the rows of vertices crossing a block at one row of its samples
/// each.
void compute_vertices(const std::vector<uint64_t>& vertex_keys, const DenseEdgeKeys& dense, const SparseField& field,
                      float iso, TriangleMesh& mesh) {
  resize_huge(mesh.vertices, vertex_keys.size());
  for_each_chunk(vertex_keys.size(), 1, [&](std::size_t begin, std::size_t end) {
    constexpr std::size_t kAhead = 16;
    CachedFieldReader reader(field);
    std::array<EdgeSamples, kAhead> ahead;
    auto locate = [&](std::size_t v) {
      const EdgeSamples e = edge_samples(dense.key(vertex_keys[v]), field.lattice(), reader);
      __builtin_prefetch(e.v0);
      __builtin_prefetch(e.v1);
      ahead[v % kAhead] = e;
    };
    for (std::size_t v = begin; v != std::min(end, begin + kAhead); ++v) locate(v);
    for (std::size_t v = begin; v != end; ++v) {
      const EdgeSamples e = ahead[v % kAhead];
      if (v + kAhead < end) locate(v + kAhead);
      mesh.vertices[v] = edge_vertex(e.p0, e.p1, *e.v0, *e.v1, iso, kEdgeClamp);
    }
  });
}

/// Numbers the runs of equal keys: `packed` holds (dense key << index_bits | index) words; after one
/// radix sort on the key bits equal keys are adjacent, each run becomes a vertex (in key order)
/// and its number is written to target[index] for every word of the run — no search at all.
/// Returns the dense key of each vertex; frees `packed`.
std::vector<uint64_t> number_runs(std::vector<uint64_t>& packed, int index_bits, int dense_bits, uint32_t* target) {
  const std::size_t n = packed.size();
  radix_sort(packed, index_bits, index_bits + dense_bits);

  constexpr std::size_t kChunk = std::size_t(1) << 16;
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  auto key_of = [index_bits](uint64_t p) { return p >> index_bits; };
  auto is_head = [&](std::size_t i) { return i == 0 || key_of(packed[i]) != key_of(packed[i - 1]); };
  std::vector<std::size_t> first_vertex(chunks + 1, 0);
  for_each_index(chunks, [&](std::size_t c) {
    std::size_t heads = 0;
    for (std::size_t i = c * kChunk, end = std::min(n, i + kChunk); i < end; ++i) heads += is_head(i);
    first_vertex[c + 1] = heads;
  });
  for (std::size_t c = 0; c < chunks; ++c) first_vertex[c + 1] += first_vertex[c];

  check_vertex_count(first_vertex.back());
  std::vector<uint64_t> vertex_keys;
  resize_populated(vertex_keys, first_vertex.back());
  const uint64_t index_mask = (uint64_t(1) << index_bits) - 1;
  for_each_index(chunks, [&](std::size_t c) {
    std::size_t v = first_vertex[c];  // index of the next run head
    for (std::size_t i = c * kChunk, end = std::min(n, i + kChunk); i < end; ++i) {
      if (is_head(i)) vertex_keys[v++] = key_of(packed[i]);
      target[packed[i] & index_mask] = uint32_t(v - 1);
    }
  });
  std::vector<uint64_t>().swap(packed);  // `= {}` would keep the capacity
  return vertex_keys;
}

/// The triangles' corners as one array of 3 indices per triangle (null when there are none).
uint32_t* corner_data(std::vector<Triangle>& triangles) {
  static_assert(sizeof(Triangle) == 3 * sizeof(uint32_t), "Triangle must be three packed indices");
  return reinterpret_cast<uint32_t*>(triangles.data());
}

int index_bits_for(std::size_t count) { return count < 2 ? 1 : int(std::bit_width(count - 1)); }

/// Without the block structure: every corner's dense key and index packed in place (the largest
/// array of the extraction, 8 bytes a triangle corner; a second copy would raise the peak by a
/// third) and numbered by one sort over all corners.
void weld_packed(std::vector<uint64_t>& corner_keys, const DenseEdgeKeys& dense, int index_bits,
                 const SparseField& field, float iso, TriangleMesh& mesh) {
  const std::size_t n = corner_keys.size();
  std::vector<uint64_t>& packed = corner_keys;
  for_each_index(n, [&](std::size_t i) { packed[i] = (dense.dense(packed[i]) << index_bits) | i; });
  std::vector<Triangle> triangles;
  resize_populated(triangles, n / 3);
  const std::vector<uint64_t> vertex_keys = number_runs(packed, index_bits, dense.bits, corner_data(triangles));
  mesh.triangles = std::move(triangles);
  compute_vertices(vertex_keys, dense, field, iso, mesh);
}

/// With the block structure of the marching (the usual case): the vertices are the crossing edges
/// (MarchedCorners::block_crossings), numbered in key order — by the (z, y, x, type) of their base
/// cell — straight from per-row counts, without sorting any key. A block's cells form n² rows of
/// n cells; the key order runs over the rows of one z-slab of blocks (blocks with equal z, in
/// (y, x) order, as blocks_to_march sorts them) row z by row y by block x. So a prefix sum over
/// the slabs, then over each slab's rows, gives every row's first vertex, and a crossing edge's
/// vertex is its row's first plus the popcounts of the crossing masks before it. Each block then
/// numbers its own distinct edges (their base cells lie in it or a neighbour, whose rows are
/// known), writes its triangles' corners and the positions of the vertices its cells own. Same
/// mesh as sorting all the corners' keys (weld_packed; tested), without the sort, its scratch
/// copy, the packed keys or the per-vertex key array, and the positions are computed where the
/// block's field values are at hand: about half the time and a lower peak than the sort.
void weld_numbered(MarchedCorners& m, const SparseField& field, float iso, bool with_keys, ExtractResult& result) {
  TriangleMesh& mesh = result.mesh;
  const std::size_t blocks = m.origins.size();
  const int n = m.block_cells;
  const int shift = std::countr_zero(unsigned(n));
  const std::size_t rows = std::size_t(n) * std::size_t(n);

  // Each row's count of crossing edges, then (in place) its first vertex number; and each cell's
  // count of the crossing edges before it in its row (at most 3 · 54 on the A15 lattice, 7 · 7 on
  // the cubic one: a byte), so that numbering an edge takes one popcount, not one per cell before it.
  const std::size_t cells = rows * std::size_t(n);
  std::vector<uint32_t> row_start(blocks * rows, 0);
  std::vector<uint8_t> before_in_row;
  resize_populated(before_in_row, blocks * cells);
  for_each_index(blocks, [&](std::size_t b) {
    if (m.block_crossings[b] == nullptr) return;
    for (std::size_t row = 0; row < rows; ++row) {
      uint32_t count = 0;
      for (int x = 0; x < n; ++x) {
        before_in_row[b * cells + row * n + x] = uint8_t(count);
        count += uint32_t(std::popcount(m.crossings(b, row * n + x)));
      }
      row_start[b * rows + row] = count;
    }
  });
  std::vector<std::size_t> slab_first{0};
  for (std::size_t b = 1; b < blocks; ++b)
    if (m.origins[b].z != m.origins[b - 1].z) slab_first.push_back(b);
  slab_first.push_back(blocks);
  const std::size_t slabs = slab_first.size() - 1;
  std::vector<uint64_t> slab_start(slabs + 1, 0);
  for_each_index(slabs, [&](std::size_t s) {
    uint64_t total = 0;
    for (std::size_t i = slab_first[s] * rows; i < slab_first[s + 1] * rows; ++i) total += row_start[i];
    slab_start[s + 1] = total;
  });
  for (std::size_t s = 0; s < slabs; ++s) slab_start[s + 1] += slab_start[s];
  check_vertex_count(slab_start.back());
  for_each_index(slabs, [&](std::size_t s) {
    uint64_t next = slab_start[s];
    for (int z = 0; z < n; ++z)
      for (std::size_t g = slab_first[s], g_end; g < slab_first[s + 1]; g = g_end) {
        g_end = g + 1;  // the blocks of one y, in x order
        while (g_end < slab_first[s + 1] && m.origins[g_end].y == m.origins[g].y) ++g_end;
        for (int y = 0; y < n; ++y)
          for (std::size_t b = g; b < g_end; ++b) {
            uint32_t& row = row_start[b * rows + std::size_t(z) * n + std::size_t(y)];
            const uint32_t count = row;
            row = uint32_t(next);
            next += count;
          }
      }
  });

  // The 27 blocks around a block (offsets in {-1, 0, 1}³) as slots 0..26, and back.
  const auto slot_of = [](Vec3i d) { return (d.z + 1) * 9 + (d.y + 1) * 3 + d.x + 1; };
  const auto slot_offset = [](int slot) { return Vec3i{slot % 3 - 1, slot / 3 % 3 - 1, slot / 9 - 1}; };
  // A code's cell (BlockEdgeCodes: relative to the block's first cell - 2) as the block holding
  // it, by its slot, and the cell's index there.
  const BlockEdgeCodes codes = m.codes;
  struct CellRef {
    uint8_t slot;
    uint16_t cell;
  };
  std::vector<CellRef> cell_ref(std::size_t(codes.span) * codes.span * codes.span);
  for (int z = 0, i = 0; z < codes.span; ++z)
    for (int y = 0; y < codes.span; ++y)
      for (int x = 0; x < codes.span; ++x, ++i) {
        const Vec3i c{x - 2, y - 2, z - 2};
        const Vec3i o{c.x >> shift, c.y >> shift, c.z >> shift};  // -1, 0 or 1
        const Vec3i l{c.x - o.x * n, c.y - o.y * n, c.z - o.z * n};
        cell_ref[std::size_t(i)] = {uint8_t(slot_of(o)), uint16_t((l.z * n + l.y) * n + l.x)};
      }
  const uint16_t type_mask = uint16_t((1u << codes.type_bits) - 1);
  std::vector<uint64_t> keys(blocks);
  for (std::size_t b = 0; b < blocks; ++b) {
    const Vec3i o = m.origins[b];
    keys[b] = pack_coords(o.x >> shift, o.y >> shift, o.z >> shift);
  }
  const CellIndex index(keys);

  resize_populated(mesh.triangles, m.corner_count() / 3);
  // Ordinary pages for the positions too: on huge pages (madvise'd, as the voids' and normals'
  // random reads would like) the first surfacing after a pause can stall in the kernel's
  // compaction for them (bench/RESULTS.md#caveats), and the later passes gain no time from them.
  resize_populated(mesh.vertices, std::size_t(slab_start.back()));
  std::vector<uint64_t>& edge_key_of_vertex = result.vertex_keys;
  if (with_keys) resize_populated(edge_key_of_vertex, mesh.vertices.size());
  const SampleLattice& lattice = field.lattice();
  const std::size_t repeated = reduce(
      blocks, 1, std::size_t(0),
      [&](std::size_t begin, std::size_t end, std::size_t acc) {
        std::vector<uint32_t> vertex_of;  // per distinct edge of the block
        for (std::size_t b = begin; b != end; ++b) {
          const Vec3i block{m.origins[b].x >> shift, m.origins[b].y >> shift, m.origins[b].z >> shift};
          std::array<uint32_t, 27> around;  // marched-block index per slot, looked up when first used
          around.fill(kNotFound - 1);
          auto neighbour = [&](int slot) {
            if (around[slot] == kNotFound - 1) around[slot] = index.find(block + slot_offset(slot));
            return around[slot];
          };
          const std::span<const uint16_t> edges = m.edges(b);
          if (!edges.empty()) {
            vertex_of.resize(edges.size());
            for (std::size_t e = 0; e < edges.size(); ++e) {
              const CellRef ref = cell_ref[edges[e] >> codes.type_bits];
              const int type = edges[e] & type_mask;
              const uint32_t owner = neighbour(ref.slot);
              // Every corner's edge crosses, and the block holding its base cell is marched.
              if (owner == kNotFound || m.block_crossings[owner] == nullptr ||
                  !(m.crossings(owner, ref.cell) >> type & 1))
                throw std::logic_error("extract_surface: a triangle corner lies on an edge that does not cross");
              uint32_t v = row_start[owner * rows + (ref.cell >> shift)] + before_in_row[owner * cells + ref.cell];
              v += uint32_t(std::popcount(m.crossings(owner, ref.cell) & ((uint64_t(1) << type) - 1)));
              vertex_of[e] = v;
            }
            const std::span<const uint16_t> corners = m.corners(b);
            Triangle* out = mesh.triangles.data() + m.triangle_offsets[b];
            for (std::size_t c = 0; c < corners.size(); c += 3, ++out) {
              *out = {vertex_of[corners[c]], vertex_of[corners[c + 1]], vertex_of[corners[c + 2]]};
              acc += (*out)[0] == (*out)[1] || (*out)[1] == (*out)[2] || (*out)[0] == (*out)[2];
            }
          }
          if (m.block_crossings[b] == nullptr) continue;
          // The positions of the vertices this block's cells own: where {φ = iso} crosses each
          // crossing edge (compute_vertices' formula), the far sample read from the field block
          // next door when the edge leaves this one.
          std::array<uint32_t, 27> field_block;
          field_block.fill(kNotFound - 1);
          auto value = [&](Vec3i cell, int s) {
            const Vec3i cb{cell.x >> shift, cell.y >> shift, cell.z >> shift};
            const int slot = slot_of(cb - block);
            if (field_block[slot] == kNotFound - 1) field_block[slot] = field.find_block(cb);
            return *field.address_in(field_block[slot], cb, cell, s);
          };
          for (int z = 0; z < n; ++z)
            for (int y = 0; y < n; ++y) {
              uint32_t v = row_start[b * rows + std::size_t(z) * n + std::size_t(y)];
              for (int x = 0; x < n; ++x) {
                const Vec3i c0 = m.origins[b] + Vec3i{x, y, z};
                for (uint64_t bits = m.crossings(b, (std::size_t(z) * n + y) * n + x); bits != 0; bits &= bits - 1) {
                  const int type = std::countr_zero(bits);
                  const LatticeEdge& e = m.edge_types[type];
                  const Vec3i c1{c0.x + e.dx, c0.y + e.dy, c0.z + e.dz};
                  if (with_keys) edge_key_of_vertex[v] = edge_key(c0, type);
                  mesh.vertices[v++] = edge_vertex(lattice.sample_position(c0, e.s0), lattice.sample_position(c1, e.s1),
                                                   value(c0, e.s0), value(c1, e.s1), iso, kEdgeClamp);
                }
              }
            }
        }
        return acc;
      },
      std::plus<>());
  m = MarchedCorners();  // the pages, given back before the voids and smoothing allocate
  give_back_free_heap_pages();
  if (repeated == 0) return;
  if (with_keys) {  // the keys of the vertices that a triangle without a repeated corner uses
    std::vector<uint64_t>& vertex_keys = result.vertex_keys;
    std::vector<uint8_t> used(vertex_keys.size(), 0);
    for (const Triangle& t : mesh.triangles)
      if (t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
        for (const uint32_t v : t) used[v] = 1;
    std::size_t kept = 0;
    for (std::size_t v = 0; v < vertex_keys.size(); ++v)
      if (used[v]) vertex_keys[kept++] = vertex_keys[v];
    vertex_keys.resize(kept);
  }
  result.dropped_triangles = drop_repeated(mesh);
}

/// Fallback for fields whose cells span so much of the key range (components near opposite
/// corners of a 2^19-cell cube) that key and index do not share a word: sort the keys alone, keep
/// the distinct ones, and find each corner's key by a two-level binary search.
void weld_searched(std::span<const uint64_t> corner_keys, const DenseEdgeKeys& dense, const SparseField& field,
                   float iso, TriangleMesh& mesh) {
  std::vector<uint64_t> sorted(corner_keys.size());
  for_each_index(corner_keys.size(), [&](std::size_t i) { sorted[i] = dense.dense(corner_keys[i]); });
  radix_sort(sorted, 0, dense.bits);
  const std::vector<uint64_t> vertex_keys = unique_sorted(sorted);
  std::vector<uint64_t>().swap(sorted);
  check_vertex_count(vertex_keys.size());
  compute_vertices(vertex_keys, dense, field, iso, mesh);

  const SortedKeyIndex index(vertex_keys);
  mesh.triangles.resize(corner_keys.size() / 3);
  for_each_chunk(mesh.triangles.size(), 1, [&](std::size_t begin, std::size_t end) {
    for (std::size_t t = begin; t != end; ++t)
      for (int k = 0; k < 3; ++k) mesh.triangles[t][k] = uint32_t(index.find(dense.dense(corner_keys[3 * t + k])));
  });
}

}  // namespace

namespace {

/// Drops the triangles with a repeated vertex (never made by the marching stages; see drop_repeated).
void drop_repeated_triangles(ExtractResult& result) {
  TriangleMesh& mesh = result.mesh;
  const std::size_t repeated = reduce(
      mesh.triangles.size(), 1, std::size_t(0),
      [&](std::size_t begin, std::size_t end, std::size_t acc) {
        for (std::size_t t = begin; t != end; ++t) {
          const Triangle& tri = mesh.triangles[t];
          acc += tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2];
        }
        return acc;
      },
      [](std::size_t a, std::size_t b) { return a + b; });
  if (repeated > 0) result.dropped_triangles = drop_repeated(mesh);
}

}  // namespace

ExtractResult weld_edge_keys(std::vector<uint64_t> corner_keys, const SparseField& field, float iso) {
  ExtractResult result;
  const DenseEdgeKeys dense(corner_keys);
  const int index_bits = index_bits_for(corner_keys.size());
  if (dense.bits + index_bits <= 64)
    weld_packed(corner_keys, dense, index_bits, field, iso, result.mesh);
  else
    weld_searched(corner_keys, dense, field, iso, result.mesh);
  drop_repeated_triangles(result);
  return result;
}

ExtractResult weld_edge_keys(MarchedCorners marched, const SparseField& field, float iso, bool vertex_keys) {
  const std::size_t blocks = marched.origins.size();
  if (marched.triangle_offsets.size() != blocks + 1 || marched.edge_offsets.size() != blocks + 1 ||
      marched.block_edges.size() != blocks || marched.block_corners.size() != blocks ||
      marched.block_crossings.size() != blocks || marched.edge_types == nullptr)
    throw std::logic_error("weld_edge_keys: the block offsets do not match the blocks");
  ExtractResult result;
  weld_numbered(marched, field, iso, vertex_keys, result);
  return result;
}

}  // namespace meniscus
