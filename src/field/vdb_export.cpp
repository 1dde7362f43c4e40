// meniscus — the distance field as an OpenVDB level set (Museth 2013), for Houdini and Blender.
#include <openvdb/openvdb.h>

#include <filesystem>
#include <fmt/format.h>
#include <random>
#include <unistd.h>

#include "field/distance_field.hpp"
#include "field/vdb_export.hpp"
#include "meniscus/errors.hpp"

namespace meniscus {

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

  // Written beside the target and renamed, like every other output.
  const std::filesystem::path target(path);
  std::mt19937_64 rng{std::random_device{}()};
  const std::filesystem::path temp =
      target.parent_path() / fmt::format(".{}.tmp-{}-{:x}", target.filename().string(), getpid(), rng());
  try {
    openvdb::io::File file(temp.string());
    file.write(openvdb::GridPtrVec{vdb});
    file.close();
    std::filesystem::rename(temp, target);
  } catch (const std::exception& e) {
    std::error_code ec;
    std::filesystem::remove(temp, ec);
    throw IoError(fmt::format("{}: cannot write the field: {}", path, e.what()));
  }
}

}  // namespace meniscus
