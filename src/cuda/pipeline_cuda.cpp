// meniscus — the CUDA backend's pipeline (docs/method.md): one upload, every stage on the device, one
// download. Stage times are device times (CUDA events around each stage's work).
#include <cuda_runtime.h>
#include <fmt/format.h>

#include <cmath>

#include "cuda/pipeline_cuda.hpp"
#include "cuda/stages_cuda.hpp"
#include "extract/field_band.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/messages.hpp"
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
    calls_ = device_calls;
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
    const DeviceCalls& now = device_calls;  // the timer's own wait below is not the stage's
    stats_.device_calls.push_back({name, now.launches - calls_.launches, now.uploads - calls_.uploads,
                                   now.downloads - calls_.downloads, now.device_copies - calls_.device_copies,
                                   now.memsets - calls_.memsets, now.waits - calls_.waits});
    MENISCUS_CUDA_CHECK(cudaEventSynchronize(stop_));
    float ms = 0;
    MENISCUS_CUDA_CHECK(cudaEventElapsedTime(&ms, start_, stop_));
    stats_.stages.push_back({name, double(ms) / 1e3});
    if (progress_) progress_(name, 1.0);
  }
  Stats& stats_;
  const ProgressFn& progress_;
  DeviceCalls calls_;
  cudaEvent_t start_ = nullptr, stop_ = nullptr;
};

void check_fits(double bytes, const char* what) {
  std::size_t free_bytes = 0, total_bytes = 0;
  MENISCUS_CUDA_CHECK(cudaMemGetInfo(&free_bytes, &total_bytes));
  if (bytes > 0.9 * double(free_bytes))
    throw ResourceError(fmt::format("the CUDA device has {} free, {} would need about {}",
                                    human_bytes(double(free_bytes)), what, human_bytes(bytes)));
}

}  // namespace

namespace {

/// The device's stages (pipeline/stages.hpp), each timed with CUDA events, between one upload and
/// one download.
class DeviceStages final : public StageBackend {
 public:
  DeviceStages(const PipelineInput& in, Stats& stats, const ProgressFn& progress)
      : particles_(in.particles), p_(in.params), plan_(in.plan), volumes_(in.volumes), velocity_(in.velocity),
        stats_(stats), timer_(stats, progress) {}

  void timed(const char* name, const std::function<void()>& stage) override { timer_.run(name, stage); }

  void prepare() override {
    check_coordinates_and_memory();
    upload();
  }

  void particles() override { particle_frames(); }
  void grid() override { build_grid(); }
  void field() override { compute_field(); }
  void extract() override { extract_mesh(); }
  void voids() override { stats_.removed_voids = remove_small_voids(mesh_, plan_.void_volume); }

  void blobs() override {
    stats_.removed_blobs = remove_unsupported_blobs(mesh_, grid_, plan_.void_volume, plan_.blob_min_volume);
  }

  /// run_on_device refuses close_handles (a pass of the CPU's) before the device runs.
  void handles() override { throw InvalidParameter("close_handles: not on the CUDA backend"); }

  void reorder() override { reorder_vertices_spatially(mesh_, plan_.lattice.cell_size); }

  void adjacency() override {
    adj_ = timer_.run("adjacency", [&] { return build_adjacency(mesh_); });
  }

  void erode() override { stats_.flipped_triangles = ::meniscus::cuda::erode(mesh_, adj_, plan_.erode_distance); }

  void smooth() override { smooth_mesh(); }
  void transfer() override { transfer_attributes(); }
  void normals() override { normals_ = vertex_normals(mesh_, adj_); }

  void finish(TriangleMesh& out) override { download(out); }

 private:
  /// The grid's coordinate range, checked on the host as the CPU grid does (the positions are read
  /// here anyway to upload them), and the particles' share of the device memory.
  void check_coordinates_and_memory() {
    const std::size_t n = particles_.size();
    if (n >= std::size_t(kNotFound)) throw ResourceError(fmt::format("{} points exceed the 2^32-1 limit", n));
    lo_ = particles_.positions[0], hi_ = lo_;
    for (const Vec3f& q : particles_.positions) lo_ = min(lo_, q), hi_ = max(hi_, q);
    const ParticlePass& pass = plan_.particles;  // the raw particles' grid has its own cell size
    const float smallest_cell = pass.run ? std::min(plan_.grid_cell, pass.raw_cell) : plan_.grid_cell;
    const double limit = double(kMaxCoord) * smallest_cell;
    for (int a = 0; a < 3; ++a)
      if (std::abs(double(lo_[a])) >= limit || std::abs(double(hi_[a])) >= limit)
        throw ResourceError(fmt::format("points reach {:g} on axis {}, more than {} cells of size {:g} from the origin",
                                        std::max(std::abs(double(lo_[a])), std::abs(double(hi_[a]))), "xyz"[a],
                                        kMaxCoord, smallest_cell));
    // Positions and the hash grid; the raw grid and the centres for Yu & Turk; the ellipsoids
    // (36 B, twice while reordered, plus the shells) and volumes of the field methods.
    check_fits(double(n) * (64.0 + (pass.run ? 64.0 : 0.0) + (pass.anisotropic ? 3 * 36.0 : 0.0) +
                            (plan_.kernel_field ? 8.0 : 0.0)),
               "the particles and their hash grid");
  }

  void upload() {
    const std::size_t n = particles_.size();
    attributes_.resize(plan_.transfer.size());
    timer_.run("upload", [&] {
      points_.upload(particles_.positions.data(), n);
      for (std::size_t k = 0; k < plan_.transfer.size(); ++k) {
        const AttributeView* a = particles_.find(plan_.transfer[k]);
        attributes_[k].upload(a->values.data(), a->values.size());
      }
      if (!volumes_.empty()) volumes_device_.upload(volumes_.data(), volumes_.size());
      if (plan_.velocity_weights) velocity_device_.upload(velocity_->values.data(), velocity_->values.size());
    });
  }

  /// Kernel centres: the particles, Laplacian-smoothed when asked (Yu & Turk §5), and the
  /// anisotropic ellipsoids, both from a grid of the raw particles (as the CPU's stages).
  void particle_frames() {
    const ParticlePass& pass = plan_.particles;
    const uint32_t n = uint32_t(particles_.size());
    const DeviceGrid raw =
        ::meniscus::cuda::build_grid(points_, n, pass.raw_cell, grid_cell_of(lo_, pass.raw_cell), grid_cell_of(hi_, pass.raw_cell));
    DeviceBuffer<Vec3f> centres;
    ::meniscus::cuda::particle_frames(raw, pass.pca_radius, pass.constants, pass.smooth_radius, pass.lambda,
                                      pass.lambda > 0 ? &centres : nullptr, pass.anisotropic ? &ellipsoids_ : nullptr,
                                      pass.centre_reach);
    if (pass.lambda > 0) {
      points_ = std::move(centres);
      point_bounds(points_, n, &lo_, &hi_);  // within the particles' bounds up to rounding
    }
  }

  void build_grid() {
    const float cell = plan_.grid_cell;
    grid_ = ::meniscus::cuda::build_grid(points_, uint32_t(particles_.size()), cell, grid_cell_of(lo_, cell),
                                         grid_cell_of(hi_, cell));
    if (plan_.particles.anisotropic) ellipsoids_ = to_sorted_order(grid_, ellipsoids_);
    if (plan_.ellipsoid_shells) {  // the constraint shells, which the field's inside includes too
      shells_ = unit_volume_shells(ellipsoids_);
      shell_axis_ = max_ellipsoid_axis(shells_, uint32_t(particles_.size()));
    }
    if (!volumes_.empty()) volumes_device_ = to_sorted_order(grid_, volumes_device_);
    points_ = {};
  }

  void compute_field() {
    const double d = p_.spacing;
    KernelParticles k;
    k.method = plan_.field;
    k.radius = float(p_.kernel_radius);
    k.volumes = volumes_device_.size() > 0 ? volumes_device_.data() : nullptr;
    k.uniform_volume = float(d * d * d);
    k.ellipsoids = plan_.particles.anisotropic ? ellipsoids_.data() : nullptr;
    k.shells = plan_.ellipsoid_shells ? shells_.data() : nullptr;
    k.shell_radius = plan_.r_outer;
    const float support = kernel_field_support(
        plan_.field, k.radius,
        plan_.particles.anisotropic ? max_ellipsoid_axis(ellipsoids_, uint32_t(particles_.size())) : 0.0f,
        plan_.ellipsoid_shells ? shell_reach(plan_.r_outer, shell_axis_) : 0.0f);
    const float band = plan_.kernel_field ? support + float(p_.voxel_size) : plan_.distance_band;
    field_ = [&] {
      std::size_t blocks = 0;
      DeviceBuffer<uint64_t> keys = band_blocks(grid_, plan_.lattice, band, &blocks);
      // Field values, masks, the marching counts of the blocks and their ghosts, the corners.
      const double cells = double(kBlockSamples / plan_.lattice.samples_per_cell());
      const double bytes = double(blocks) * (kBlockSamples * 4.0 + 8.0 + cells * (1.0 + 2.0 * 16.0));
      if (bytes > p_.max_memory_gb * 1e9)
        throw ResourceError(fmt::format("the {} field would need about {} ({} blocks), more than the {} allowed; use "
                                        "a larger {} or raise {}",
                                        to_string(plan_.field), human_bytes(bytes), blocks,
                                        human_bytes(p_.max_memory_gb * 1e9), spelled("voxel_size"),
                                        spelled("max_memory_gb")));
      check_fits(bytes, "the field and the extraction");
      if (!plan_.kernel_field) return distance_field(grid_, plan_.lattice, band, std::move(keys), blocks);
      const float iso = float(p_.iso);
      return kernel_field(grid_, plan_.lattice, k, support, iso, kernel_field_background(plan_.field, k.radius, iso),
                          std::move(keys), blocks);
    }();
    stats_.field_blocks = field_.blocks;
  }

  void extract_mesh() {
    mesh_ = extract_surface(field_, plan_.iso, plan_.extractor);
    field_ = DeviceField();
    stats_.dropped_triangles = 0;
  }

  void smooth_mesh() {
    SmoothSettings s;
    DeviceBuffer<float> weights;
    if (plan_.velocity_weights && p_.velocity_reference > 0) {
      const DeviceBuffer<float> v = transfer_attribute(velocity_device_, 3, grid_, mesh_, plan_.transfer_radius);
      weights = velocity_weights(v, mesh_.vertex_count, float(p_.velocity_reference), float(p_.velocity_min_weight));
      s.vertex_relax = weights.data();
    }
    if (plan_.ellipsoid_shells) {
      s.shells = shells_.data();
      s.max_axis = shell_axis_;
    }
    static_cast<SmoothSchedule&>(s) = plan_.schedule;
    s.r_inner = plan_.r_inner;
    s.r_outer = plan_.r_outer;
    stats_.smoothing = smooth_surface(mesh_, adj_, grid_, s);
  }

  void transfer_attributes() {
    for (std::size_t k = 0; k < plan_.transfer.size(); ++k)
      transferred_.push_back(transfer_attribute(attributes_[k], particles_.find(plan_.transfer[k])->components, grid_,
                                                mesh_, plan_.transfer_radius));
  }

  void download(TriangleMesh& out) {
    timer_.run("download", [&] {
      out.vertices.resize(mesh_.vertex_count);
      mesh_.vertices.download(out.vertices.data(), mesh_.vertex_count);
      out.triangles.resize(mesh_.triangle_count);
      mesh_.triangles.download(out.triangles.data()->data(), 3 * mesh_.triangle_count);
      out.normals.resize(mesh_.vertex_count);
      normals_.download(out.normals.data(), mesh_.vertex_count);
      for (std::size_t k = 0; k < plan_.transfer.size(); ++k) {
        const AttributeView* a = particles_.find(plan_.transfer[k]);
        Attribute attribute;
        attribute.name = a->name;
        attribute.components = a->components;
        attribute.values.resize(transferred_[k].size());
        transferred_[k].download(attribute.values.data(), attribute.values.size());
        out.attributes.push_back(std::move(attribute));
      }
    });
  }

  const ParticlesView& particles_;
  const Params& p_;
  const StagePlan& plan_;
  const std::vector<float>& volumes_;
  const AttributeView* velocity_;
  Stats& stats_;
  EventTimer timer_;
  Vec3f lo_{}, hi_{};
  DeviceBuffer<Vec3f> points_;
  std::vector<DeviceBuffer<float>> attributes_, transferred_;
  DeviceBuffer<float> volumes_device_, velocity_device_;
  DeviceBuffer<Ellipsoid> ellipsoids_;  // original order, then the grid's
  DeviceBuffer<Ellipsoid> shells_;      // the constraint shells, the grid's order
  float shell_axis_ = 0;                // their longest axis
  DeviceGrid grid_;
  DeviceField field_;
  DeviceMesh mesh_;
  DeviceAdjacency adj_;
  DeviceBuffer<Vec3f> normals_;
};

}  // namespace

std::unique_ptr<StageBackend> make_device_stages(const PipelineInput& in, Stats& stats, const ProgressFn& progress) {
  MENISCUS_CUDA_CHECK(cudaSetDevice(0));
  return std::make_unique<DeviceStages>(in, stats, progress);
}

}  // namespace meniscus::cuda
