// meniscus — the stages of the CUDA backend over device data, mirroring the CPU stage folders:
// every stage is written once over the backend tag in its folder and instantiated for the device
// in the folder's *_device.cu: the hash grid (grid/build_grid.hpp), the field's band, distance and
// kernel fields and the per-particle frames (field/band_field.hpp, field/particle_frames.hpp), the
// velocity weights (transfer/velocity_weights.hpp), the extraction and the voids
// (extract/extract_backend.hpp, mesh/voids_backend.hpp), the vertex reorder, adjacency and normals
// (mesh/*_backend.hpp), the sweeps (smooth/sweeps_backend.hpp), the attribute transfer
// (transfer/transfer_backend.hpp). The data are the stage folders' backend templates
// (GridBuffers, FieldBuffers, MeshBuffers, AdjacencyBuffers) on the Device; their views are plain
// structs of pointers with MENISCUS_HD accessors, so the shared *_impl.hpp templates run on them.
#pragma once

#include <cstdint>
#include <vector>

#include "cuda/cuda_check.hpp"
#include "cuda/device.hpp"
#include "field/field_buffers.hpp"
#include "field/kernel_impl.hpp"
#include "field/sparse_field.hpp"
#include "grid/grid_buffers.hpp"
#include "grid/hash_grid_impl.hpp"
#include "grid/key_index.hpp"
#include "meniscus/params.hpp"
#include "meniscus/vec.hpp"
#include "mesh/mesh_buffers.hpp"
#include "smooth/schedule.hpp"

namespace meniscus::cuda {

using ::meniscus::CellRange;
using ::meniscus::FieldView;
using ::meniscus::find_sorted;
using ::meniscus::GridView;
using ::meniscus::SampleOffsets;
using DeviceGrid = GridBuffers<Device>;
using DeviceField = FieldBuffers<Device>;
using DeviceMesh = MeshBuffers<Device>;
using DeviceAdjacency = AdjacencyBuffers<Device>;

// --- stages ---------------------------------------------------------------------------------------

/// Hash grid of `count` device points (grid/build_grid.hpp): keys, stable radix sort, cell ranges.
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

// --- per-particle stages (grid/build_grid.hpp, field/particle_frames.hpp, transfer/velocity_weights.hpp) ---

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

/// extract_surface() on the device (extract/extract_backend.hpp): march (count, scan, write), then weld
/// by sorting edge keys.
DeviceMesh extract_surface(const DeviceField& field, float iso, Extractor extractor);
/// remove_small_voids() on the device (mesh/voids_backend.hpp); returns the number of voids removed.
std::size_t remove_small_voids(DeviceMesh& mesh, double max_volume);
/// remove_unsupported_blobs() on the device (kernel fields), against the points of `grid`; returns
/// the number of components removed.
std::size_t remove_unsupported_blobs(DeviceMesh& mesh, const DeviceGrid& grid, double max_volume, double min_volume);
/// reorder_vertices_spatially() on the device (mesh/vertex_order_backend.hpp): the same numbering
/// as the CPU.
void reorder_vertices_spatially(DeviceMesh& mesh, float cell);

/// The mesh's adjacency on the device (mesh/adjacency_backend.hpp).
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
/// smooth_surface() on the device (constrained against `grid`; smooth/sweeps_backend.hpp).
SmoothingStats smooth_surface(DeviceMesh& mesh, const DeviceAdjacency& adj, const DeviceGrid& grid, const SmoothSettings& s);

/// erode() on the device (mesh/normals_backend.hpp); returns the flipped triangle count.
std::size_t erode(DeviceMesh& mesh, const DeviceAdjacency& adj, float distance);
/// vertex_normals() on the device (mesh/normals_backend.hpp).
DeviceBuffer<Vec3f> vertex_normals(const DeviceMesh& mesh, const DeviceAdjacency& adj);
/// transfer_attribute() on the device: `values` are the attribute in the original particle
/// order, `components` per particle; returns components per vertex.
DeviceBuffer<float> transfer_attribute(const DeviceBuffer<float>& values, int components, const DeviceGrid& grid,
                                       const DeviceMesh& mesh, float radius);

}  // namespace meniscus::cuda
