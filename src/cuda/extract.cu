// meniscus — iso-surface extraction on the device (Williams 2008 Marching Tiles; Lorensen & Cline
// 1987; Doi & Koide 1991; Edespong 2010 §4.3): inside masks per cell, the blocks to march
// (allocated + ghost blocks), per-cell triangle counts, an exclusive scan over (block, cell) — the
// CPU's order — and the write pass with the shared kernels of marching_impl.hpp; then the weld:
// a stable sort of the corner edge keys, one vertex per distinct key (increasing key order, as on
// the CPU), positions from the field.
#include <mutex>

#include "cuda/primitives.hpp"
#include "cuda/stages_cuda.hpp"
#include "extract/edge_key.hpp"
#include "extract/extract.hpp"
#include "extract/marching_impl.hpp"

namespace meniscus::cuda {

namespace {

// Raw storage: MarchingTables has default member initialisers, which a __device__ variable cannot
// run; the host copies the constexpr tables in (upload_tables).
__device__ uint64_t d_tables_storage[(sizeof(MarchingTables) + 7) / 8];
#define d_tables (*reinterpret_cast<const MarchingTables*>(d_tables_storage))
__device__ TileVertexLookup d_tile_lookup;

__global__ void masks_kernel(const float* values, uint64_t samples, int spc, float iso, uint8_t* masks) {
  const uint64_t cells = samples / uint64_t(spc);
  MENISCUS_GRID_STRIDE(c, cells) {
    unsigned bits = 0;
    for (int s = 0; s < spc; ++s) bits |= unsigned(values[c * spc + s] < iso) << s;
    masks[c] = uint8_t(bits);
  }
}

__device__ bool block_has_inside(const uint8_t* masks, uint32_t b, int cells) {
  for (int c = 0; c < cells; ++c)
    if (masks[uint64_t(b) * cells + c] != 0) return true;
  return false;
}

/// Ghost blocks: unallocated neighbours (on the stencil's side) of blocks with an inside sample.
__global__ void ghost_kernel(const uint64_t* keys, uint32_t blocks, const uint8_t* masks, int cells, bool full,
                             const uint64_t* offsets, uint64_t* out, uint32_t* counts) {
  MENISCUS_GRID_STRIDE(b, blocks) {
    uint32_t n = 0;
    if (block_has_inside(masks, uint32_t(b), cells)) {
      const Vec3i c = unpack_coords(keys[b]);
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            if (dx == 0 && dy == 0 && dz == 0) continue;
            if (!full && (dx > 0 || dy > 0 || dz > 0)) continue;
            const uint64_t k = pack_coords(c.x + dx, c.y + dy, c.z + dz);
            if (find_sorted(keys, blocks, k) != kNotFound) continue;
            if (out != nullptr) out[offsets[b] + n] = k;
            ++n;
          }
    }
    if (counts != nullptr) counts[b] = n;
  }
}

__global__ void key_range_kernel(const uint64_t* keys, uint32_t blocks, int n, int* bad) {
  MENISCUS_GRID_STRIDE(b, blocks) {
    const Vec3i c = unpack_coords(keys[b]);
    for (int a = 0; a < 3; ++a) {
      const int64_t first = int64_t(c[a]) * n, last = first + n - 1;
      if (first - n - 2 < -kEdgeKeyMaxCoord || last + n + 2 > kEdgeKeyMaxCoord) atomicExch(bad, 1);
    }
  }
}

/// One thread block per march block: gathers the padded masks into shared memory, then each
/// thread counts (out == nullptr) or writes the triangles of its cells.
template <bool kTiles>
__global__ void march_kernel(const uint64_t* march_keys, const uint64_t* field_keys, uint32_t field_blocks,
                             const uint8_t* cell_masks, int n, Extractor extractor, uint64_t* counts,
                             const uint64_t* offsets, uint64_t* corners) {
  __shared__ uint8_t padded[10 * 10 * 10];
  __shared__ uint32_t neighbour[27];
  const int p = n + 2, cells = n * n * n;
  const uint64_t b = blockIdx.x;
  const Vec3i bc = unpack_coords(march_keys[b]);
  for (unsigned k = threadIdx.x; k < 27; k += blockDim.x) {  // whatever the block size
    const int dx = int(k % 3) - 1, dy = int(k / 3 % 3) - 1, dz = int(k / 9) - 1;
    neighbour[k] = find_sorted(field_keys, field_blocks, pack_coords(bc.x + dx, bc.y + dy, bc.z + dz));
  }
  __syncthreads();
  for (int i = threadIdx.x; i < p * p * p; i += blockDim.x) {
    const int x = i % p - 1, y = i / p % p - 1, z = i / (p * p) - 1;
    const int dx = x < 0 ? -1 : (x >= n ? 1 : 0), dy = y < 0 ? -1 : (y >= n ? 1 : 0), dz = z < 0 ? -1 : (z >= n ? 1 : 0);
    const uint32_t nb = neighbour[(dz + 1) * 9 + (dy + 1) * 3 + (dx + 1)];
    const int lx = x - dx * n, ly = y - dy * n, lz = z - dz * n;
    padded[i] = nb == kNotFound ? uint8_t(0) : cell_masks[uint64_t(nb) * cells + uint64_t((lz * n + ly) * n + lx)];
  }
  __syncthreads();
  const Vec3i origin{bc.x * n, bc.y * n, bc.z * n};
  const int sy = p, sz = p * p;
  for (int c = threadIdx.x; c < cells; c += blockDim.x) {
    const int x = c % n, y = c / n % n, z = c / (n * n);
    const uint8_t* m = padded + ((z + 1) * p + (y + 1)) * p + (x + 1);
    const uint64_t slot = b * uint64_t(cells) + uint64_t(c);
    uint64_t* out = corners != nullptr ? corners + 3 * offsets[slot] : nullptr;
    if (out == nullptr && counts == nullptr) continue;
    uint32_t count = 0;
    const uint64_t cell_key = edge_key(Vec3i{origin.x + x, origin.y + y, origin.z + z}, 0);
    if (kTiles) {
      if (tile_cell_may_cross(m, sy, sz))
        count = march_tile_cell(m, d_tile_lookup, d_tables.tet_cases, d_tables.a15_edges, cell_key, out);
    } else if (extractor == Extractor::cubes) {
      count = march_cube_cell(m, sy, sz, d_tables, cell_key, out);
    } else {
      count = march_kuhn_cell(m, sy, sz, d_tables, cell_key, out);
    }
    if (counts != nullptr) counts[slot] = count;
  }
}

__global__ void index_kernel(uint32_t* v, uint64_t n) {
  MENISCUS_GRID_STRIDE(i, n)
    v[i] = uint32_t(i);
}

__global__ void weld_heads_kernel(const uint64_t* keys, uint64_t n, uint32_t* heads) {
  MENISCUS_GRID_STRIDE(i, n)
    heads[i] = (i == 0 || keys[i] != keys[i - 1]) ? 1u : 0u;
}

__global__ void weld_scatter_kernel(const uint64_t* keys, const uint32_t* corner, const uint32_t* heads,
                                    const uint32_t* vertex_of, uint64_t n, uint32_t* triangles,
                                    uint64_t* vertex_keys) {
  MENISCUS_GRID_STRIDE(i, n) {
    // vertex_of is the exclusive scan of heads: the run of i is vertex (scan + head − 1).
    const uint32_t v = vertex_of[i] + heads[i] - 1;
    if (heads[i]) vertex_keys[v] = keys[i];
    triangles[corner[i]] = v;
  }
}

__global__ void vertex_position_kernel(const uint64_t* vertex_keys, uint64_t nv, FieldView field, bool a15,
                                       float cell_size, float iso, SampleOffsets offsets, Vec3f* vertices) {
  const float(*c_offsets)[3] = offsets.o;
  const LatticeEdge* types = a15 ? d_tables.a15_edges.types : d_tables.kuhn_edges.types;
  MENISCUS_GRID_STRIDE(v, nv) {
    Vec3i c0, c1;
    int s0 = 0, s1 = 0;
    edge_key_samples(vertex_keys[v], types, &c0, &s0, &c1, &s1);
    const Vec3f o0{c_offsets[s0][0], c_offsets[s0][1], c_offsets[s0][2]}, o1{c_offsets[s1][0], c_offsets[s1][1], c_offsets[s1][2]};
    vertices[v] = edge_vertex(lattice_point(c0, o0, cell_size), lattice_point(c1, o1, cell_size), field.value(c0, s0),
                              field.value(c1, s1), iso, kEdgeClamp);
  }
}

__global__ void repeated_kernel(const uint32_t* tris, uint64_t nt, unsigned long long* count) {
  MENISCUS_GRID_STRIDE(t, nt) {
    const uint32_t a = tris[3 * t], b = tris[3 * t + 1], c = tris[3 * t + 2];
    if (a == b || b == c || a == c) atomicAdd(count, 1ull);
  }
}

/// The marching tables, on the device once per process: the same constants for every run, so
/// concurrent reconstructions share them safely (the first one uploads, the others wait for it).
void upload_tables() {
  static std::once_flag once;
  std::call_once(once, [] {
    static const MarchingTables tables = host_marching_tables();
    static constexpr TileVertexLookup lookup = make_tile_vertex_lookup(6, 36);
    MENISCUS_CUDA_CHECK(cudaMemcpyToSymbol(d_tables_storage, &tables, sizeof(tables)));
    MENISCUS_CUDA_CHECK(cudaMemcpyToSymbol(d_tile_lookup, &lookup, sizeof(lookup)));
  });
}

}  // namespace

DeviceMesh extract_surface(const DeviceField& field, float iso, Extractor extractor) {
  const bool a15 = field.lattice.kind == SampleLattice::Kind::a15;
  if (a15 != (extractor == Extractor::tiles))
    throw InvalidParameter("extract_surface (cuda): the field's lattice does not fit the extractor");
  if (!(field.background > iso)) throw InvalidParameter("extract_surface (cuda): the background must be > the iso value");
  upload_tables();
  DeviceMesh mesh;
  const uint32_t blocks = field.blocks;
  if (blocks == 0) return mesh;
  const int n = field.lattice.block_cells(), spc = field.lattice.samples_per_cell(), cells = n * n * n;
  {
    DeviceBuffer<int> bad(1);
    bad.zero();
    MENISCUS_LAUNCH(key_range_kernel, blocks_for(blocks), 256)(field.keys.data(), blocks, n, bad.data());
    MENISCUS_CUDA_CHECK_LAUNCH();
    if (bad.get(0) != 0)
      throw ResourceError("extract_surface (cuda): a field block lies outside the range of the 64-bit edge keys; use a "
                          "larger voxel size or move the particles closer to the origin");
  }
  DeviceBuffer<uint8_t> masks(std::size_t(blocks) * cells);
  MENISCUS_LAUNCH(masks_kernel, blocks_for(std::size_t(blocks) * cells), 256)(field.values.data(), uint64_t(blocks) * kBlockSamples,
                                                                  spc, iso, masks.data());
  MENISCUS_CUDA_CHECK_LAUNCH();

  // Blocks to march: the allocated ones plus the ghosts, sorted, unique.
  const bool full = extractor == Extractor::tiles;
  DeviceBuffer<uint32_t> ghost_counts(blocks), ghost_offsets32(std::size_t(blocks) + 1);
  MENISCUS_LAUNCH(ghost_kernel, blocks_for(blocks), 256)(field.keys.data(), blocks, masks.data(), cells, full, nullptr, nullptr,
                                            ghost_counts.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  exclusive_sum(Device{}, ghost_counts.data(), ghost_offsets32.data(), blocks);
  const uint32_t ghosts = ghost_offsets32.get(blocks);
  DeviceBuffer<uint64_t> ghost_offsets(blocks);
  {
    std::vector<uint32_t> h(blocks);
    ghost_offsets32.download(h.data(), blocks);  // small: one word per block
    std::vector<uint64_t> h64(h.begin(), h.end());
    ghost_offsets.upload(h64.data(), blocks);
  }
  DeviceBuffer<uint64_t> march_keys(std::size_t(blocks) + ghosts);
  MENISCUS_CUDA_CHECK(counted_memcpy(march_keys.data(), field.keys.data(), blocks * sizeof(uint64_t), cudaMemcpyDeviceToDevice));
  MENISCUS_LAUNCH(ghost_kernel, blocks_for(blocks), 256)(field.keys.data(), blocks, masks.data(), cells, full, ghost_offsets.data(),
                                            march_keys.data() + blocks, nullptr);
  MENISCUS_CUDA_CHECK_LAUNCH();
  sort_keys(Device{}, march_keys.data(), std::size_t(blocks) + ghosts);
  const std::size_t march_blocks = unique_sorted(Device{}, march_keys.data(), std::size_t(blocks) + ghosts);

  // Count, scan, write.
  const std::size_t slots = march_blocks * std::size_t(cells);
  DeviceBuffer<uint64_t> counts(slots), offsets(slots + 1);
  const unsigned threads = unsigned(cells < 128 ? cells : 128);
  auto march = [&](uint64_t* c, const uint64_t* o, uint64_t* out) {
    if (a15)
      MENISCUS_LAUNCH(march_kernel<true>, unsigned(march_blocks), threads)(march_keys.data(), field.keys.data(), blocks, masks.data(),
                                                              n, extractor, c, o, out);
    else
      MENISCUS_LAUNCH(march_kernel<false>, unsigned(march_blocks), threads)(march_keys.data(), field.keys.data(), blocks,
                                                               masks.data(), n, extractor, c, o, out);
    MENISCUS_CUDA_CHECK_LAUNCH();
  };
  march(counts.data(), nullptr, nullptr);
  exclusive_sum(Device{}, counts.data(), offsets.data(), slots);
  const uint64_t triangles = offsets.get(slots);
  const uint64_t corners_n = 3 * triangles;
  if (corners_n >= uint64_t(kNotFound))
    throw ResourceError("extract_surface (cuda): the mesh would need 2^32 or more triangle corners");
  DeviceBuffer<uint64_t> corners(corners_n);
  march(nullptr, offsets.data(), corners.data());
  counts = {};
  offsets = {};
  masks = {};

  // Weld: stable sort of (edge key, corner index); run heads become vertices in key order.
  DeviceBuffer<uint32_t> corner_index(corners_n);
  MENISCUS_LAUNCH(index_kernel, blocks_for(corners_n), 256)(corner_index.data(), corners_n);
  MENISCUS_CUDA_CHECK_LAUNCH();
  sort_pairs(Device{}, corners.data(), corner_index.data(), corners_n, 0, 63);
  DeviceBuffer<uint32_t> heads(corners_n), vertex_of(corners_n + 1);
  MENISCUS_LAUNCH(weld_heads_kernel, blocks_for(corners_n), 256)(corners.data(), corners_n, heads.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  exclusive_sum(Device{}, heads.data(), vertex_of.data(), corners_n);
  const uint32_t nv = corners_n == 0 ? 0 : vertex_of.get(corners_n);
  DeviceBuffer<uint64_t> vertex_keys(nv);
  mesh.triangles.resize(corners_n);
  MENISCUS_LAUNCH(weld_scatter_kernel, blocks_for(corners_n), 256)(corners.data(), corner_index.data(), heads.data(),
                                                      vertex_of.data(), corners_n, mesh.triangles.data(),
                                                      vertex_keys.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  mesh.vertices.resize(nv);
  MENISCUS_LAUNCH(vertex_position_kernel, blocks_for(nv), 256)(vertex_keys.data(), nv, field.view(), a15,
                                                               field.lattice.cell_size, iso, SampleOffsets(field.lattice),
                                                               mesh.vertices.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  mesh.vertex_count = nv;
  mesh.triangle_count = triangles;
  DeviceBuffer<unsigned long long> repeated(1);
  repeated.zero();
  MENISCUS_LAUNCH(repeated_kernel, blocks_for(triangles), 256)(mesh.triangles.data(), triangles, repeated.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  // Unreachable for the marching stages (a triangle's corners lie on distinct edges); the CPU
  // weld drops such triangles, this backend hands the job back to the CPU instead.
  if (repeated.get(0) != 0)
    throw ResourceError("extract_surface (cuda): the weld produced triangles with a repeated vertex");
  return mesh;
}

}  // namespace meniscus::cuda
