// meniscus — the distance field as an OpenVDB level set (Museth 2013), for Houdini and Blender.
#include <openvdb/openvdb.h>

#include <fmt/format.h>
#include <sstream>

#include "field/distance_field.hpp"
#include "io/vdb_export.hpp"
#include "io/atomic_file.hpp"
#include "meniscus/errors.hpp"

namespace meniscus {

namespace {

/// openvdb::io::File's layout on any seekable stream: File itself writes only to a path, through
/// an std::ofstream whose failures (a full disk) it does not report.
class SeekableArchive : public openvdb::io::Archive {
 public:
  void write_to(std::ostream& out, const openvdb::GridPtrVec& grids) const {
    Archive::write(out, grids, /*seekable=*/true, openvdb::MetaMap());
  }
};

}  // namespace

bool has_openvdb() { return true; }

void write_field_vdb(const std::string& path, const ParticleSet& particles, const Params& p) {
  if (!(p.spacing > 0 && p.voxel_size > 0 && p.r_outer > 0))
    throw InvalidParameter("write_field_vdb needs resolved parameters (see resolve_params)");
  const float h = float(p.voxel_size), r_outer = float(p.r_outer);
  const float band = r_outer + 2 * h;
  const HashGrid grid(particles.positions, 2 * r_outer);
  const SampleLattice lattice{SampleLattice::Kind::cubic, h};
  const SparseField field = distance_field(grid, lattice, band, band_blocks(grid, lattice, band));

  openvdb::initialize();
  // Signed distance to the union-of-spheres surface φ = r_outer: negative inside the fluid.
  openvdb::FloatGrid::Ptr vdb = openvdb::FloatGrid::create(band - r_outer);
  vdb->setTransform(openvdb::math::Transform::createLinearTransform(double(h)));
  vdb->setGridClass(openvdb::GRID_LEVEL_SET);
  vdb->setName("surface");
  auto accessor = vdb->getAccessor();
  const int n = lattice.block_cells();
  for (std::size_t b = 0; b < field.block_count(); ++b) {
    const Vec3i o = field.block_origin(b);
    const auto values = field.block_values(b);
    for (int z = 0; z < n; ++z)
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          const float phi = values[std::size_t(field.local_index({x, y, z}, 0))];
          if (phi >= band) continue;  // outside the band: background
          accessor.setValue(openvdb::Coord(o.x + x, o.y + y, o.z + z), phi - r_outer);
        }
  }
  vdb->insertMeta("meniscus_r_outer", openvdb::FloatMetadata(r_outer));
  vdb->insertMeta("meniscus_spacing", openvdb::FloatMetadata(float(p.spacing)));

  // Through the one atomic writer, like every other output: the archive is laid out in memory
  // exactly as openvdb::io::File lays out a file (a seekable stream, so the grid offsets are
  // written), then written, synced and renamed, and every failure is reported.
  std::stringstream bytes(std::ios::in | std::ios::out | std::ios::binary);
  SeekableArchive().write_to(bytes, openvdb::GridPtrVec{vdb});
  if (!bytes) throw IoError(fmt::format("{}: cannot write the field: the archive could not be encoded", path));
  const std::string data = std::move(bytes).str();
  io::AtomicFile file(path);
  file.write(data);
  file.commit();
}

}  // namespace meniscus
