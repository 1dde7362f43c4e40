// Tests of the A and B operators against a dense reference assembled per triangle.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <map>
#include <random>
#include <set>

#include "common/primitives.hpp"
#include "mesh/adjacency_backend.hpp"
#include "smooth/adjacency.hpp"
#include "smooth/cotangent_impl.hpp"
#include "smooth/operators.hpp"
#include "smooth/smooth.hpp"

namespace meniscus {
namespace {

// A subdivided octahedron projected on the unit sphere, then perturbed: a closed mesh with
// valences 4 and 6 and irregular triangles.
TriangleMesh perturbed_sphere(int subdivisions, float noise, uint32_t seed) {
  TriangleMesh m;
  m.vertices = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  m.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  for (int s = 0; s < subdivisions; ++s) {
    std::vector<Triangle> next;
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> mid;
    auto midpoint = [&](uint32_t a, uint32_t b) {
      auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      m.vertices.push_back(normalized((m.vertices[a] + m.vertices[b]) * 0.5f));
      return mid[key] = uint32_t(m.vertices.size() - 1);
    };
    for (const Triangle& t : m.triangles) {
      const uint32_t a = midpoint(t[0], t[1]), b = midpoint(t[1], t[2]), c = midpoint(t[2], t[0]);
      next.push_back({t[0], a, c});
      next.push_back({a, t[1], b});
      next.push_back({c, b, t[2]});
      next.push_back({a, b, c});
    }
    m.triangles = next;
  }
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-noise, noise);
  for (auto& v : m.vertices) v += Vec3f{u(rng), u(rng), u(rng)};
  return m;
}

// The mesh without the triangles f with f % every == skip: open fans around the holes.
TriangleMesh with_holes(const TriangleMesh& closed, std::size_t every, std::size_t skip) {
  TriangleMesh open = closed;
  open.triangles.clear();
  for (std::size_t f = 0; f < closed.triangles.size(); ++f)
    if (f % every != skip) open.triangles.push_back(closed.triangles[f]);
  return open;
}

TEST(Adjacency, OctahedronRowsAreSortedNeighbours) {
  const TriangleMesh m = perturbed_sphere(0, 0, 1);
  const Adjacency adj = build_adjacency(m.vertices.size(), m.triangles);
  ASSERT_EQ(adj.vertex_count(), 6u);
  const std::vector<uint32_t> expected0{2, 3, 4, 5};  // all but itself and its antipode 1
  EXPECT_EQ(std::vector<uint32_t>(adj.row(0).begin(), adj.row(0).end()), expected0);
  for (uint32_t i = 0; i < 6; ++i) {
    EXPECT_EQ(adj.row(i).size(), 4u);
    EXPECT_EQ(adj.tri_offsets[i + 1] - adj.tri_offsets[i], 4u);
  }
}

// build_adjacency lays the rows out on the triangle lists' offsets (a closed fan has as many
// neighbours as triangles) and counts them first only when some fan is open: both paths against a
// brute-force reference — rows the sorted distinct neighbours, triangle lists ascending — on a
// closed sphere and on the same sphere with every fifth triangle removed (open fans).
TEST(Adjacency, RowsAndTriangleListsMatchABruteForceReferenceOnClosedAndOpenMeshesOnBothVersions) {
  const TriangleMesh closed = perturbed_sphere(6, 0.01f, 5);
  const TriangleMesh open = with_holes(closed, 5, 2);
  for (const TriangleMesh* m : {&closed, &open}) {
    const std::size_t nv = m->vertices.size();
    ASSERT_GT(nv, 4096u) << "more than one parallel grain";
    std::vector<std::set<uint32_t>> rows(nv);
    std::vector<std::vector<uint32_t>> tris(nv);
    for (uint32_t f = 0; f < m->triangles.size(); ++f)
      for (uint32_t v : m->triangles[f]) {
        tris[v].push_back(f);
        for (uint32_t u : m->triangles[f])
          if (u != v) rows[v].insert(u);
      }
    std::size_t open_fans = 0;
    for (std::size_t i = 0; i < nv; ++i) open_fans += rows[i].size() != tris[i].size();
    EXPECT_EQ(open_fans == 0, m == &closed) << "the closed sphere has only closed fans, the open one not";
    const Adjacency adj = build_adjacency(nv, m->triangles);
    ASSERT_EQ(adj.vertex_count(), nv);
    for (uint32_t i = 0; i < nv; ++i) {
      ASSERT_EQ(std::vector<uint32_t>(adj.row(i).begin(), adj.row(i).end()),
                std::vector<uint32_t>(rows[i].begin(), rows[i].end()))
          << (m == &closed ? "closed" : "open") << " row " << i;
      ASSERT_EQ(std::vector<uint32_t>(adj.tri_ids.begin() + adj.tri_offsets[i], adj.tri_ids.begin() + adj.tri_offsets[i + 1]),
                tris[i])
          << (m == &closed ? "closed" : "open") << " triangles of " << i;
    }
    // The shared version (mesh/adjacency_backend.hpp, the device's) run on the host: the same arrays.
    MeshBuffers<Host> mesh;
    mesh.vertex_count = nv;
    mesh.triangle_count = m->triangles.size();
    mesh.vertices.upload(m->vertices.data(), nv);
    mesh.triangles.upload(m->triangles.data()->data(), 3 * m->triangles.size());
    const AdjacencyBuffers<Host> shared = build_adjacency(Host{}, mesh);
    auto same = [](const HostBuffer<uint32_t>& a, const UninitVector<uint32_t>& b) {
      return a.size() == b.size() && std::equal(b.begin(), b.end(), a.data());
    };
    EXPECT_TRUE(same(shared.offsets, adj.offsets));
    EXPECT_TRUE(same(shared.neighbors, adj.neighbors));
    EXPECT_TRUE(same(shared.tri_offsets, adj.tri_offsets));
    EXPECT_TRUE(same(shared.tri_ids, adj.tri_ids));
  }
}

TEST(CotanOperator, RegularOctahedronHasTheClosedFormWeights) {
  const TriangleMesh m = perturbed_sphere(0, 0, 1);
  const Adjacency adj = build_adjacency(m.vertices.size(), m.triangles);
  const CotanOperator op = build_cotan_operator(m.vertices, m.triangles, adj, 0.0f);
  const float cot60 = 1.0f / std::sqrt(3.0f);
  for (float w : op.w) EXPECT_NEAR(w, 2 * cot60, 1e-5f);
  const float area = std::sqrt(3.0f) / 4 * 2;  // equilateral, side √2
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_NEAR(op.area[i], 4 * area / 3, 1e-5f);
    EXPECT_NEAR(w_diagonal(adj, op, uint32_t(i)), -8 * cot60, 1e-5f);
  }
}

TEST(CotanOperator, MatchesADenseReferenceOnAnIrregularMesh) {
  const TriangleMesh m = perturbed_sphere(2, 0.04f, 9);
  const std::size_t n = m.vertices.size();
  const Adjacency adj = build_adjacency(n, m.triangles);
  const CotanOperator op = build_cotan_operator(m.vertices, m.triangles, adj, 0.0f);

  // Dense W and D assembled by scattering per triangle (the textbook form).
  std::vector<double> W(n * n, 0.0), D(n, 0.0);
  for (const Triangle& t : m.triangles)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = t[k], b = t[(k + 1) % 3], c = t[(k + 2) % 3];
      const double cot = clamped_cotangent(m.vertices[c], m.vertices[a], m.vertices[b]);  // opposite edge (a,b)
      W[a * n + b] += cot;
      W[b * n + a] += cot;
      D[a] += clamped_area(m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]]) / 3.0;
    }
  for (std::size_t i = 0; i < n; ++i) {
    double s = 0;
    for (std::size_t j = 0; j < n; ++j) s += W[i * n + j];
    W[i * n + i] = -s;
  }
  for (std::size_t i = 0; i < n; ++i) ASSERT_NEAR(op.area[i], D[i], 1e-5);

  // B = W D⁻¹ W; compare diag(B), B x and the energy.
  std::vector<double> Bx(n * 3, 0.0), Wx(n * 3, 0.0);
  for (std::size_t k = 0; k < n; ++k)
    for (std::size_t j = 0; j < n; ++j)
      for (int c = 0; c < 3; ++c) Wx[k * 3 + c] += W[k * n + j] * m.vertices[j][c];
  double energy = 0;
  for (std::size_t k = 0; k < n; ++k)
    for (int c = 0; c < 3; ++c) energy += Wx[k * 3 + c] * Wx[k * 3 + c] / D[k];
  for (std::size_t i = 0; i < n; ++i) {
    double bii = 0;
    for (std::size_t k = 0; k < n; ++k) {
      bii += W[i * n + k] * W[k * n + i] / D[k];
      for (int c = 0; c < 3; ++c) Bx[i * 3 + c] += W[i * n + k] / D[k] * Wx[k * 3 + c];
    }
    EXPECT_NEAR(b_diagonal(adj, op, uint32_t(i)), bii, 1e-3 * std::abs(bii));
    const Vec3f row = bilaplacian_row(adj, op, m.vertices, uint32_t(i));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(row[c], Bx[i * 3 + c], 1e-3 * (1 + std::abs(Bx[i * 3 + c])));
  }
  std::vector<Vec3f> wx(n);
  apply_w(adj, op, m.vertices, wx);
  EXPECT_NEAR(bilaplacian_energy(op, wx), energy, 1e-4 * energy);
}

// The operator from corner lists (adopt_corner_lists: what the CPU sweeps use) is bit for bit the
// one from the triangle lists (cotan_row over MeshRows: what the CUDA backend uses), on a closed
// mesh and an open one with a degenerate triangle.
TEST(CotanOperator, CornerListsGiveTheTriangleListsOperatorBitForBit) {
  const TriangleMesh closed = perturbed_sphere(4, 0.02f, 7);
  TriangleMesh open = with_holes(closed, 7, 3);
  open.triangles.push_back({5, 5, 17});  // a corner repeated: no slot, as in cotan_row
  auto same = [](const CotanOperator& a, const CotanOperator& b, const char* what) {
    ASSERT_EQ(a.w.size(), b.w.size()) << what;
    for (std::size_t e = 0; e < a.w.size(); ++e) ASSERT_EQ(a.w[e], b.w[e]) << what << " entry " << e;
    for (std::size_t i = 0; i < a.area.size(); ++i) {
      ASSERT_EQ(a.area[i], b.area[i]) << what << " vertex " << i;
    }
  };
  for (const TriangleMesh* m : {&closed, static_cast<const TriangleMesh*>(&open)}) {
    const std::size_t nv = m->vertices.size();
    const Adjacency lists = build_adjacency(nv, m->triangles);
    const CotanOperator reference = build_cotan_operator(m->vertices, m->triangles, lists, 0.0f);
    Adjacency corners = build_adjacency(nv, m->triangles);
    ASSERT_TRUE(adopt_corner_lists(corners, m->triangles));
    EXPECT_TRUE(corners.tri_ids.empty() && corners.tri_offsets.empty()) << "the triangle lists are freed";
    ASSERT_EQ(corners.corner_offsets.size(), nv + 1);
    EXPECT_EQ(corners.corners.size(), 3 * m->triangles.size());
    same(build_cotan_operator(m->vertices, {}, corners, 0.0f), reference, "plain");
    // The CPU sums W_ii again from the row (w_diagonal); the CUDA backend stores what cotan_row
    // returns: the same bits.
    const MeshRows rows{lists.offsets.data(), lists.neighbors.data(), lists.tri_offsets.data(), lists.tri_ids.data(),
                        m->triangles.data()->data()};
    std::vector<float> w(lists.entry_count());
    for (uint32_t i = 0; i < nv; ++i) {
      float diag = 0, area = 0;
      cotan_row(rows, m->vertices.data(), i, w.data(), &diag, &area);
      ASSERT_EQ(diag, w_diagonal(lists, reference, i)) << "vertex " << i;
    }

  }
}

// The 16-bit neighbour lists read back every entry: near ones (within ±30000 of the row's vertex,
// the bounds included) and far ones (from ±30001 on, listed aside per chunk of 4096 rows: the
// first 2767 of a chunk by index, the rest by search — this test's chunks have thousands), in
// rows of every length (empty too), at the first and last rows.
TEST(Adjacency, CompactNeighboursReadBackEveryEntry) {
  const uint32_t nv = 100000;
  Adjacency adj;
  adj.offsets.push_back(0);
  std::vector<uint32_t> entries;
  std::mt19937 rng(5);
  std::size_t far = 0;
  for (uint32_t i = 0; i < nv; ++i) {
    const int64_t steps[] = {1, -1, 30000, -30000, 30001, -30001, 40000, -99999, 99999, 7};
    const std::size_t n = (i * 7) % 11;  // 0 .. 10 entries
    for (std::size_t k = 0; k < n; ++k) {
      int64_t j = k < 10 ? int64_t(i) + steps[k] : int64_t(rng() % nv);
      if (j < 0 || j >= int64_t(nv) || j == int64_t(i)) j = (int64_t(i) + 1) % nv;
      far += std::abs(j - int64_t(i)) > 30000;
      entries.push_back(uint32_t(j));
    }
    adj.offsets.push_back(uint32_t(entries.size()));
  }
  adj.neighbors.assign(entries.begin(), entries.end());
  adj.compact_neighbors();
  EXPECT_TRUE(adj.neighbors.empty()) << "the 32-bit lists are freed";
  EXPECT_EQ(adj.entry_count(), entries.size());
  EXPECT_EQ(adj.compact.delta.size(), entries.size());
  EXPECT_EQ(adj.compact.far_entry.size(), far);
  EXPECT_GT(far, entries.size() / 10);
  std::size_t searched = 0;  // far entries past the first 2767 of their chunk
  for (std::size_t q = 0; q + 1 < adj.compact.chunk_far.size(); ++q)
    searched += std::max<std::size_t>(adj.compact.chunk_far[q + 1] - adj.compact.chunk_far[q], 2767) - 2767;
  EXPECT_GT(searched, far / 4) << "both ways of finding a far entry are read";
  EXPECT_LT(searched, far * 3 / 4);
  EXPECT_EQ(adj.compact.memory_bytes(), 2 * entries.size() + 8 * far + 4 * ((nv + 4095) / 4096 + 1))
      << "2 bytes an entry, 8 a far one, 4 a chunk of rows";
  std::size_t checked = 0;
  adj.with_neighbors([&](const auto& neighbors) {
    for (uint32_t i = 0; i < nv; ++i)
      for (uint32_t e = adj.offsets[i]; e < adj.offsets[i + 1]; ++e, ++checked)
        ASSERT_EQ(neighbor_at(neighbors, i, e), entries[e]) << "row " << i << " entry " << e;
  });
  EXPECT_EQ(checked, entries.size());
}

// The smoothing's set-up compacts the rows first, then adopts corner lists in that form: the same
// corner lists as from the full lists.
TEST(Adjacency, CompactRowsAdoptTheFullRowsCornerLists) {
  const TriangleMesh sphere = perturbed_sphere(7, 0.02f, 5);
  const std::size_t nv = sphere.vertices.size();
  // A numbering at random: a fifth or more of the entries far (stored aside), the rest near.
  std::vector<uint32_t> rank(nv);
  for (std::size_t n = 0; n < nv; ++n) rank[n] = uint32_t(n);
  std::shuffle(rank.begin(), rank.end(), std::mt19937(5));
  std::vector<Triangle> triangles = sphere.triangles;
  for (Triangle& t : triangles)
    for (uint32_t& v : t) v = rank[v];
  Adjacency full = build_adjacency(nv, triangles);
  Adjacency compact = build_adjacency(nv, triangles);
  ASSERT_TRUE(corner_lists_fit(compact));
  compact.compact_neighbors();
  ASSERT_FALSE(compact.compact.far_entry.empty());
  ASSERT_FALSE(compact.compact.far_entry.size() == compact.entry_count());
  ASSERT_TRUE(adopt_corner_lists(full, triangles));
  ASSERT_TRUE(adopt_corner_lists(compact, triangles));
  EXPECT_TRUE(full.corner_offsets == compact.corner_offsets);
  for (std::size_t k = 0; k < full.corners.size(); ++k) {
    ASSERT_EQ(full.corners[k].j, compact.corners[k].j) << k;
    ASSERT_EQ(full.corners[k].l, compact.corners[k].l) << k;
  }
  EXPECT_TRUE(full.corner_offsets == compact.corner_offsets);
}

// On a mesh numbered at random (most of its 65k vertices' neighbours far in the numbering), the
// compact lists give the operator, W x and the B rows bit for bit, and so the whole smoothing.
TEST(CotanOperator, CompactNeighboursGiveTheSameOperatorProductsAndSmoothing) {
  const TriangleMesh sphere = perturbed_sphere(7, 0.02f, 3);
  const std::size_t nv = sphere.vertices.size();
  ASSERT_GT(nv, 65536u);
  std::vector<uint32_t> rank(nv);
  for (std::size_t n = 0; n < nv; ++n) rank[n] = uint32_t(n);
  std::shuffle(rank.begin(), rank.end(), std::mt19937(11));
  TriangleMesh m;
  m.vertices.resize(nv);
  for (std::size_t n = 0; n < nv; ++n) m.vertices[rank[n]] = sphere.vertices[n];
  m.triangles = sphere.triangles;
  for (Triangle& t : m.triangles)
    for (uint32_t& v : t) v = rank[v];
  Adjacency plain = build_adjacency(nv, m.triangles);
  ASSERT_TRUE(adopt_corner_lists(plain, m.triangles));
  Adjacency compact = build_adjacency(nv, m.triangles);
  ASSERT_TRUE(adopt_corner_lists(compact, m.triangles));
  compact.compact_neighbors();
  EXPECT_GT(compact.compact.far_entry.size(), compact.entry_count() / 5);
  const CotanOperator a = build_cotan_operator(m.vertices, {}, plain, 0.0f);
  const CotanOperator b = build_cotan_operator(m.vertices, {}, compact, 0.0f);
  ASSERT_TRUE(a.w == b.w && a.area == b.area);
  std::vector<Vec3f> wa(nv), wb(nv);
  apply_w(plain, a, m.vertices, wa);
  apply_w(compact, b, m.vertices, wb);
  ASSERT_TRUE(wa == wb);
  for (uint32_t i = 0; i < nv; i += 97) {
    ASSERT_EQ(bilaplacian_row(plain, a, m.vertices, i), bilaplacian_row(compact, b, m.vertices, i)) << i;
    ASSERT_EQ(plain.with_neighbors([&](const auto& n) { return bilaplacian_row_from_wx(plain, n, a, wa, i); }),
              compact.with_neighbors([&](const auto& n) { return bilaplacian_row_from_wx(compact, n, b, wb, i); }))
        << i;
    ASSERT_EQ(b_diagonal(plain, a, i), b_diagonal(compact, b, i)) << i;
  }
  // The sweeps' one pass (the row of B x and B_ii together) gives the bits of the two functions
  // the CUDA backend calls apart (bilaplacian_row_from_wx, and bilaplacian_diagonal_row for the
  // B_ii it stores).
  compact.with_neighbors([&](const auto& n) {
    for (uint32_t i = 0; i < nv; ++i) {
      float b_ii = 0;
      const Vec3f row = bilaplacian_row_and_diagonal(compact.offsets.data(), n, b.w.data(), w_diagonal(compact, b, i),
                                                     b.area.data(), wb.data(), i, &b_ii);
      ASSERT_EQ(row, bilaplacian_row_from_wx(compact, n, b, wb, i)) << i;
      ASSERT_EQ(b_ii, b_diagonal(compact, b, i)) << i;
    }
  });
  SmoothOptions o;
  o.steps_a = 3;
  o.steps_b = 3;
  o.steps_free = 1;
  std::vector<Vec3f> x[2] = {m.vertices, m.vertices};
  for (int c = 0; c < 2; ++c) {
    o.compact_neighbors = c == 1;
    std::vector<Triangle> t = m.triangles;
    smooth_surface(x[c], t, nullptr, o);
    EXPECT_TRUE(t == m.triangles);
  }
  std::size_t moved = 0;
  for (std::size_t i = 0; i < nv; ++i) {
    for (int k = 0; k < 3; ++k) ASSERT_EQ(std::bit_cast<uint32_t>(x[0][i][k]), std::bit_cast<uint32_t>(x[1][i][k])) << i;
    moved += !(x[1][i] == m.vertices[i]);
  }
  EXPECT_GT(moved, nv / 2);
}

// A row longer than a byte can index keeps the triangle lists (adopt_corner_lists declines and
// changes nothing); the operator then comes from them as before.
TEST(CotanOperator, ARowTooLongForCornerListsKeepsTheTriangleLists) {
  TriangleMesh fan;  // a cone: apex 0 over a ring of 300 vertices, closed by a second apex
  const uint32_t ring = 300;
  fan.vertices.push_back({0, 0, 1});
  fan.vertices.push_back({0, 0, -1});
  for (uint32_t k = 0; k < ring; ++k) {
    const float a = 6.2831853f * float(k) / float(ring);
    fan.vertices.push_back({std::cos(a), std::sin(a), 0});
  }
  for (uint32_t k = 0; k < ring; ++k) {
    const uint32_t a = 2 + k, b = 2 + (k + 1) % ring;
    fan.triangles.push_back({0, a, b});
    fan.triangles.push_back({1, b, a});
  }
  Adjacency adj = build_adjacency(fan.vertices.size(), fan.triangles);
  ASSERT_GT(adj.row(0).size(), std::size_t(kMaxCornerRow));
  const std::size_t tri_ids = adj.tri_ids.size();
  EXPECT_FALSE(adopt_corner_lists(adj, fan.triangles));
  EXPECT_EQ(adj.tri_ids.size(), tri_ids);
  EXPECT_TRUE(adj.corner_offsets.empty());
  const CotanOperator op = build_cotan_operator(fan.vertices, fan.triangles, adj, 0.0f);
  float sum = 0;
  for (uint32_t e = adj.offsets[0]; e < adj.offsets[1]; ++e) sum += op.w[e];
  EXPECT_EQ(w_diagonal(adj, op, 0), -sum);
  EXPECT_GT(op.area[0], 0.0f);
}

TEST(CotanOperator, ClampsSliversAndObtuseAngles) {
  // A needle triangle: the angle at the apex is ~0 (huge cotangent) and one angle is obtuse.
  const Vec3f a{0, 0, 0}, b{1, 0, 0}, c{0.5f, 1e-6f, 0};
  EXPECT_LE(clamped_cotangent(a, b, c), 1.0f / kMinSine + 1e-3f);
  EXPECT_GE(clamped_cotangent(c, a, b), kMinCotangent);  // obtuse: cot < 0 is clamped
  EXPECT_GE(clamped_area(a, b, c), 0.5f * kMinSine * 1.0f * length(c - a) - 1e-6f);
}

}  // namespace
}  // namespace meniscus
