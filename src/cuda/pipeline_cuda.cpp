// meniscus — the CUDA backend's pipeline (DESIGN §1): one upload, every stage on the device, one
// download. Stage times are device times (CUDA events around each stage's work).
#include <cuda_runtime.h>
#include <fmt/format.h>

#include <cmath>

#include "cuda/pipeline_cuda.hpp"
#include "cuda/stages_cuda.hpp"
#include "extract/field_band.hpp"
#include "meniscus/errors.hpp"
#include "mesh/voids.hpp"

namespace meniscus::cuda {

namespace {

/// Records each stage's device time with a pair of CUDA events.
class EventTimer {
 public:
  EventTimer(Stats& stats, const ProgressFn& progress) : stats_(stats), progress_(progress) {
    MENISCUS_CUDA_CHECK(cudaEventCreate(&start_));
    MENISCUS_CUDA_CHECK(cudaEventCreate(&stop_));
  }
  ~EventTimer() {
    cudaEventDestroy(start_);
    cudaEventDestroy(stop_);
  }
  EventTimer(const EventTimer&) = delete;
  EventTimer& operator=(const EventTimer&) = delete;

  template <class F>
  auto run(const char* name, F&& f) {
    if (progress_) progress_(name, 0.0);
    MENISCUS_CUDA_CHECK(cudaEventRecord(start_));
    if constexpr (std::is_void_v<decltype(f())>) {
      f();
      finish(name);
    } else {
      auto result = f();
      finish(name);
      return result;
    }
  }

 private:
  void finish(const char* name) {
    MENISCUS_CUDA_CHECK(cudaEventRecord(stop_));
    MENISCUS_CUDA_CHECK(cudaEventSynchronize(stop_));
    float ms = 0;
    MENISCUS_CUDA_CHECK(cudaEventElapsedTime(&ms, start_, stop_));
    stats_.stages.push_back({name, double(ms) / 1e3});
    if (progress_) progress_(name, 1.0);
  }
  Stats& stats_;
  const ProgressFn& progress_;
  cudaEvent_t start_ = nullptr, stop_ = nullptr;
};

void check_fits(double bytes, const char* what) {
  std::size_t free_bytes = 0, total_bytes = 0;
  MENISCUS_CUDA_CHECK(cudaMemGetInfo(&free_bytes, &total_bytes));
  if (bytes > 0.9 * double(free_bytes))
    throw ResourceError(fmt::format("the CUDA device has {:.2f} GB free, {} would need about {:.2f} GB",
                                    double(free_bytes) / 1e9, what, bytes / 1e9));
}

}  // namespace

void reconstruct(const ParticleSet& particles, const Params& p, const std::vector<float>& volumes,
                 const Attribute* velocity, Stats& stats, TriangleMesh& mesh, const ProgressFn& progress) {
  MENISCUS_CUDA_CHECK(cudaSetDevice(0));
  const std::size_t n = particles.size();
  if (n >= std::size_t(kNotFound)) throw ResourceError(fmt::format("{} points exceed the 2^32-1 limit", n));
  const float r_outer = float(p.r_outer), r_inner = float(p.r_inner), h = float(p.voxel_size);
  const float cell_size = 2 * r_outer;
  const double d = p.spacing;
  const bool anisotropic = p.field == FieldMethod::anisotropic;
  const bool kernel = p.field != FieldMethod::distance;

  // The grid's coordinate range, checked on the host as the CPU grid does (the positions are
  // read here anyway to upload them).
  Vec3f lo = particles.positions[0], hi = lo;
  for (const Vec3f& q : particles.positions) lo = min(lo, q), hi = max(hi, q);
  // (The grid of the raw particles for Yu & Turk has its own cell size, as on the CPU.)
  const ParticlePass pass = particle_pass(p);
  const float smallest_cell = pass.run ? std::min(cell_size, pass.raw_cell) : cell_size;
  const double limit = double(kMaxCoord) * smallest_cell;
  for (int a = 0; a < 3; ++a)
    if (std::abs(double(lo[a])) >= limit || std::abs(double(hi[a])) >= limit)
      throw ResourceError(fmt::format("points reach {:g} on axis {}, more than {} cells of size {:g} from the origin",
                                      std::max(std::abs(double(lo[a])), std::abs(double(hi[a]))), "xyz"[a], kMaxCoord,
                                      smallest_cell));
  // Positions and the hash grid; the raw grid and the centres for Yu & Turk; the ellipsoids (36 B,
  // twice while reordered, plus the shells) and volumes of the field methods.
  check_fits(double(n) * (64.0 + (pass.run ? 64.0 : 0.0) + (anisotropic ? 3 * 36.0 : 0.0) + (kernel ? 8.0 : 0.0)),
             "the particles and their hash grid");

  EventTimer timer(stats, progress);
  DeviceBuffer<Vec3f> points;
  std::vector<DeviceBuffer<float>> attributes(p.transfer.size());
  DeviceBuffer<float> device_volumes, device_velocity;
  timer.run("upload", [&] {
    points.upload(particles.positions.data(), n);
    for (std::size_t k = 0; k < p.transfer.size(); ++k) {
      const Attribute* a = particles.find(p.transfer[k]);
      attributes[k].upload(a->values.data(), a->values.size());
    }
    if (!volumes.empty()) device_volumes.upload(volumes.data(), volumes.size());
    if (p.velocity_weighted) device_velocity.upload(velocity->values.data(), velocity->values.size());
  });

  // Kernel centres: the particles, Laplacian-smoothed when asked (Yu & Turk §5), and the
  // anisotropic ellipsoids, both from a grid of the raw particles (as pipeline.cpp).
  DeviceBuffer<Ellipsoid> ellipsoids;  // original order, then the grid's
  if (pass.run)
    timer.run("particles", [&] {
      const DeviceGrid raw =
          build_grid(points, uint32_t(n), pass.raw_cell, grid_cell_of(lo, pass.raw_cell), grid_cell_of(hi, pass.raw_cell));
      DeviceBuffer<Vec3f> centres;
      particle_frames(raw, pass.pca_radius, pass.constants, pass.smooth_radius, pass.lambda,
                      pass.lambda > 0 ? &centres : nullptr, anisotropic ? &ellipsoids : nullptr);
      if (pass.lambda > 0) {
        points = std::move(centres);
        point_bounds(points, uint32_t(n), &lo, &hi);  // within the particles' bounds up to rounding
      }
    });
  const DeviceGrid grid = timer.run("grid", [&] {
    DeviceGrid g = build_grid(points, uint32_t(n), cell_size, grid_cell_of(lo, cell_size), grid_cell_of(hi, cell_size));
    if (anisotropic) ellipsoids = to_sorted_order(g, ellipsoids);
    if (!volumes.empty()) device_volumes = to_sorted_order(g, device_volumes);
    return g;
  });
  points = {};

  SampleLattice lattice;
  lattice.kind = p.extract == Extractor::tiles ? SampleLattice::Kind::a15 : SampleLattice::Kind::cubic;
  lattice.cell_size = float(p.extract == Extractor::tiles ? 2 * h : h);

  DeviceMesh dmesh = [&] {
    KernelParticles k;
    k.method = p.field;
    k.radius = float(p.kernel_radius);
    k.volumes = device_volumes.size() > 0 ? device_volumes.data() : nullptr;
    k.uniform_volume = float(d * d * d);
    k.ellipsoids = anisotropic ? ellipsoids.data() : nullptr;
    const float support =
        kernel_field_support(p.field, k.radius, anisotropic ? max_ellipsoid_axis(ellipsoids, uint32_t(n)) : 0.0f);
    const float band = kernel ? support + h : field_band(p);
    const DeviceField field = timer.run("field", [&] {
      std::size_t blocks = 0;
      DeviceBuffer<uint64_t> keys = band_blocks(grid, lattice, band, &blocks);
      // Field values, masks, the marching counts of the blocks and their ghosts, the corners.
      const double cells = double(kBlockSamples / lattice.samples_per_cell());
      const double bytes = double(blocks) * (kBlockSamples * 4.0 + 8.0 + cells * (1.0 + 2.0 * 16.0));
      if (bytes > p.max_memory_gb * 1e9)
        throw ResourceError(fmt::format("the {} field would need about {:.1f} GB ({} blocks), more than the "
                                        "{:.1f} GB allowed; use a larger --voxel-size or raise --max-memory",
                                        to_string(p.field), bytes / 1e9, blocks, p.max_memory_gb));
      check_fits(bytes, "the field and the extraction");
      if (!kernel) return distance_field(grid, lattice, band, std::move(keys), blocks);
      const float iso = float(p.iso);
      return kernel_field(grid, lattice, k, support, iso, kernel_field_background(p.field, k.radius, iso),
                          std::move(keys), blocks);
    });
    stats.field_blocks = field.blocks;
    return timer.run("extract", [&] { return extract_surface(field, kernel ? 0.0f : r_outer, p.extract); });
  }();
  stats.dropped_triangles = 0;
  if (!p.keep_voids)
    stats.removed_voids = timer.run("voids", [&] { return remove_small_voids(dmesh, small_component_volume(d)); });
  // As on the CPU: a kernel field's blobs the smoothing cannot hold (mesh/voids.hpp).
  if (kernel)
    stats.removed_blobs = timer.run("blobs", [&] {
      return remove_unsupported_blobs(dmesh, grid, small_component_volume(d), inner_ball_volume(p.r_inner));
    });
  if (p.steps_a + p.steps_b + p.steps_free > 0) timer.run("reorder", [&] { reorder_vertices_spatially(dmesh); });

  const DeviceAdjacency adj = timer.run("adjacency", [&] { return build_adjacency(dmesh); });
  timer.run("smooth", [&] {
    SmoothSettings s;
    DeviceBuffer<float> weights;
    DeviceBuffer<Ellipsoid> shell_ellipsoids;
    if (p.velocity_weighted && p.velocity_reference > 0) {
      const DeviceBuffer<float> v = transfer_attribute(device_velocity, 3, grid, dmesh, float(p.transfer_radius));
      weights = velocity_weights(v, dmesh.vertex_count, float(p.velocity_reference), float(p.velocity_min_weight));
      s.vertex_relax = weights.data();
    }
    if (anisotropic) {
      shell_ellipsoids = unit_volume_shells(ellipsoids);
      s.shells = shell_ellipsoids.data();
      s.max_axis = max_ellipsoid_axis(shell_ellipsoids, uint32_t(n));
    }
    static_cast<SmoothSchedule&>(s) = smooth_schedule(p);
    s.r_inner = r_inner;
    s.r_outer = r_outer;
    stats.smoothing = smooth_surface(dmesh, adj, grid, s);
  });
  if (p.erode > 0) stats.flipped_triangles = timer.run("erode", [&] { return erode(dmesh, adj, float(p.erode)); });
  std::vector<DeviceBuffer<float>> transferred;
  if (!p.transfer.empty())
    timer.run("transfer", [&] {
      for (std::size_t k = 0; k < p.transfer.size(); ++k)
        transferred.push_back(transfer_attribute(attributes[k], particles.find(p.transfer[k])->components, grid, dmesh,
                                                 float(p.transfer_radius)));
    });
  const DeviceBuffer<Vec3f> normals = timer.run("normals", [&] { return vertex_normals(dmesh, adj); });

  timer.run("download", [&] {
    mesh.vertices.resize(dmesh.vertex_count);
    dmesh.vertices.download(mesh.vertices.data(), dmesh.vertex_count);
    mesh.triangles.resize(dmesh.triangle_count);
    dmesh.triangles.download(mesh.triangles.data()->data(), 3 * dmesh.triangle_count);
    mesh.normals.resize(dmesh.vertex_count);
    normals.download(mesh.normals.data(), dmesh.vertex_count);
    for (std::size_t k = 0; k < p.transfer.size(); ++k) {
      const Attribute* a = particles.find(p.transfer[k]);
      Attribute out;
      out.name = a->name;
      out.components = a->components;
      out.values.resize(transferred[k].size());
      transferred[k].download(out.values.data(), out.values.size());
      mesh.attributes.push_back(std::move(out));
    }
  });
  stats.vertices = mesh.vertices.size();
  stats.triangles = mesh.triangles.size();
}

}  // namespace meniscus::cuda
