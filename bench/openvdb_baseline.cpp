// meniscus bench — OpenVDB baseline: level set from particles, optional curvature filtering,
// uniform (adaptivity 0) dual-contouring-style meshing, each stage timed separately.
#include "openvdb_baseline.hpp"

#include <openvdb/openvdb.h>
#include <openvdb/tools/LevelSetFilter.h>
#include <openvdb/tools/ParticlesToLevelSet.h>
#include <openvdb/tools/VolumeToMesh.h>

#include <chrono>
#include <mutex>

#include "common/clock.hpp"
#include "memory.hpp"

namespace meniscus::bench {
namespace {

// The particle-list concept ParticlesToLevelSet expects: positions in world space; the radius
// passed to getPosRad is only used by the per-particle-radius overload, which we do not call.
class ParticleList {
 public:
  using PosType = openvdb::Vec3R;
  ParticleList(std::span<const Vec3f> p, double radius) : p_(p), radius_(radius) {}
  std::size_t size() const { return p_.size(); }
  void getPos(std::size_t n, openvdb::Vec3R& xyz) const { xyz = openvdb::Vec3R(p_[n].x, p_[n].y, p_[n].z); }
  void getPosRad(std::size_t n, openvdb::Vec3R& xyz, openvdb::Real& r) const {
    getPos(n, xyz);
    r = radius_;
  }

 private:
  std::span<const Vec3f> p_;
  double radius_;
};

}  // namespace

VdbResult run_openvdb(std::span<const Vec3f> particles, const VdbOptions& o) {
  static std::once_flag init;
  std::call_once(init, [] { openvdb::initialize(); });
  VdbResult r;
  const std::size_t base = begin_peak_measurement();

  auto t0 = std::chrono::steady_clock::now();
  openvdb::FloatGrid::Ptr grid = openvdb::createLevelSet<openvdb::FloatGrid>(o.voxel_size, o.half_width);
  {
    openvdb::tools::ParticlesToLevelSet<openvdb::FloatGrid> raster(*grid);
    const ParticleList list(particles, o.radius);
    raster.rasterizeSpheres(list, o.radius);
    // prune: what the Houdini SOP does, and it makes the interior a constant tile.
    raster.finalize(/*prune=*/true);
  }
  r.rasterize_seconds = seconds_since(t0);
  r.active_voxels = std::size_t(grid->activeVoxelCount());

  t0 = std::chrono::steady_clock::now();
  if (o.filter_passes > 0) {
    openvdb::tools::LevelSetFilter<openvdb::FloatGrid> filter(*grid);
    for (int i = 0; i < o.filter_passes; ++i) filter.meanCurvature();
  }
  r.filter_seconds = seconds_since(t0);

  t0 = std::chrono::steady_clock::now();
  std::vector<openvdb::Vec3s> points;
  std::vector<openvdb::Vec4I> quads;
  openvdb::tools::volumeToMesh(*grid, points, quads, /*isovalue=*/0.0);
  // Conversion to our mesh counts as meshing: a caller needs triangles either way.
  r.mesh.vertices.resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) r.mesh.vertices[i] = {points[i].x(), points[i].y(), points[i].z()};
  r.mesh.triangles.reserve(quads.size() * 2);
  for (const openvdb::Vec4I& q : quads) {
    const Triangle a{q[0], q[1], q[2]}, b{q[0], q[2], q[3]}, c{q[0], q[1], q[3]}, d{q[1], q[2], q[3]};
    // Split along the shorter diagonal: the better-shaped pair, so the angle metric is fair.
    const auto& v = r.mesh.vertices;
    if (length2(v[q[0]] - v[q[2]]) <= length2(v[q[1]] - v[q[3]])) {
      r.mesh.triangles.push_back(a), r.mesh.triangles.push_back(b);
    } else {
      r.mesh.triangles.push_back(c), r.mesh.triangles.push_back(d);
    }
  }
  r.quads = quads.size();
  r.mesh_seconds = seconds_since(t0);
  r.peak_delta_bytes = peak_delta_bytes(base);
  return r;
}

}  // namespace meniscus::bench
