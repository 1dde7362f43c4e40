// Tests of the uniform hashed grid against brute force.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <set>

#include "grid/build_grid.hpp"
#include "grid/hash_grid.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "meniscus/reconstruct.hpp"
#include "support/io_helpers.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

std::vector<Vec3f> random_points(std::size_t n, float extent, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-extent, extent);
  std::vector<Vec3f> p(n);
  for (auto& v : p) v = {u(rng), u(rng), u(rng)};
  return p;
}

TEST(HashGrid, SortedByCellAndCellRangesPartitionThePoints) {
  const auto pts = random_points(5000, 3.0f, 7);
  const HashGrid grid(pts, 0.4f);
  ASSERT_EQ(grid.size(), pts.size());
  // order() is a permutation and sorted_points() follows it.
  std::vector<int> seen(pts.size(), 0);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    ++seen[grid.order()[i]];
    EXPECT_EQ(grid.sorted_points()[i], pts[grid.order()[i]]);
  }
  for (int s : seen) ASSERT_EQ(s, 1);
  // Every point lies in the cell whose range holds it.
  std::size_t covered = 0;
  for (std::size_t c = 0; c < grid.cell_keys().size(); ++c) {
    const Vec3i cell = unpack_coords(grid.cell_keys()[c]);
    for (uint32_t i = grid.cell_starts()[c]; i < grid.cell_starts()[c + 1]; ++i) {
      EXPECT_EQ(grid.cell_of(grid.sorted_points()[i]), cell);
      ++covered;
    }
    const auto [b, e] = grid.cell_range(cell);
    EXPECT_EQ(b, grid.cell_starts()[c]);
    EXPECT_EQ(e, grid.cell_starts()[c + 1]);
  }
  EXPECT_EQ(covered, pts.size());
}

TEST(HashGrid, NearestMatchesBruteForce) {
  const auto pts = random_points(3000, 2.0f, 11);
  HashGrid grid(pts, 0.25f);
  // The queries need no original indices: the pipeline frees them for the smoothing.
  const std::size_t bytes = grid.memory_bytes();
  grid.release_order();
  EXPECT_TRUE(grid.order().empty());
  EXPECT_EQ(grid.memory_bytes(), bytes - 4 * pts.size());
  const auto queries = random_points(500, 3.0f, 12);  // some outside the points' box
  for (const Vec3f& q : queries) {
    float best = INFINITY;
    for (const Vec3f& p : pts) best = std::min(best, length2(p - q));
    const auto n = grid.nearest(q);
    ASSERT_NE(n.index, kNotFound);
    EXPECT_FLOAT_EQ(n.dist2, best);
    EXPECT_FLOAT_EQ(length2(grid.sorted_points()[n.index] - q), best);
    // Bounded search: found iff the nearest is within the radius.
    const auto b = grid.nearest(q, 0.3f);
    if (best <= 0.09f) {
      EXPECT_FLOAT_EQ(b.dist2, best);
    } else {
      EXPECT_EQ(b.index, kNotFound);
    }
  }
}

TEST(HashGrid, RadiusQueryMatchesBruteForce) {
  const auto pts = random_points(2000, 1.0f, 3);
  const HashGrid grid(pts, 0.1f);
  const auto queries = random_points(100, 1.2f, 4);
  for (const Vec3f& q : queries) {
    std::size_t expected = 0;
    for (const Vec3f& p : pts) expected += length2(p - q) <= 0.35f * 0.35f;
    std::size_t got = 0;
    grid.for_each_within(q, 0.35f, [&](uint32_t i, float d2) {
      EXPECT_LE(d2, 0.35f * 0.35f);
      EXPECT_FLOAT_EQ(d2, length2(grid.sorted_points()[i] - q));
      ++got;
    });
    EXPECT_EQ(got, expected);
  }
}

TEST(HashGrid, DenseAndHashedIndexesFindTheSameCells) {
  // A compact cloud gets the dense index; the same cloud with two far outliers (a box of 10^9
  // cells) the hash index. Both must give every occupied cell its range, empty cells none, and
  // radius queries the brute-force answer.
  const std::vector<Vec3f> compact = random_points(4000, 1.0f, 21);
  std::vector<Vec3f> spread = compact;
  spread.push_back({-90.0f, 80.0f, 95.0f});
  spread.push_back({99.0f, -99.0f, -70.0f});
  for (const std::vector<Vec3f>* pts : {&compact, static_cast<const std::vector<Vec3f>*>(&spread)}) {
    const HashGrid grid(*pts, 0.2f);
    EXPECT_EQ(grid.dense_index(), pts == &compact);
    std::set<uint64_t> occupied(grid.cell_keys().begin(), grid.cell_keys().end());
    for (std::size_t c = 0; c < grid.cell_keys().size(); ++c) {
      const auto [b, e] = grid.cell_range(unpack_coords(grid.cell_keys()[c]));
      EXPECT_EQ(b, grid.cell_starts()[c]);
      EXPECT_EQ(e, grid.cell_starts()[c + 1]);
    }
    for (int z = -7; z <= 7; ++z)
      for (int y = -7; y <= 7; ++y)
        for (int x = -7; x <= 7; ++x)
          if (!occupied.count(pack_coords(x, y, z))) {
            const auto [b, e] = grid.cell_range({x, y, z});
            EXPECT_EQ(b, e) << x << " " << y << " " << z;
          }
    for (const Vec3f& q : random_points(50, 1.3f, 22)) {
      std::size_t expected = 0;
      for (const Vec3f& p : *pts) expected += length2(p - q) <= 0.3f * 0.3f;
      std::size_t got = 0;
      grid.for_each_within(q, 0.3f, [&](uint32_t, float) { ++got; });
      EXPECT_EQ(got, expected);
    }
  }
}

TEST(CellIndex, DenseAndHashedFindEveryCellAndNoOther) {
  // A filled slab with holes (dense) and the same with one far cell (hashed), against a map; the
  // empty index finds nothing.
  std::vector<uint64_t> slab;
  for (int z = -3; z <= 2; ++z)
    for (int y = -5; y <= 5; ++y)
      for (int x = -4; x <= 6; ++x)
        if ((x * 7 + y * 3 + z) % 5 != 0) slab.push_back(pack_coords(x, y, z));
  std::vector<uint64_t> far = slab;
  far.push_back(pack_coords(900, -800, 700));
  for (std::vector<uint64_t>* keys : {&slab, &far}) {
    std::sort(keys->begin(), keys->end());
    const CellIndex index(*keys);
    EXPECT_EQ(index.dense(), keys == &slab);
    std::map<uint64_t, uint32_t> expected;
    for (std::size_t i = 0; i < keys->size(); ++i) expected[(*keys)[i]] = uint32_t(i);
    for (int z = -6; z <= 5; ++z)
      for (int y = -8; y <= 8; ++y)
        for (int x = -7; x <= 9; ++x) {
          const auto it = expected.find(pack_coords(x, y, z));
          EXPECT_EQ(index.find({x, y, z}), it == expected.end() ? kNotFound : it->second) << x << " " << y << " " << z;
        }
    EXPECT_EQ(index.find({900, -800, 700}), keys == &far ? uint32_t(keys->size() - 1) : kNotFound);
  }
  EXPECT_EQ(CellIndex(std::vector<uint64_t>{}).find({0, 0, 0}), kNotFound);
}

TEST(HashGrid, RefusesCoordinatesBeyondTheKeyRange) {
  std::vector<Vec3f> pts{{0, 0, 0}, {1e9f, 0, 0}};
  EXPECT_THROW(HashGrid(pts, 0.01f), ResourceError);
  EXPECT_THROW(HashGrid(pts, -1.0f), InvalidParameter);
}

TEST(HashGrid, EmptyGridFindsNothing) {
  const HashGrid grid(std::vector<Vec3f>{}, 1.0f);
  EXPECT_EQ(grid.nearest({0, 0, 0}).index, kNotFound);
}

// The CPU's HashGrid (a compact key of the cells' box, sorted on its few bits) is a fast path of
// build_grid, the build written once for both backends (grid/build_grid.hpp, 64-bit cell keys):
// run with Host{} on a real frame, at the pipeline's cell and at the field's, it gives the same
// bounds, sorted points (bits), order, cell keys and cell starts.
TEST(HashGrid, SharedBuildOnTheHostIsTheCpuGridBitForBit) {
  const ParticleSet ps = read_particles(test::data_file("ply/dam_break_frame_23_24389_particles.ply"));
  const float d = float(estimate_spacing(ps));
  const uint32_t n = uint32_t(ps.positions.size());
  Vec3f lo, hi;
  point_bounds(Host{}, ps.positions.data(), n, &lo, &hi);
  Vec3f serial_lo = ps.positions[0], serial_hi = ps.positions[0];
  for (const Vec3f& p : ps.positions) serial_lo = min(serial_lo, p), serial_hi = max(serial_hi, p);
  for (int a = 0; a < 3; ++a) {
    ASSERT_TRUE(test::same_bits(lo[a], serial_lo[a]));
    ASSERT_TRUE(test::same_bits(hi[a], serial_hi[a]));
  }
  for (const float cell : {2 * d, 4 * d, 0.5f * d}) {
    SCOPED_TRACE(cell);
    const HashGrid cpu(ps.positions, cell);
    const GridBuffers<Host> shared =
        build_grid(Host{}, ps.positions.data(), n, cell, grid_cell_of(lo, cell), grid_cell_of(hi, cell));
    ASSERT_EQ(shared.count, n);
    ASSERT_EQ(shared.cells, cpu.cell_keys().size());
    EXPECT_EQ(shared.lo, cpu.cell_min());
    EXPECT_EQ(shared.hi, cpu.cell_max());
    for (uint32_t i = 0; i < n; ++i) {
      ASSERT_EQ(shared.order.data()[i], cpu.order()[i]) << i;
      for (int a = 0; a < 3; ++a) ASSERT_TRUE(test::same_bits(shared.sorted.data()[i][a], cpu.sorted_points()[i][a]));
    }
    for (uint32_t c = 0; c < shared.cells; ++c) {
      ASSERT_EQ(shared.keys.data()[c], cpu.cell_keys()[c]) << c;
      ASSERT_EQ(shared.starts.data()[c], cpu.cell_starts()[c]) << c;
    }
    EXPECT_EQ(shared.starts.data()[shared.cells], cpu.cell_starts()[shared.cells]);
    // Per-particle data into the grid's order.
    std::vector<float> x(n);
    for (uint32_t i = 0; i < n; ++i) x[i] = ps.positions[i].x;
    const HostBuffer<float> sorted_x = to_sorted_order(Host{}, shared, x.data());
    for (uint32_t i = 0; i < n; ++i) ASSERT_TRUE(test::same_bits(sorted_x.data()[i], cpu.sorted_points()[i].x));
  }
}

}  // namespace
}  // namespace meniscus
