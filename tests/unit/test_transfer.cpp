// Tests of normals, erosion, attribute transfer and void removal against direct computations.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <array>
#include <cmath>
#include <cstring>
#include <random>

#include "grid/hash_grid.hpp"
#include "mesh/voids.hpp"
#include "meniscus/quality.hpp"
#include "support/test_support.hpp"
#include "transfer/attribute_transfer.hpp"
#include "mesh/normals.hpp"
#include "mesh/normals_impl.hpp"
#include "common/for_each.hpp"
#include "common/primitives.hpp"
#include "mesh/adjacency_backend.hpp"
#include "mesh/normals_backend.hpp"

namespace meniscus {
namespace {

// Octahedron |x|+|y|+|z| = r, outward triangles.
TriangleMesh octahedron(float r, Vec3f c = {0, 0, 0}, bool inward = false) {
  TriangleMesh m;
  m.vertices = {{r, 0, 0}, {-r, 0, 0}, {0, r, 0}, {0, -r, 0}, {0, 0, r}, {0, 0, -r}};
  for (auto& v : m.vertices) v += c;
  m.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  if (inward)
    for (auto& t : m.triangles) std::swap(t[1], t[2]);
  return m;
}

TEST(Normals, OctahedronVertexNormalsPointAlongTheAxes) {
  const TriangleMesh m = octahedron(2.0f);
  const auto n = vertex_normals(m.vertices, m.triangles);
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_NEAR(length(n[i]), 1.0f, 1e-6f);
    EXPECT_NEAR(dot(n[i], normalized(m.vertices[i])), 1.0f, 1e-6f) << i;
  }
}

TEST(Normals, AreaWeightingFavoursLargeTriangles) {
  // A vertex shared by a big triangle in the xy plane and a small one in the xz plane.
  const std::vector<Vec3f> x{{0, 0, 0}, {10, 0, 0}, {0, 10, 0}, {0, 0, -1}};
  const std::vector<Triangle> t{{0, 1, 2}, {0, 3, 1}};
  const auto n = vertex_normals(x, t);
  // Σ cross products: (0,0,100) + (0,1,0)·... computed directly:
  const Vec3f expected = normalized(cross(x[1] - x[0], x[2] - x[0]) + cross(x[3] - x[0], x[1] - x[0]));
  EXPECT_NEAR(dot(n[0], expected), 1.0f, 1e-6f);
  EXPECT_GT(n[0].z, 0.99f);
}

/// A wavy height field of rows × cols vertices in row order (test::grid_mesh): a mesh in spatial
/// order over many of the normals' chunks (2^16 triangles each).
TriangleMesh height_field(uint32_t rows, uint32_t cols) {
  return test::grid_mesh(cols, rows, [](uint32_t c, uint32_t r) {
    return std::sin(0.05f * float(c)) * std::cos(0.03f * float(r)) * 5.0f;
  });
}

/// Normals summed serially in double precision, in triangle order.
std::vector<Vec3f> serial_normals(const TriangleMesh& m) {
  std::vector<std::array<double, 3>> n(m.vertices.size(), {0, 0, 0});
  for (const Triangle& t : m.triangles) {
    const Vec3f c = cross(m.vertices[t[1]] - m.vertices[t[0]], m.vertices[t[2]] - m.vertices[t[0]]);
    for (const uint32_t v : t)
      for (int a = 0; a < 3; ++a) n[v][std::size_t(a)] += double(c[a]);
  }
  std::vector<Vec3f> out;
  for (const auto& s : n) out.push_back(normalized(Vec3f{float(s[0]), float(s[1]), float(s[2])}));
  return out;
}

TEST(Normals, ParallelWavesMatchASerialSumOnEveryThreadCount) {
  // 638k triangles, 10 chunks each sharing a row of vertices with the next: waves of every other
  // chunk. Then the same mesh with a hub vertex in triangles all over it, so that far apart chunks
  // meet and the chunks go one at a time. The normals must match a serial double sum and be
  // bit-identical on 1, 2 and 4 threads.
  TriangleMesh hub = height_field(400, 800);
  for (std::size_t t = 0; t < hub.triangles.size(); t += 5000) hub.triangles[t][0] = 0;
  for (const TriangleMesh& m : {height_field(400, 800), hub}) {
    const std::vector<Vec3f> reference = serial_normals(m);
    std::vector<Vec3f> first;
    for (int threads : {1, 2, 4}) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
      const std::vector<Vec3f> n = vertex_normals(m.vertices, m.triangles);
      ASSERT_EQ(n.size(), reference.size());
      for (std::size_t v = 0; v < n.size(); ++v) ASSERT_GT(dot(n[v], reference[v]), 1.0f - 1e-5f) << v;
      if (first.empty())
        first = n;
      else
        for (std::size_t v = 0; v < n.size(); ++v)
          ASSERT_TRUE(n[v].x == first[v].x && n[v].y == first[v].y && n[v].z == first[v].z) << threads << " " << v;
    }
  }
}

TEST(Normals, TheCpuScatterIsTheSharedGatherBitForBit) {
  // The CPU scatters the triangles' cross products (vertex_normals, its fast path); the device
  // gathers them per vertex with the shared GatherNormal. Run on the CPU over incidence lists made
  // here, the gather must give the scatter's bits on both meshes of the test above.
  TriangleMesh hub = height_field(200, 300);
  for (std::size_t t = 0; t < hub.triangles.size(); t += 2000) hub.triangles[t][0] = 0;
  for (const TriangleMesh& m : {height_field(200, 300), hub}) {
    const std::size_t nv = m.vertices.size();
    std::vector<uint32_t> offsets(nv + 1, 0), ids;
    for (const Triangle& t : m.triangles)
      for (const uint32_t v : t) ++offsets[v + 1];
    for (std::size_t v = 0; v < nv; ++v) offsets[v + 1] += offsets[v];
    ids.resize(offsets[nv]);
    std::vector<uint32_t> fill(offsets.begin(), offsets.end() - 1);
    for (std::size_t f = 0; f < m.triangles.size(); ++f)
      for (const uint32_t v : m.triangles[f]) ids[fill[v]++] = uint32_t(f);  // ascending per vertex
    std::vector<Vec3f> gathered(nv);
    for_each_index(Host{}, nv, GatherNormal<const Triangle*>{m.vertices.data(), m.triangles.data(), offsets.data(),
                                                             ids.data(), gathered.data()});
    const std::vector<Vec3f> scattered = vertex_normals(m.vertices, m.triangles);
    std::size_t hub_triangles = offsets[1] - offsets[0];
    EXPECT_GT(hub_triangles, 0u);
    for (std::size_t v = 0; v < nv; ++v)
      ASSERT_TRUE(gathered[v].x == scattered[v].x && gathered[v].y == scattered[v].y && gathered[v].z == scattered[v].z)
          << v;
  }
}

// The shared stages the device runs (mesh/normals_backend.hpp, over the shared adjacency), run with
// Host{}: the CPU's normals (its scatter) and erosion bit for bit, and the same flipped triangles.
TEST(Normals, TheSharedStagesOnTheHostGiveTheCpusNormalsAndErosion) {
  TriangleMesh hub = height_field(200, 300);
  for (std::size_t t = 0; t < hub.triangles.size(); t += 2000) hub.triangles[t][0] = 0;
  for (const TriangleMesh& m : {height_field(200, 300), hub}) {
    MeshBuffers<Host> shared;
    shared.vertex_count = m.vertices.size();
    shared.triangle_count = m.triangles.size();
    shared.vertices.upload(m.vertices.data(), m.vertices.size());
    shared.triangles.upload(m.triangles.data()->data(), 3 * m.triangles.size());
    const AdjacencyBuffers<Host> adj = build_adjacency(Host{}, shared);
    const HostBuffer<Vec3f> n = vertex_normals(Host{}, shared, adj);
    const std::vector<Vec3f> scattered = vertex_normals(m.vertices, m.triangles);
    EXPECT_EQ(std::memcmp(n.data(), scattered.data(), scattered.size() * sizeof(Vec3f)), 0);
    const float e = 0.3f;
    std::vector<Vec3f> x = m.vertices;
    const std::size_t flipped_cpu = erode(x, m.triangles, e);
    const std::size_t flipped_shared = erode(Host{}, shared, adj, e);
    EXPECT_EQ(flipped_shared, flipped_cpu);
    EXPECT_EQ(std::memcmp(shared.vertices.data(), x.data(), x.size() * sizeof(Vec3f)), 0);
  }
}

TEST(Erosion, MovesVerticesInwardAndCountsFlips) {
  TriangleMesh m = octahedron(2.0f);
  const double v0 = signed_volume(m);
  EXPECT_EQ(erode(m.vertices, m.triangles, 0.5f), 0u);
  for (const Vec3f& v : m.vertices) EXPECT_NEAR(length(v), 1.5f, 1e-6f);
  EXPECT_LT(signed_volume(m), v0);
  // A pyramid eroded by more than its height: the rim vertices move past the apex and every
  // triangle folds over; a small erosion folds none.
  const std::vector<Triangle> fan{{0, 1, 2}, {0, 2, 3}, {0, 3, 4}, {0, 4, 1}};
  const std::vector<Vec3f> pyramid{{0, 0, 1}, {1, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, -1, 0}};
  std::vector<Vec3f> x = pyramid;
  EXPECT_EQ(erode(x, fan, 0.1f), 0u);
  x = pyramid;
  EXPECT_EQ(erode(x, fan, 1.5f), fan.size());
}

TEST(AttributeTransfer, MatchesABruteForceWeightedMean) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> u(0, 1);
  std::vector<Vec3f> particles(500);
  Attribute a{"value", 2, false, {}};
  for (auto& p : particles) {
    p = {u(rng), u(rng), u(rng)};
    a.values.push_back(p.x * 3 + 1);
    a.values.push_back(u(rng));
  }
  const HashGrid grid(particles, 0.1f);
  std::vector<Vec3f> vertices(200);
  for (auto& v : vertices) v = {u(rng) * 1.4f - 0.2f, u(rng), u(rng)};
  vertices.push_back({5, 5, 5});  // far from everything: nearest particle's value
  const float radius = 0.15f;
  const Attribute out = transfer_attribute(a, grid, vertices, radius);
  ASSERT_EQ(out.values.size(), vertices.size() * 2);
  for (std::size_t v = 0; v < vertices.size(); ++v) {
    double sum[2] = {0, 0}, wsum = 0;
    std::size_t nearest = 0;
    for (std::size_t i = 0; i < particles.size(); ++i) {
      const double r2 = length2(particles[i] - vertices[v]);
      if (r2 < length2(particles[nearest] - vertices[v])) nearest = i;
      const double q = 1 - r2 / (radius * radius);
      if (q <= 0) continue;
      const double w = q * q * q;
      sum[0] += w * a.values[i * 2];
      sum[1] += w * a.values[i * 2 + 1];
      wsum += w;
    }
    for (int c = 0; c < 2; ++c) {
      const double expected = wsum > 0 ? sum[c] / wsum : a.values[nearest * 2 + std::size_t(c)];
      EXPECT_NEAR(out.values[v * 2 + std::size_t(c)], expected, 1e-4) << v;
    }
  }
}

TEST(AttributeTransfer, ManyComponentsAreEachTheirOwnWeightedMean) {
  // 9 components: three walks of the grid (4 + 4 + 1). Each component must be the transfer of
  // that component alone, bit for bit, and a far vertex takes the nearest particle's values.
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0, 1);
  std::vector<Vec3f> particles(400);
  constexpr int kComponents = 9;
  Attribute a{"many", kComponents, false, {}};
  for (auto& p : particles) {
    p = {u(rng), u(rng), u(rng)};
    for (int c = 0; c < kComponents; ++c) a.values.push_back(u(rng) * float(c + 1));
  }
  const HashGrid grid(particles, 0.1f);
  std::vector<Vec3f> vertices(150);
  for (auto& v : vertices) v = {u(rng), u(rng), u(rng)};
  vertices.push_back({-4, 2, 9});
  const Attribute all = transfer_attribute(a, grid, vertices, 0.12f);
  ASSERT_EQ(all.values.size(), vertices.size() * kComponents);
  for (int c = 0; c < kComponents; ++c) {
    Attribute one{"one", 1, false, {}};
    for (std::size_t i = 0; i < particles.size(); ++i) one.values.push_back(a.values[i * kComponents + std::size_t(c)]);
    const Attribute alone = transfer_attribute(one, grid, vertices, 0.12f);
    for (std::size_t v = 0; v < vertices.size(); ++v)
      ASSERT_EQ(all.values[v * kComponents + std::size_t(c)], alone.values[v]) << "component " << c << " vertex " << v;
  }
  std::size_t nearest = 0;
  for (std::size_t i = 0; i < particles.size(); ++i)
    if (length2(particles[i] - vertices.back()) < length2(particles[nearest] - vertices.back())) nearest = i;
  for (int c = 0; c < kComponents; ++c)
    EXPECT_EQ(all.values[(vertices.size() - 1) * kComponents + std::size_t(c)],
              a.values[nearest * kComponents + std::size_t(c)]);
}

TEST(Voids, RemovesSmallInwardComponentsOnly) {
  TriangleMesh m = octahedron(5.0f);                       // the fluid: kept
  const TriangleMesh small_void = octahedron(0.5f, {0, 0, 0}, true);   // volume 0.167: removed
  const TriangleMesh big_void = octahedron(2.0f, {0.5f, 0, 0}, true);  // volume 10.7: kept
  const TriangleMesh droplet = octahedron(0.3f, {9, 0, 0});           // small but outward: kept
  for (const TriangleMesh* part : {&small_void, &big_void, &droplet}) {
    const uint32_t base = uint32_t(m.vertices.size());
    m.vertices.insert(m.vertices.end(), part->vertices.begin(), part->vertices.end());
    for (Triangle t : part->triangles) m.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
  }
  const double before = signed_volume(m);
  EXPECT_EQ(remove_small_voids(m, 1.0), 1u);
  EXPECT_EQ(m.vertices.size(), 18u);
  EXPECT_EQ(m.triangles.size(), 24u);
  EXPECT_NEAR(signed_volume(m), before + 4.0 / 3.0 * 0.125, 1e-4);
  const TopologyReport t = analyze_topology(m);
  EXPECT_TRUE(t.watertight());
  EXPECT_EQ(t.components, 3u);
  EXPECT_EQ(t.unreferenced_vertices, 0u);
}


// Many components spread over several of the volume sums' chunks and both threads, with the
// parts interleaved: the count is known by construction, and one thread gives the same mesh.
TEST(Voids, ManyComponentsAnyThreadCount) {
  TriangleMesh m = octahedron(500.0f);
  std::size_t expected_removed = 0, expected_triangles = m.triangles.size();
  for (int i = 0; i < 9000; ++i) {
    const Vec3f c{float(i % 30) * 3 - 45, float(i / 30 % 30) * 3 - 45, float(i / 900) * 3 - 15};
    const int kind = (i * 7) % 3;  // 0: small void (removed), 1: big void, 2: small droplet
    const TriangleMesh part = octahedron(kind == 1 ? 1.4f : 0.5f, c, kind != 2);
    expected_removed += kind == 0;
    if (kind != 0) expected_triangles += part.triangles.size();
    const uint32_t base = uint32_t(m.vertices.size());
    m.vertices.insert(m.vertices.end(), part.vertices.begin(), part.vertices.end());
    for (Triangle t : part.triangles) m.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
  }
  ASSERT_GT(m.triangles.size(), std::size_t(1) << 16);  // more than one chunk
  TriangleMesh serial = m;
  std::size_t removed_serial = 0;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    removed_serial = remove_small_voids(serial, 1.0);
  }
  EXPECT_EQ(remove_small_voids(m, 1.0), expected_removed);
  EXPECT_EQ(removed_serial, expected_removed);
  EXPECT_EQ(m.triangles.size(), expected_triangles);
  EXPECT_EQ(m.triangles, serial.triangles);
  EXPECT_EQ(m.vertices, serial.vertices);
  EXPECT_TRUE(analyze_topology(m).watertight());
}

// Kernel-field blobs: the small outward components without a particle inside, or smaller than
// the inner ball, go; everything else stays, whatever its size or orientation.
TEST(Voids, UnsupportedBlobsAreRemovedAndSupportedComponentsKept) {
  TriangleMesh m = octahedron(5.0f, {0, 0, 0});  // volume 167: above max_volume, kept untested
  const std::vector<std::pair<TriangleMesh, bool>> parts = {
      {octahedron(1.0f, {10, 0, 0}), false},        // volume 1.33, holds particle (10.2, 0, 0): kept
      {octahedron(1.0f, {20, 0, 0}), true},         // volume 1.33, no particle inside: removed
      {octahedron(0.3f, {30, 0, 0}), true},         // volume 0.036 < min_volume, holds one: removed
      {octahedron(0.5f, {40, 0, 0}, true), false},  // a small void (inward): not this function's
  };
  std::size_t expected_triangles = m.triangles.size();
  for (const auto& [part, removed] : parts) {
    const uint32_t base = uint32_t(m.vertices.size());
    m.vertices.insert(m.vertices.end(), part.vertices.begin(), part.vertices.end());
    for (Triangle t : part.triangles) m.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
    if (!removed) expected_triangles += part.triangles.size();
  }
  // Particles: inside the big one, inside the first and third blobs, and next to (outside) the
  // second one, within its bounding box's corner.
  const std::vector<Vec3f> particles = {{0, 0, 0}, {10.2f, 0, 0}, {30.05f, 0, 0}, {20.8f, 0.8f, 0.8f}};
  const HashGrid grid(particles, 2.0f);
  EXPECT_EQ(remove_unsupported_blobs(m, grid, /*max_volume=*/2.0, /*min_volume=*/0.1), 2u);
  EXPECT_EQ(m.triangles.size(), expected_triangles);
  EXPECT_EQ(m.vertices.size(), 18u);  // 5 octahedra of 6 vertices, 2 removed
  const TopologyReport t = analyze_topology(m);
  EXPECT_TRUE(t.watertight());
  EXPECT_EQ(t.components, 3u);
  EXPECT_EQ(t.unreferenced_vertices, 0u);
  EXPECT_EQ(points_outside(m, std::span<const Vec3f>(particles.data(), 2)), 0u);
}

}  // namespace
}  // namespace meniscus
