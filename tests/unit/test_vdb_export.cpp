// Tests of the .vdb level-set export (read back with OpenVDB itself).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "io/vdb_export.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/reconstruct.hpp"
#include "support/test_support.hpp"

#ifdef MENISCUS_HAS_OPENVDB
#include <openvdb/openvdb.h>
#endif

namespace meniscus {
namespace {

#ifdef MENISCUS_HAS_OPENVDB
TEST(VdbExport, WritesTheUnionOfSpheresAsALevelSet) {
  ParticleSet ps;
  ps.positions = {{0, 0, 0}, {3, 0, 0}};
  Params in;
  in.spacing = 1.0;
  const Params p = resolve_params(ps, in);  // h = 0.5, r_outer = 1
  test::TempDir tmp;
  write_field_vdb(tmp.file("field.vdb"), ps, p);

  openvdb::initialize();
  openvdb::io::File file(tmp.file("field.vdb"));
  file.open();
  const auto grid = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("surface"));
  file.close();
  ASSERT_TRUE(grid);
  EXPECT_EQ(grid->getGridClass(), openvdb::GRID_LEVEL_SET);
  EXPECT_DOUBLE_EQ(grid->voxelSize()[0], 0.5);
  EXPECT_FLOAT_EQ(grid->background(), 1.0f);  // band (r_outer + 2h) − r_outer
  const auto acc = grid->getConstAccessor();
  EXPECT_FLOAT_EQ(acc.getValue(openvdb::Coord(0, 0, 0)), -1.0f);   // on a particle: −r_outer
  EXPECT_FLOAT_EQ(acc.getValue(openvdb::Coord(2, 0, 0)), 0.0f);    // r_outer away: the surface
  EXPECT_FLOAT_EQ(acc.getValue(openvdb::Coord(3, 0, 0)), 0.5f);    // halfway: 1.5 from both
  EXPECT_FLOAT_EQ(acc.getValue(openvdb::Coord(6, 1, 0)), std::sqrt(0.25f) - 1.0f);
  EXPECT_FLOAT_EQ(acc.getValue(openvdb::Coord(40, 0, 0)), 1.0f);   // far: background
  EXPECT_GT(grid->activeVoxelCount(), 100u);
  // No temporary file is left beside it.
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(tmp.path), std::filesystem::directory_iterator{}), 1);
}
#else
TEST(VdbExport, RefusedWithoutOpenVdb) {
  EXPECT_FALSE(has_openvdb());
  EXPECT_THROW(write_field_vdb("x.vdb", ParticleSet{}, Params{}), InvalidParameter);
}
#endif

}  // namespace
}  // namespace meniscus
