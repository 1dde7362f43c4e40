// Tests of the coincident points' groups (grid/coincident.hpp) against brute force, and of the
// particle pass that computes a pile's centre and ellipsoid once (field/anisotropy.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <set>

#include "field/anisotropy.hpp"
#include "grid/coincident.hpp"

namespace meniscus {
namespace {

/// Per point, the lowest index of a point in the same cell of the grid of `cell` and the same
/// cell of the lattice of `tolerance` (0: the same position), by comparing every pair.
std::vector<uint32_t> brute_first(const std::vector<Vec3f>& p, float cell, double tolerance) {
  auto same = [&](Vec3f a, Vec3f b) {
    if (grid_cell_of(a, cell) != grid_cell_of(b, cell)) return false;
    if (tolerance == 0) return a == b;
    for (int c = 0; c < 3; ++c)
      if (std::floor(double(a[c]) / tolerance) != std::floor(double(b[c]) / tolerance)) return false;
    return true;
  };
  std::vector<uint32_t> first(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    first[i] = uint32_t(i);
    for (std::size_t j = 0; j < i; ++j)
      if (same(p[j], p[i])) {
        first[i] = uint32_t(j);
        break;
      }
  }
  return first;
}

/// 3,000 scattered points; 400 copies of point 5 spread through the list (a cell of hundreds,
/// grouped by sorting); 10 copies of point 9 (a cell of at most 16, grouped pairwise); then
/// kHairWide points within 1e-7 of point 11 (at kHairWideFrom).
constexpr std::size_t kHairWide = 300, kHairWideFrom = 3410;
std::vector<Vec3f> piles() {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-2.0f, 2.0f), hair(-1e-7f, 1e-7f);
  std::vector<Vec3f> p(3000);
  for (Vec3f& x : p) x = {u(rng), u(rng), u(rng)};
  const Vec3f a = p[5], b = p[9], c = p[11];
  for (int k = 0; k < 400; ++k) p.insert(p.begin() + 20 + 7 * k, a);
  for (int k = 0; k < 10; ++k) p.push_back(b);
  for (std::size_t k = 0; k < kHairWide; ++k) p.push_back(c + Vec3f{hair(rng), hair(rng), hair(rng)});
  return p;
}

TEST(CoincidentPoints, GroupsEqualPositionsUnderTheirLowestIndex) {
  const std::vector<Vec3f> p = piles();
  const HashGrid grid(p, 0.3f);
  const CoincidentPoints g = coincident_points(grid, 0);
  const std::vector<uint32_t> expected = brute_first(p, 0.3f, 0);
  ASSERT_EQ(g.first, expected);
  std::size_t copies = 0;
  for (std::size_t i = 0; i < p.size(); ++i) copies += expected[i] != i;
  EXPECT_EQ(g.copies, copies);
  EXPECT_GE(g.copies, 410u);
  const GroupHeads h = group_heads(g, p.size());
  EXPECT_EQ(h.index.size(), p.size() - g.copies);
  std::size_t counted = 0;
  for (std::size_t k = 0; k < h.index.size(); ++k) {
    EXPECT_EQ(g.first[h.index[k]], h.index[k]);
    counted += h.count[k];
  }
  EXPECT_EQ(counted, p.size());
  const auto five = std::find(h.index.begin(), h.index.end(), 5u);
  ASSERT_NE(five, h.index.end());
  EXPECT_EQ(h.count[std::size_t(five - h.index.begin())], 401u);
}

TEST(CoincidentPoints, ATolerantLatticeGroupsAHairWidePileIntoAFewGroups) {
  const std::vector<Vec3f> p = piles();
  const HashGrid grid(p, 0.3f);
  const double tolerance = 1e-5;
  const CoincidentPoints g = coincident_points(grid, tolerance);
  ASSERT_EQ(g.first, brute_first(p, 0.3f, tolerance));
  // The points around point 11 lie in at most 8 cells of the lattice.
  std::set<uint32_t> groups;
  for (std::size_t i = kHairWideFrom; i < p.size(); ++i) {
    groups.insert(g.first[i]);
    EXPECT_LE(length(p[i] - p[g.first[i]]), float(std::sqrt(3.0) * tolerance));
  }
  EXPECT_LE(groups.size(), 8u);
  // More than that many distinct positions: the lattice, not equality, groups them.
  const CoincidentPoints exact = coincident_points(grid, 0);
  std::set<uint32_t> positions;
  for (std::size_t i = kHairWideFrom; i < p.size(); ++i) positions.insert(exact.first[i]);
  EXPECT_GT(positions.size(), groups.size());
}

TEST(CoincidentPoints, PointsAllApartGiveNoGroups) {
  std::vector<Vec3f> p;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j) p.push_back(Vec3f{float(i) * 0.1f, float(j) * 0.1f, 0.0f});
  p.push_back(Vec3f{-0.0f, 0.0f, 0.5f});
  p.push_back(Vec3f{0.0f, -0.0f, 0.5f});  // −0 and +0: one position
  const HashGrid grid(p, 1.0f);
  const CoincidentPoints g = coincident_points(grid, 0);
  EXPECT_EQ(g.copies, 1u);
  EXPECT_EQ(g.first[101], 100u);
  p.pop_back();
  EXPECT_TRUE(coincident_points(HashGrid(p, 1.0f), 0).first.empty());
  EXPECT_TRUE(coincident_points(HashGrid(p, 1.0f), 1e-6).first.empty());
}

TEST(CoincidentPoints, APileSharesTheCentreAndEllipsoidItsParticlesWouldEachGet) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 0.5f);
  std::vector<Vec3f> p(2000);
  for (Vec3f& x : p) x = {u(rng), u(rng), u(rng)};
  for (int k = 0; k < 300; ++k) {  // copies before their originals
    const Vec3f x = p[std::size_t(1000 + 3 * k)];
    p.insert(p.begin() + 3 * k, x);
  }
  const HashGrid grid(p, 0.1f);
  const CoincidentPoints g = coincident_points(grid, 0);
  ASSERT_EQ(g.copies, 300u);
  AnisotropyConstants k;
  k.bulk_variance = yu_turk_bulk_variance(0.1f);
  const std::vector<Vec3f> each = smooth_positions(grid, 0.08f, 0.5f), once = smooth_positions(grid, 0.08f, 0.5f, g.first);
  const std::vector<Ellipsoid> e_each = yu_turk_ellipsoids(grid, 0.1f, k), e_once = yu_turk_ellipsoids(grid, 0.1f, k, g.first);
  ASSERT_EQ(once.size(), each.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    ASSERT_EQ(once[i], each[i]) << i;
    ASSERT_EQ(std::memcmp(&e_once[i], &e_each[i], sizeof(Ellipsoid)), 0) << i;
  }
}

}  // namespace
}  // namespace meniscus
