// meniscus — the stages of the CUDA backend over device data, mirroring the CPU stage folders:
// hash_grid.cu (grid/), distance_field.cu (field/), extract.cu (extract/ + mesh/voids),
// smooth.cu (smooth/), transfer.cu (transfer/). Views are plain structs of device pointers with
// MENISCUS_HD accessors, so the shared *_impl.hpp templates (grid queries, projection) run on them.
#pragma once

#include <cstdint>
#include <vector>

#include "cuda/cuda_check.hpp"
#include "field/kernel_impl.hpp"
#include "field/sparse_field.hpp"
#include "grid/hash_grid_impl.hpp"
#include "grid/key_index.hpp"
#include "meniscus/params.hpp"
#include "meniscus/vec.hpp"
#include "smooth/schedule.hpp"

namespace meniscus::cuda {

/// Index of `key` in sorted keys[0, n), or kNotFound (binary search; the device's KeyIndex).
MENISCUS_HD inline uint32_t find_sorted(const uint64_t* keys, uint32_t n, uint64_t key) {
  uint32_t lo = 0, hi = n;
  while (lo < hi) {
    const uint32_t mid = lo + (hi - lo) / 2;
    if (keys[mid] < key) lo = mid + 1; else hi = mid;
  }
  return lo < n && keys[lo] == key ? lo : kNotFound;
}

/// The lattice's sample offsets (in cells), passed to the kernels by value: no per-process device
/// state, so concurrent reconstructions on different lattices stay apart.
struct SampleOffsets {
  float o[8][3] = {};
  SampleOffsets() = default;
  explicit SampleOffsets(const SampleLattice& lattice) {
    for (int s = 0; s < lattice.samples_per_cell(); ++s)
      for (int a = 0; a < 3; ++a) o[s][a] = lattice.sample_offset(s)[a];
  }
};

struct CellRange {
  uint32_t first = 0, second = 0;
};

/// The hash grid on the device (the Grid of hash_grid_impl.hpp).
struct GridView {
  const Vec3f* sorted = nullptr;
  const uint64_t* keys = nullptr;
  const uint32_t* starts = nullptr;
  uint32_t cells = 0, count = 0;
  float cs = 1;
  Vec3i lo{}, hi{-1, -1, -1};

  MENISCUS_HD float cell_size() const { return cs; }
  MENISCUS_HD Vec3i cell_min() const { return lo; }
  MENISCUS_HD Vec3i cell_max() const { return hi; }
  MENISCUS_HD uint32_t size() const { return count; }
  MENISCUS_HD Vec3f point(uint32_t i) const { return sorted[i]; }
  MENISCUS_HD const Vec3f* points() const { return sorted; }
  MENISCUS_HD CellRange cell_range(Vec3i c) const {
    if (c.x < lo.x || c.y < lo.y || c.z < lo.z || c.x > hi.x || c.y > hi.y || c.z > hi.z) return {};
    const uint32_t i = find_sorted(keys, cells, pack_coords(c.x, c.y, c.z));
    if (i == kNotFound) return {};
    return {starts[i], starts[i + 1]};
  }
};

struct DeviceGrid {
  DeviceBuffer<Vec3f> sorted;
  DeviceBuffer<uint32_t> order;
  DeviceBuffer<uint64_t> keys;
  DeviceBuffer<uint32_t> starts;
  uint32_t cells = 0, count = 0;
  float cell_size = 1;
  Vec3i lo{}, hi{-1, -1, -1};
  GridView view() const { return {sorted.data(), keys.data(), starts.data(), cells, count, cell_size, lo, hi}; }
};

/// The sparse field on the device: sorted block keys and 512 values per block.
struct FieldView {
  const uint64_t* keys = nullptr;
  const float* values = nullptr;
  uint32_t blocks = 0;
  int n = 8, spc = 1;  ///< cells per block edge, samples per cell
  float background = 0;

  MENISCUS_HD float value(Vec3i cell, int s) const {
    auto div = [this](int32_t v) { return v >= 0 ? v / n : -((-v + n - 1) / n); };
    const Vec3i b{div(cell.x), div(cell.y), div(cell.z)};
    const uint32_t i = find_sorted(keys, blocks, pack_coords(b.x, b.y, b.z));
    if (i == kNotFound) return background;
    const Vec3i l{cell.x - b.x * n, cell.y - b.y * n, cell.z - b.z * n};
    return values[std::size_t(i) * kBlockSamples + std::size_t(((l.z * n + l.y) * n + l.x) * spc + s)];
  }
};

struct DeviceField {
  SampleLattice lattice;
  DeviceBuffer<uint64_t> keys;
  DeviceBuffer<float> values;
  uint32_t blocks = 0;
  float background = 0;
  FieldView view() const {
    return {keys.data(), values.data(), blocks, lattice.block_cells(), lattice.samples_per_cell(), background};
  }
};

struct DeviceMesh {
  DeviceBuffer<Vec3f> vertices;
  DeviceBuffer<uint32_t> triangles;  ///< 3 per triangle
  std::size_t vertex_count = 0, triangle_count = 0;
};

/// Mesh connectivity on the device (the CPU's Adjacency).
struct DeviceAdjacency {
  DeviceBuffer<uint32_t> offsets, neighbors, tri_offsets, tri_ids;
};

// --- stages ---------------------------------------------------------------------------------------

/// Hash grid of `count` device points (grid/hash_grid.cpp): keys, stable radix sort, cell ranges.
/// `lo`/`hi`: the points' cell range (checked on the host against the key range).
DeviceGrid build_grid(const DeviceBuffer<Vec3f>& points, uint32_t count, float cell_size, Vec3i lo, Vec3i hi);

/// band_blocks() on the device: sorted unique block keys.
DeviceBuffer<uint64_t> band_blocks(const DeviceGrid& grid, const SampleLattice& lattice, float band,
                                   std::size_t* block_count);
/// distance_field() on the device over `keys` (moved in).
DeviceField distance_field(const DeviceGrid& grid, const SampleLattice& lattice, float band,
                           DeviceBuffer<uint64_t> keys, std::size_t block_count);

/// kernel_field() on the device over `keys` (moved in): one thread per sample gathering
/// kernel_field_sample (kernel_impl.hpp; `k` holds device pointers, per sorted particle).
DeviceField kernel_field(const DeviceGrid& grid, const SampleLattice& lattice, const KernelParticles& k, float support,
                         float iso, float background, DeviceBuffer<uint64_t> keys, std::size_t block_count);

// --- per-particle stages (fields.cu) -------------------------------------------------------------------

/// Bounds of `count` device points (exact: min and max are order-independent).
void point_bounds(const DeviceBuffer<Vec3f>& points, uint32_t count, Vec3f* lo, Vec3f* hi);
/// The largest max_axis of `count` device ellipsoids (≥ 0).
float max_ellipsoid_axis(const DeviceBuffer<Ellipsoid>& ellipsoids, uint32_t count);
/// Yu & Turk over `raw`, a grid of the original particles (anisotropy.cpp): per particle, in the
/// original order, the ellipsoid (when `ellipsoids` is non-null; neighbours within pca_radius)
/// and the Laplacian-smoothed centre (when lambda > 0, else the particle; neighbours within
/// smooth_radius), with both: held within `centre_reach` of the particle in its shell's metric
/// (centre_holding_particle; 0: as smoothed).
void particle_frames(const DeviceGrid& raw, float pca_radius, const AnisotropyConstants& k, float smooth_radius,
                     float lambda, DeviceBuffer<Vec3f>* centres, DeviceBuffer<Ellipsoid>* ellipsoids,
                     float centre_reach = 0);
/// out[i] = values[order[i]]: per-particle data from the original order into the grid's.
DeviceBuffer<float> to_sorted_order(const DeviceGrid& grid, const DeviceBuffer<float>& values);
DeviceBuffer<Ellipsoid> to_sorted_order(const DeviceGrid& grid, const DeviceBuffer<Ellipsoid>& values);
/// unit_volume_shell() of every ellipsoid (the constraint shells of the field and the smoothing).
DeviceBuffer<Ellipsoid> unit_volume_shells(const DeviceBuffer<Ellipsoid>& ellipsoids);
/// velocity_weight() of every vertex from its transferred velocity (3 floats a vertex).
DeviceBuffer<float> velocity_weights(const DeviceBuffer<float>& velocity, std::size_t vertices, float reference,
                                     float min_weight);

/// extract_surface() on the device: march (count, scan, write), then weld by sorting edge keys.
DeviceMesh extract_surface(const DeviceField& field, float iso, Extractor extractor);
/// remove_small_voids() on the device; returns the number of voids removed.
std::size_t remove_small_voids(DeviceMesh& mesh, double max_volume);
/// remove_unsupported_blobs() on the device (kernel fields), against the points of `grid`; returns
/// the number of components removed.
std::size_t remove_unsupported_blobs(DeviceMesh& mesh, const DeviceGrid& grid, double max_volume, double min_volume);
/// reorder_vertices_spatially() on the device: the same numbering as the CPU.
void reorder_vertices_spatially(DeviceMesh& mesh, float cell);

DeviceAdjacency build_adjacency(const DeviceMesh& mesh);

struct SmoothSettings : SmoothSchedule {
  float r_inner = 0, r_outer = 0;
  /// Ellipsoid constraints (anisotropic): the shells per sorted particle and their largest axis;
  /// null: spherical shells.
  const Ellipsoid* shells = nullptr;
  float max_axis = 1;
  /// Per-vertex factor on the damping of every sweep (velocity weighting); null: 1.
  const float* vertex_relax = nullptr;
};
/// smooth_surface() on the device (constrained against `grid`).
SmoothingStats smooth_surface(DeviceMesh& mesh, const DeviceAdjacency& adj, const DeviceGrid& grid, const SmoothSettings& s);

/// erode() on the device; returns the flipped triangle count.
std::size_t erode(DeviceMesh& mesh, const DeviceAdjacency& adj, float distance);
/// vertex_normals() on the device.
DeviceBuffer<Vec3f> vertex_normals(const DeviceMesh& mesh, const DeviceAdjacency& adj);
/// transfer_attribute() on the device: `values` are the attribute in the original particle
/// order, `components` per particle; returns components per vertex.
DeviceBuffer<float> transfer_attribute(const DeviceBuffer<float>& values, int components, const DeviceGrid& grid,
                                       const DeviceMesh& mesh, float radius);

}  // namespace meniscus::cuda
