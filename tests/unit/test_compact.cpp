// Tests of the in-place triangle/vertex compaction (mesh/compact.hpp) against a plain serial
// filter, over many chunks, with normals and a two-component attribute carried along.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <functional>
#include <random>
#include <stdexcept>

#include "mesh/compact.hpp"

namespace meniscus {
namespace {

TriangleMesh random_mesh(std::size_t vertices, std::size_t triangles, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<uint32_t> pick(0, uint32_t(vertices - 1));
  TriangleMesh m;
  for (std::size_t v = 0; v < vertices; ++v) {
    m.vertices.push_back({float(v), float(v) * 0.5f, -float(v)});
    m.normals.push_back({0, 0, float(v)});
  }
  Attribute a;
  a.name = "uv";
  a.components = 2;
  for (std::size_t v = 0; v < vertices; ++v) {
    a.values.push_back(float(v));
    a.values.push_back(-float(v));
  }
  m.attributes.push_back(a);
  // Triangles mostly local (as the extraction makes them), some far-reaching.
  for (std::size_t t = 0; t < triangles; ++t) {
    const uint32_t v0 = uint32_t(t * vertices / triangles);
    const uint32_t v1 = t % 7 == 0 ? pick(rng) : std::min(uint32_t(vertices - 1), v0 + 1);
    const uint32_t v2 = t % 11 == 0 ? pick(rng) : std::min(uint32_t(vertices - 1), v0 + 2);
    m.triangles.push_back({v0, v1, v2});
  }
  return m;
}

/// The obvious serial filter: kept triangles in order, then the used vertices in order.
TriangleMesh reference_keep(const TriangleMesh& m, const std::vector<uint8_t>& keep) {
  TriangleMesh out;
  std::vector<uint8_t> used(m.vertices.size(), 0);
  for (std::size_t t = 0; t < m.triangles.size(); ++t)
    if (keep[t])
      for (uint32_t v : m.triangles[t]) used[v] = 1;
  std::vector<uint32_t> remap(m.vertices.size(), ~0u);
  out.attributes.push_back(Attribute{"uv", 2, false, {}});
  for (std::size_t v = 0; v < m.vertices.size(); ++v)
    if (used[v]) {
      remap[v] = uint32_t(out.vertices.size());
      out.vertices.push_back(m.vertices[v]);
      out.normals.push_back(m.normals[v]);
      out.attributes[0].values.push_back(m.attributes[0].values[2 * v]);
      out.attributes[0].values.push_back(m.attributes[0].values[2 * v + 1]);
    }
  for (std::size_t t = 0; t < m.triangles.size(); ++t)
    if (keep[t]) out.triangles.push_back({remap[m.triangles[t][0]], remap[m.triangles[t][1]], remap[m.triangles[t][2]]});
  return out;
}

void expect_same(const TriangleMesh& a, const TriangleMesh& b) {
  EXPECT_EQ(a.triangles, b.triangles);
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.normals, b.normals);
  ASSERT_EQ(a.attributes.size(), 1u);
  EXPECT_EQ(a.attributes[0].values, b.attributes[0].values);
}

TEST(Compact, KeepTrianglesMatchesASerialFilterOverManyChunks) {
  // 5 chunks of triangles and 3 of vertices; drop patterns: none at the start (the first chunks
  // stay where they are), runs across chunk edges, isolated ones, and a whole chunk.
  const std::size_t nv = 3 * kOffsetChunk - 17, nt = 5 * kOffsetChunk + 5;
  const TriangleMesh original = random_mesh(nv, nt, 3);
  std::vector<uint8_t> keep(nt, 1);
  std::mt19937 rng(8);
  for (std::size_t t = kOffsetChunk + 100; t < nt; ++t) keep[t] = rng() % 9 != 0;
  for (std::size_t t = 2 * kOffsetChunk - 50; t < 2 * kOffsetChunk + 70; ++t) keep[t] = 0;
  for (std::size_t t = 3 * kOffsetChunk; t < 4 * kOffsetChunk; ++t) keep[t] = 0;
  const TriangleMesh expected = reference_keep(original, keep);
  ASSERT_LT(expected.vertices.size(), nv);  // vertices go too

  for (int threads : {1, 2, 4}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
    TriangleMesh m = original;
    const auto index_of = [&](const Triangle& t) { return std::size_t(&t - m.triangles.data()); };
    const std::size_t dropped = keep_triangles(m, [&](const Triangle& t) { return keep[index_of(t)] != 0; });
    EXPECT_EQ(dropped, nt - expected.triangles.size()) << threads;
    expect_same(m, expected);
  }
}

TEST(Compact, KeepingEverythingLeavesTheMeshAsItIs) {
  TriangleMesh m = random_mesh(1000, 3000, 4);
  const TriangleMesh before = m;
  EXPECT_EQ(keep_triangles(m, [](const Triangle&) { return true; }), 0u);
  expect_same(m, before);
}

TEST(Compact, DroppingEverythingEmptiesTheMesh) {
  TriangleMesh m = random_mesh(1000, 3000, 5);
  EXPECT_EQ(keep_triangles(m, [](const Triangle&) { return false; }), 3000u);
  EXPECT_TRUE(m.triangles.empty());
  EXPECT_TRUE(m.vertices.empty());
  EXPECT_TRUE(m.normals.empty());
  EXPECT_TRUE(m.attributes[0].values.empty());
}

/// `groups` components of `group` vertices each: strips of triangles within each group, the groups'
/// triangles interleaved over the array (as the extraction's blocks interleave components), each
/// triangle's orientation at random.
TriangleMesh strip_groups(std::size_t groups, uint32_t group, uint32_t seed) {
  TriangleMesh m = random_mesh(groups * group, 1, seed);
  m.triangles.clear();
  std::mt19937 rng(seed + 1);
  for (uint32_t k = 0; k < 2; ++k)
    for (std::size_t g = 0; g < groups; ++g)
      for (uint32_t i = k; i + 2 < group; i += 2) {
        const uint32_t v = uint32_t(g) * group + i;
        m.triangles.push_back(rng() % 2 ? Triangle{v, v + 1, v + 2} : Triangle{v + 2, v + 1, v});
      }
  return m;
}

/// Components of kGroup vertices (strip_groups), and the mesh without the groups `dropped` says, by
/// keep_triangles; drop_sorted must give the same from the sorted lists.
void expect_drop_sorted_matches(std::size_t groups, const std::function<bool(std::size_t)>& dropped) {
  constexpr uint32_t kGroup = 24;
  const TriangleMesh original = strip_groups(groups, kGroup, 11);
  TriangleMesh expected = original;
  const std::size_t count = keep_triangles(expected, [&](const Triangle& t) { return !dropped(t[0] / kGroup); });
  std::vector<uint32_t> triangles, vertices;
  for (uint32_t t = 0; t < original.triangles.size(); ++t)
    if (dropped(original.triangles[t][0] / kGroup)) triangles.push_back(t);
  for (uint32_t v = 0; v < original.vertices.size(); ++v)
    if (dropped(v / kGroup)) vertices.push_back(v);
  ASSERT_EQ(triangles.size(), count);
  for (int threads : {1, 2, 4}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
    TriangleMesh m = original;
    EXPECT_EQ(drop_sorted(m, triangles, vertices), count) << threads;
    expect_same(m, expected);
  }
}

TEST(Compact, DropSortedMatchesKeepTrianglesForSparseDrops) {
  // 11000 groups: 242k triangles, 264k vertices. Sparse drops (1.2 %) make 43 chunks of each, each
  // moving by the drops before it and the next one overwriting its tail: every 97th group, a run of
  // groups whose triangles straddle chunk edges, the first group and the last (the last chunk's end).
  const std::size_t groups = 11000;
  expect_drop_sorted_matches(groups, [&](std::size_t g) {
    return g % 97 == 5 || (g >= 5000 && g < 5012) || g == 0 || g == groups - 1;
  });
}

TEST(Compact, DropSortedMatchesKeepTrianglesForDenseDrops) {
  // Drops too many for chunks of twice their number: one chunk, every third group.
  expect_drop_sorted_matches(3000, [](std::size_t g) { return g % 3 == 1; });
  // Nothing, and everything.
  expect_drop_sorted_matches(500, [](std::size_t) { return false; });
  expect_drop_sorted_matches(500, [](std::size_t) { return true; });
}

TEST(Compact, DropSortedRefusesUnsortedLists) {
  TriangleMesh m = random_mesh(100, 300, 13);
  const std::vector<uint32_t> unsorted{5, 3}, none;
  const std::vector<uint32_t> past_the_end{300};
  EXPECT_THROW(drop_sorted(m, unsorted, none), std::logic_error);
  EXPECT_THROW(drop_sorted(m, past_the_end, none), std::logic_error);
  EXPECT_THROW(drop_sorted(m, none, std::vector<uint32_t>{7, 7}), std::logic_error);
  EXPECT_EQ(m.triangles.size(), 300u);
}

}  // namespace
}  // namespace meniscus
