// meniscus — the CPU's stages (stages.hpp): each a call of the stage's functions over the host's
// arrays, in the order the driver gives; the state between stages (grid, field, mesh) lives here.
#include <algorithm>
#include <optional>
#include <span>

#include "extract/extract.hpp"
#include "field/anisotropy.hpp"
#include "field/distance_field.hpp"
#include "field/kernel_field.hpp"
#include "field/kernel_impl.hpp"
#include "grid/hash_grid.hpp"
#include "system/memory_scope.hpp"
#include "mesh/vertex_order.hpp"
#include "mesh/handles.hpp"
#include "mesh/voids.hpp"
#include "pipeline/internal.hpp"
#include "pipeline/stages.hpp"
#include "smooth/smooth.hpp"
#include "transfer/attribute_transfer.hpp"
#include "mesh/normals.hpp"
#include "transfer/velocity_weight_impl.hpp"

namespace meniscus {

namespace {

/// Per-vertex damping factors of the velocity weighting (velocity_weight_impl.hpp).
std::vector<float> velocity_weights(const AttributeView& velocity, const HashGrid& grid, std::span<const Vec3f> vertices,
                                    const Params& p) {
  std::vector<float> w(vertices.size(), 1.0f);
  if (!(p.velocity_reference > 0)) return w;  // nothing moves: smooth everywhere
  const Attribute v = transfer_attribute(velocity, grid, vertices, float(p.transfer_radius));
  for (std::size_t i = 0; i < w.size(); ++i)
    w[i] = velocity_weight(Vec3f{v.values[3 * i], v.values[3 * i + 1], v.values[3 * i + 2]},
                           float(p.velocity_reference), float(p.velocity_min_weight));
  return w;
}

class CpuStages final : public StageBackend {
 public:
  CpuStages(const PipelineInput& in, Stats& stats, const ProgressFn& progress)
      : particles_(in.particles), p_(in.params), plan_(in.plan), volumes_(in.volumes), velocity_(in.velocity),
        order_keys_(in.order_keys), coincident_(in.coincident), stats_(stats), progress_(progress),
        timer_(stats, progress) {}

  void timed(const char* name, const std::function<void()>& stage) override { timer_.run(name, stage); }

  /// Kernel centres: the particles, Laplacian-smoothed when asked (Yu & Turk §5), and the
  /// anisotropic ellipsoids, each centre held close enough to keep its particle inside its shell;
  /// the constraints use the centres too.
  void particles() override {
    const ParticlePass& pass = plan_.particles;
    const HashGrid raw(particles_.positions, pass.raw_cell);
    if (pass.anisotropic) ellipsoids_ = yu_turk_ellipsoids(raw, pass.pca_radius, pass.constants, coincident_);
    if (!(pass.lambda > 0)) {
      centres_.assign(particles_.positions.begin(), particles_.positions.end());
      return;
    }
    centres_ = smooth_positions(raw, pass.smooth_radius, pass.lambda, coincident_);
    if (pass.anisotropic) hold_particles_in_shells(particles_.positions, ellipsoids_, pass.centre_reach, centres_);
  }

  void grid() override {
    const std::span<const Vec3f> positions =
        centres_.empty() ? std::span<const Vec3f>(particles_.positions) : std::span<const Vec3f>(centres_);
    grid_.emplace(positions, plan_.grid_cell);
    sorted_ellipsoids_ = to_sorted_order(*grid_, ellipsoids_);
    if (plan_.ellipsoid_shells) {  // the constraint shells, which the field's inside includes too
      shells_.resize(sorted_ellipsoids_.size());
      for (std::size_t i = 0; i < shells_.size(); ++i) {
        shells_[i] = unit_volume_shell(sorted_ellipsoids_[i]);
        shell_axis_ = std::max(shell_axis_, shells_[i].max_axis);
      }
    }
    if (!coincident_.empty()) build_sites(positions);
  }

  /// The grid of the sites: the first particle at each position (their centres and ellipsoids are
  /// their copies' too: the particle pass computed them once). Its sorted order is the main grid's
  /// without the copies (both sorted by cell, then by index), so a nearest query gives the same
  /// particle, ties included: the constraints, the distance field and the blob test, which never
  /// need a copy, read it — each query costs what it costs without the pile.
  void build_sites(std::span<const Vec3f> positions) {
    std::vector<uint32_t> heads;
    for (std::size_t i = 0; i < coincident_.size(); ++i)
      if (coincident_[i] == i) heads.push_back(uint32_t(i));
    std::vector<Vec3f> at(heads.size());
    for (std::size_t k = 0; k < heads.size(); ++k) at[k] = positions[heads[k]];
    sites_.emplace(at, plan_.grid_cell);
    if (plan_.ellipsoid_shells) {
      const auto order = sites_->order();
      site_shells_.resize(heads.size());
      for (std::size_t k = 0; k < heads.size(); ++k) site_shells_[k] = unit_volume_shell(ellipsoids_[heads[order[k]]]);
    }
  }
  /// The grid the queries that need no copy read, and its shells.
  const HashGrid& sites() const { return sites_ ? *sites_ : *grid_; }
  std::span<const Ellipsoid> site_shells() const { return sites_ ? site_shells_ : shells_; }

  void field() override {
    const double max_bytes = p_.max_memory_gb * 1e9;
    if (!plan_.kernel_field) {
      // A minimum over the particles: the sites give the same field (grid_'s cells, the same blocks).
      field_.emplace(distance_field(sites(), plan_.lattice, plan_.distance_band,
                                    checked_band_blocks(*grid_, plan_.lattice, plan_.distance_band, max_bytes, p_,
                                                        stats_.max_memory_from)));
    } else {
      const double d = p_.spacing;
      KernelFieldInput in;
      in.centres = &*grid_;
      in.method = plan_.field;
      in.kernel_radius = float(p_.kernel_radius);
      in.iso = float(p_.iso);
      in.uniform_volume = float(d * d * d);
      const std::vector<float> sorted_volumes = to_sorted_order(*grid_, volumes_);
      in.volumes = sorted_volumes;
      in.ellipsoids = sorted_ellipsoids_;
      in.shells = shells_;
      in.shell_radius = plan_.r_outer;
      const float band = kernel_support(in) + float(p_.voxel_size);
      field_.emplace(kernel_field(in, plan_.lattice,
                                  checked_band_blocks(*grid_, plan_.lattice, band, max_bytes, p_, stats_.max_memory_from)));
    }
    stats_.field_blocks = field_->block_count();
  }

  void extract() override {
    ExtractResult extracted = extract_surface(*field_, plan_.iso, plan_.extractor, order_keys_);
    field_.reset();
    stats_.dropped_triangles = extracted.dropped_triangles;
    mesh_ = std::move(extracted.mesh);
    // The order keys ride with their vertices from here on; the Z-order code is the reorder's,
    // of these (extracted) positions, which the voids and blobs do not move.
    if (order_keys_)
      mesh_.attributes.push_back(order_key_attribute(mesh_.vertices, extracted.vertex_keys,
                                                     plan_.sweeps ? float(plan_.lattice.cell_size) : 0.0f));
  }

  void voids() override { stats_.removed_voids = remove_small_voids(mesh_, plan_.void_volume); }

  void blobs() override {
    stats_.removed_blobs = remove_unsupported_blobs(mesh_, sites(), plan_.void_volume, plan_.blob_min_volume);
  }

  void handles() override {
    HandleSettings settings;
    settings.water_distance = plan_.r_outer;
    stats_.closed_handles = cut_small_handles(mesh_, settings, sites());
  }

  /// The extraction numbers vertices in edge-key (row-major) order; the sweeps run several times
  /// faster on a Z-ordered mesh, where a vertex's ring and particle list sit near it in memory.
  void reorder() override {
    reuse_.end();  // the reordered mesh, which lives through the smoothing, gets its own mappings
    reorder_vertices_spatially(mesh_, plan_.lattice.cell_size);
    reuse_.end();  // and the heap gives back the old mesh the reorder freed
  }

  void smooth() override {
    SmoothOptions o;
    static_cast<SmoothSchedule&>(o) = plan_.schedule;
    std::vector<float> weights;
    if (plan_.velocity_weights) {
      weights = velocity_weights(*velocity_, *grid_, mesh_.vertices, p_);
      o.vertex_relax = weights;
    }
    // The particles' original indices serve only the attribute transfer from here on: without
    // one, 4 bytes a particle less through the sweeps.
    if (plan_.transfer.empty()) grid_->release_order();
    const auto tick = [&](double f) {
      if (progress_) progress_("smooth", f);
    };
    if (plan_.ellipsoid_shells) {
      const EllipsoidConstraint constraint{&sites(), site_shells(), plan_.r_inner, plan_.r_outer, shell_axis_};
      stats_.smoothing = smooth_surface(mesh_.vertices, mesh_.triangles, &constraint, o, tick);
    } else {
      const ShellConstraint constraint{&sites(), plan_.r_inner, plan_.r_outer};
      stats_.smoothing = smooth_surface(mesh_.vertices, mesh_.triangles, &constraint, o, tick);
    }
  }

  void erode() override {
    stats_.flipped_triangles = ::meniscus::erode(mesh_.vertices, mesh_.triangles, plan_.erode_distance);
  }

  void transfer() override {
    for (const std::string& name : plan_.transfer)
      mesh_.attributes.push_back(transfer_attribute(*particles_.find(name), *grid_, mesh_.vertices, plan_.transfer_radius));
  }

  void normals() override { mesh_.normals = vertex_normals(mesh_.vertices, mesh_.triangles); }

  void finish(TriangleMesh& mesh) override { mesh = std::move(mesh_); }

 private:
  const ParticlesView& particles_;
  const Params& p_;
  const StagePlan& plan_;
  const std::vector<float>& volumes_;
  const AttributeView* velocity_;
  const bool order_keys_;
  std::span<const uint32_t> coincident_;  // per particle, the first at its position (empty: none)
  Stats& stats_;
  const ProgressFn& progress_;
  StageTimer timer_;
  HeapReuseScope reuse_;  // up to the smoothing, where the CLI asks for it (meniscus/memory.hpp)
  std::vector<Vec3f> centres_;
  std::vector<Ellipsoid> ellipsoids_, sorted_ellipsoids_;  // original order; the grid's
  std::vector<Ellipsoid> shells_;                         // the constraint shells, the grid's order
  float shell_axis_ = 0;                                  // their longest axis
  std::optional<HashGrid> grid_;
  std::optional<HashGrid> sites_;      // the first particle at each position, when any is copied
  std::vector<Ellipsoid> site_shells_;  // their constraint shells, in sites_' order
  std::optional<SparseField> field_;
  TriangleMesh mesh_;
};

}  // namespace

std::unique_ptr<StageBackend> make_cpu_stages(const PipelineInput& in, Stats& stats, const ProgressFn& progress) {
  return std::make_unique<CpuStages>(in, stats, progress);
}

}  // namespace meniscus
