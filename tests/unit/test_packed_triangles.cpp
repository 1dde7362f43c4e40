// Tests of PackedTriangles: the triangles come back exactly, and a mesh numbered in space packs
// small.
#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <vector>

#include "mesh/packed_triangles.hpp"

namespace meniscus {
namespace {

TEST(PackedTriangles, RoundTripsAnyIndicesOverManyBlocks) {
  std::mt19937 rng(3);
  std::uniform_int_distribution<uint32_t> any(0, UINT32_MAX);
  std::vector<Triangle> triangles(3 * PackedTriangles::kBlock + 17);
  for (Triangle& t : triangles) t = {any(rng), any(rng), any(rng)};
  triangles[0] = {0, UINT32_MAX, 0};  // the largest differences, both signs
  triangles[1] = {UINT32_MAX, 0, UINT32_MAX};
  triangles[PackedTriangles::kBlock] = {7, 7, 7};  // a block's first triangle
  const std::vector<Triangle> expected = triangles;
  PackedTriangles packed;
  packed.pack(triangles);
  EXPECT_TRUE(triangles.empty());
  EXPECT_EQ(triangles.capacity(), 0u) << "the storage is handed back";
  EXPECT_TRUE(packed.packed());
  EXPECT_EQ(packed.size(), expected.size());
  packed.unpack(triangles);
  EXPECT_FALSE(packed.packed());
  EXPECT_EQ(packed.packed_bytes(), 0u);
  EXPECT_EQ(triangles, expected);
}

TEST(PackedTriangles, SelectsTheKeptTrianglesInOrderWithoutUnpacking) {
  std::mt19937 rng(5);
  std::uniform_int_distribution<uint32_t> any(0, 1u << 20);
  std::vector<Triangle> triangles(4 * PackedTriangles::kBlock + 333);
  for (Triangle& t : triangles) t = {any(rng), any(rng), any(rng)};
  // Block 1 has no triangle to keep: a search that skips it gives the same list.
  for (std::size_t k = PackedTriangles::kBlock; k < 2 * PackedTriangles::kBlock; ++k) triangles[k][0] -= triangles[k][0] % 3;
  const std::vector<Triangle> original = triangles;
  auto keep = [](const Triangle& t) { return t[0] % 3 == 1; };
  auto map = [](const Triangle& t) { return Triangle{t[2], t[0] + 1, t[1]}; };
  std::vector<Triangle> expected;
  for (const Triangle& t : original)
    if (keep(t)) expected.push_back(map(t));
  PackedTriangles packed;
  packed.pack(triangles);
  EXPECT_EQ(packed.select(keep, map), expected);
  ASSERT_EQ(packed.block_count(), 5u);
  EXPECT_EQ(packed.select(keep, map, [](std::size_t b) { return b != 1; }), expected);
  std::vector<Triangle> without_block_3;  // a search that skips a block with kept triangles drops them
  for (std::size_t k = 0; k < original.size(); ++k)
    if (keep(original[k]) && k / PackedTriangles::kBlock != 3) without_block_3.push_back(map(original[k]));
  EXPECT_EQ(packed.select(keep, map, [](std::size_t b) { return b != 3; }), without_block_3);
  EXPECT_TRUE(packed.select([](const Triangle&) { return false; }, map).empty());
  EXPECT_TRUE(packed.packed()) << "still packed";
  packed.unpack(triangles);
  EXPECT_EQ(triangles, original);
}

TEST(PackedTriangles, RoundTripsAnEmptyList) {
  std::vector<Triangle> triangles;
  PackedTriangles packed;
  packed.pack(triangles);
  EXPECT_EQ(packed.packed_bytes(), 0u);
  packed.unpack(triangles);
  EXPECT_TRUE(triangles.empty());
}

// A strip of a grid numbered row by row: neighbouring corners differ by 1 or a row, so every
// integer fits one or two bytes — 4 to 5 bytes a triangle instead of 12.
TEST(PackedTriangles, AMeshNumberedInSpacePacksToUnderHalf) {
  const uint32_t row = 100, rows = 400;
  std::vector<Triangle> triangles;
  for (uint32_t r = 0; r + 1 < rows; ++r)
    for (uint32_t c = 0; c + 1 < row; ++c) {
      const uint32_t v = r * row + c;
      triangles.push_back({v, v + 1, v + row});
      triangles.push_back({v + 1, v + row + 1, v + row});
    }
  const std::vector<Triangle> expected = triangles;
  PackedTriangles packed;
  packed.pack(triangles);
  EXPECT_LT(double(packed.packed_bytes()) / double(expected.size()), 5.0);
  packed.unpack(triangles);
  EXPECT_EQ(triangles, expected);
}

}  // namespace
}  // namespace meniscus
