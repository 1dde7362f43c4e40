// meniscus tests — the extraction tables: the A15 tile (Williams 2008), the Kuhn split and the
// Marching Tetrahedra cases (Doi & Koide 1991), the generated Marching Cubes table (Lorensen &
// Cline 1987), and the watertightness of each on random fields.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include "extract/cube_cases.hpp"
#include "extract/extract.hpp"
#include "extract/tetrahedron_cases.hpp"
#include "extract/tile_table.hpp"
#include "meniscus/quality.hpp"

namespace meniscus {
namespace {

using Vec3d = std::array<double, 3>;

Vec3d sub(Vec3d a, Vec3d b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3d cross3(Vec3d a, Vec3d b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double dot3(Vec3d a, Vec3d b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
double det3(Vec3d a, Vec3d b, Vec3d c) { return dot3(a, cross3(b, c)); }

/// Position of a tile vertex in units of the cell edge.
Vec3d a15_position(const LatticeSample& p) {
  return {p.dx + kA15SampleQuarters[p.s][0] / 4.0, p.dy + kA15SampleQuarters[p.s][1] / 4.0,
          p.dz + kA15SampleQuarters[p.s][2] / 4.0};
}

/// 384 × the signed volume of an A15 tetrahedron (= 6 · 4³ · volume), exact in integers.
long long a15_volume384(const LatticeSample (&t)[4]) {
  long long q[4][3];
  for (int v = 0; v < 4; ++v) {
    q[v][0] = 4 * t[v].dx + kA15SampleQuarters[t[v].s][0];
    q[v][1] = 4 * t[v].dy + kA15SampleQuarters[t[v].s][1];
    q[v][2] = 4 * t[v].dz + kA15SampleQuarters[t[v].s][2];
  }
  long long m[3][3];
  for (int r = 0; r < 3; ++r)
    for (int a = 0; a < 3; ++a) m[r][a] = q[r + 1][a] - q[0][a];
  return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
         m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

TEST(TileTable, SampleQuartersMatchTheFieldLattice) {
  for (int s = 0; s < 8; ++s)
    for (int a = 0; a < 3; ++a) EXPECT_EQ(float(kA15SampleQuarters[s][a]) / 4.0f, kA15Samples[s][a]) << "sample " << s;
}

TEST(TileTable, TetrahedraArePositiveAndFillTheCellExactly) {
  long long total = 0;
  for (int t = 0; t < kA15TetCount; ++t) {
    const long long v = a15_volume384(kA15Tets[t]);
    EXPECT_GT(v, 0) << "tetrahedron " << t;
    total += v;
  }
  EXPECT_EQ(total, 384) << "46 volumes must sum to one cell (a³), got " << double(total) / 384.0;
}

TEST(TileTable, DihedralAnglesAreAcute) {
  double lo = 180, hi = 0;
  for (const auto& t : kA15Tets) {
    Vec3d p[4];
    for (int v = 0; v < 4; ++v) p[v] = a15_position(t[v]);
    for (const auto& e : kTetEdgeVertices) {
      int o[2], k = 0;
      for (int v = 0; v < 4; ++v)
        if (v != e[0] && v != e[1]) o[k++] = v;
      const Vec3d axis = sub(p[e[1]], p[e[0]]);
      // Dihedral angle at edge e = angle between the normals of the two faces, seen along e.
      const Vec3d n1 = cross3(axis, sub(p[o[0]], p[e[0]])), n2 = cross3(axis, sub(p[o[1]], p[e[0]]));
      const double angle = std::acos(dot3(n1, n2) / std::sqrt(dot3(n1, n1) * dot3(n2, n2))) * 180 / std::numbers::pi;
      lo = std::min(lo, angle);
      hi = std::max(hi, angle);
    }
  }
  EXPECT_GE(lo, 53.0) << "min dihedral " << lo;
  EXPECT_LE(hi, 79.0) << "max dihedral " << hi;
  EXPECT_LT(hi, 90.0);
  std::printf("[ measured ] A15 dihedral angles %.2f..%.2f deg\n", lo, hi);
}

TEST(TileTable, TranslatesTileThePeriodWithoutGapsOrOverlaps) {
  // Barycentric coordinates of every translated tetrahedron that can reach the unit cell.
  struct Tet {
    Vec3d origin;
    Vec3d inv[3];  // rows of the inverse of [p1-p0, p2-p0, p3-p0]
  };
  std::vector<Tet> tets;
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx)
        for (const auto& t : kA15Tets) {
          Vec3d p[4];
          for (int v = 0; v < 4; ++v) {
            p[v] = a15_position(t[v]);
            p[v] = {p[v][0] + dx, p[v][1] + dy, p[v][2] + dz};
          }
          const Vec3d a = sub(p[1], p[0]), b = sub(p[2], p[0]), c = sub(p[3], p[0]);
          const double det = det3(a, b, c);
          Tet tet{p[0], {}};
          // Inverse via cross products: rows (b×c, c×a, a×b) / det.
          const Vec3d r0 = cross3(b, c), r1 = cross3(c, a), r2 = cross3(a, b);
          for (int i = 0; i < 3; ++i) {
            tet.inv[0][i] = r0[i] / det;
            tet.inv[1][i] = r1[i] / det;
            tet.inv[2][i] = r2[i] / det;
          }
          tets.push_back(tet);
        }
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  constexpr int kPoints = 20000;
  int gaps = 0, overlaps = 0;
  for (int i = 0; i < kPoints; ++i) {
    const Vec3d x{u(rng), u(rng), u(rng)};
    int loose = 0, strict = 0;
    for (const Tet& t : tets) {
      const Vec3d d = sub(x, t.origin);
      const double l1 = dot3(t.inv[0], d), l2 = dot3(t.inv[1], d), l3 = dot3(t.inv[2], d), l0 = 1 - l1 - l2 - l3;
      const double m = std::min({l0, l1, l2, l3});
      loose += m > -1e-9;
      strict += m > 1e-9;
    }
    gaps += loose == 0;
    overlaps += strict > 1;
  }
  EXPECT_EQ(gaps, 0) << "points in no tetrahedron out of " << kPoints;
  EXPECT_EQ(overlaps, 0) << "points in two tetrahedra out of " << kPoints;
}

TEST(TileTable, FiftyFourEdgeTypesWithFiveOrSixTetrahedraEach) {
  EXPECT_EQ(kA15EdgeTypeCount, 54);
  // Around a canonical edge at cell 0 lie the tetrahedra of the cells c with c + base = 0: one
  // per (tetrahedron, edge) of the table that maps to that type.
  std::vector<int> incident(kA15EdgeTypeCount, 0);
  for (const auto& edges : kA15EdgeTable.tet_edges)
    for (const TetEdge& e : edges) {
      ASSERT_LT(e.type, kA15EdgeTypeCount);
      ++incident[e.type];
    }
  std::map<int, int> histogram;
  for (int n : incident) ++histogram[n];
  EXPECT_EQ(histogram[5], 48);
  EXPECT_EQ(histogram[6], 6);
  EXPECT_EQ(histogram.size(), 2u);
}

TEST(TileTable, EdgeTypesAreCanonicalAndDecodeToTheTetrahedronEdges) {
  for (int t = 0; t < kA15EdgeTypeCount; ++t) {
    const LatticeEdge e = kA15EdgeTable.types[t];
    const LatticeSample first{0, 0, 0, e.s0}, second{e.dx, e.dy, e.dz, e.s1};
    EXPECT_TRUE(sample_less(first, second)) << "type " << t << " is not in canonical order";
    if (t > 0) {
      EXPECT_TRUE(edge_less(kA15EdgeTable.types[t - 1], e)) << "types not sorted/unique at " << t;
    }
    const Vec3d d = sub(a15_position(second), a15_position(first));
    const double length = std::sqrt(dot3(d, d));
    EXPECT_GE(length, 0.5 - 1e-12) << "type " << t;  // marching-tiles.md: 0.5a .. 0.61a
    EXPECT_LE(length, 0.62) << "type " << t;
  }
  // Decoding a tetrahedron edge's key gives back its two samples, from any owning cell.
  const Vec3i cell{-5, 17, 3};
  for (int t = 0; t < kA15TetCount; ++t)
    for (int k = 0; k < 6; ++k) {
      const TetEdge& te = kA15EdgeTable.tet_edges[t][k];
      const uint64_t key = edge_key(cell, 0) + te.key_delta;
      EXPECT_EQ(key, edge_key(cell + Vec3i{te.dx, te.dy, te.dz}, te.type));
      Vec3i c0, c1;
      int s0 = 0, s1 = 0;
      edge_key_samples(key, true, &c0, &s0, &c1, &s1);
      const LatticeSample a = kA15Tets[t][kTetEdgeVertices[k][0]], b = kA15Tets[t][kTetEdgeVertices[k][1]];
      const Vec3i ca = cell + Vec3i{a.dx, a.dy, a.dz}, cb = cell + Vec3i{b.dx, b.dy, b.dz};
      const bool same = c0 == ca && s0 == a.s && c1 == cb && s1 == b.s;
      const bool swapped = c0 == cb && s0 == b.s && c1 == ca && s1 == a.s;
      EXPECT_TRUE(same || swapped) << "tetrahedron " << t << " edge " << k;
    }
}

TEST(KuhnTetrahedra, SixPositiveTetrahedraFillTheCube) {
  int total = 0;
  for (const auto& t : kKuhnTets) {
    const int v = kuhn_tet_volume6(t);
    EXPECT_GT(v, 0);
    total += v;
    // All share the main diagonal.
    bool has0 = false, has7 = false;
    for (const LatticeSample& p : t) {
      has0 |= p.dx == 0 && p.dy == 0 && p.dz == 0;
      has7 |= p.dx == 1 && p.dy == 1 && p.dz == 1;
    }
    EXPECT_TRUE(has0 && has7);
  }
  EXPECT_EQ(total, 6) << "volumes must sum to the cube";
  EXPECT_EQ(kKuhnEdgeTable.type_count, 7);
  for (int t = 0; t < 7; ++t) {
    const LatticeEdge e = kKuhnEdgeTable.types[t];
    EXPECT_EQ(cubic_edge_type(e.dx, e.dy, e.dz), t);
  }
}

/// Marching Tetrahedra on a tetrahedron p[4] with values phi[4]: triangle corner positions.
std::vector<std::array<Vec3d, 3>> march_tet(const std::array<Vec3d, 4>& p, const double (&phi)[4], double iso) {
  int c = 0;
  for (int v = 0; v < 4; ++v) c |= int(phi[v] < iso) << v;
  std::vector<std::array<Vec3d, 3>> tris;
  const TetCase& tc = kTetCases.cases[c];
  for (int k = 0; k < tc.count; ++k) {
    std::array<Vec3d, 3> tri;
    for (int j = 0; j < 3; ++j) {
      const int a = kTetEdgeVertices[tc.edges[k][j]][0], b = kTetEdgeVertices[tc.edges[k][j]][1];
      const double t = double(edge_parameter(float(phi[a]), float(phi[b]), float(iso), kEdgeClamp));
      for (int ax = 0; ax < 3; ++ax) tri[j][ax] = p[a][ax] + t * (p[b][ax] - p[a][ax]);
    }
    tris.push_back(tri);
  }
  return tris;
}

TEST(TetrahedronCases, CornersAreExactlyTheCrossingEdges) {
  for (int c = 0; c < 16; ++c) {
    const int n_in = std::popcount(unsigned(c));
    const TetCase& tc = kTetCases.cases[c];
    EXPECT_EQ(tc.count, n_in == 0 || n_in == 4 ? 0 : (n_in == 2 ? 2 : 1)) << "case " << c;
    std::set<int> used;
    for (int k = 0; k < tc.count; ++k)
      for (int j = 0; j < 3; ++j) used.insert(tc.edges[k][j]);
    std::set<int> crossing;
    for (int e = 0; e < 6; ++e)
      if (((c >> kTetEdgeVertices[e][0]) & 1) != ((c >> kTetEdgeVertices[e][1]) & 1)) crossing.insert(e);
    EXPECT_EQ(used, crossing) << "case " << c;
  }
}

TEST(TetrahedronCases, NormalsPointTowardLargerPhiOnAnyPositiveTetrahedron) {
  // A linear field φ = g·x + b restricted to a tetrahedron is what Marching Tetrahedra
  // interpolates exactly: each triangle lies on the plane φ = iso and must face along +g. Tried on
  // the 46 tile tetrahedra and on random positive ones, for all 16 cases.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<std::array<Vec3d, 4>> shapes;
  for (const auto& t : kA15Tets)
    shapes.push_back({a15_position(t[0]), a15_position(t[1]), a15_position(t[2]), a15_position(t[3])});
  while (shapes.size() < 146) {
    std::array<Vec3d, 4> p;
    for (auto& v : p) v = {u(rng), u(rng), u(rng)};
    const double d = det3(sub(p[1], p[0]), sub(p[2], p[0]), sub(p[3], p[0]));
    if (std::abs(d) < 0.05) continue;
    if (d < 0) std::swap(p[2], p[3]);
    shapes.push_back(p);
  }
  int checked = 0;
  for (const auto& p : shapes) {
    for (int trial = 0; trial < 40; ++trial) {
      const Vec3d g{u(rng), u(rng), u(rng)};
      if (dot3(g, g) < 0.01) continue;
      double phi[4];
      for (int v = 0; v < 4; ++v) phi[v] = dot3(g, p[v]);
      const double iso = phi[0] + (phi[3] - phi[0]) * (0.5 + 0.45 * u(rng)) + 0.3 * u(rng) * (phi[1] - phi[2]);
      for (const auto& tri : march_tet(p, phi, iso)) {
        const Vec3d n = cross3(sub(tri[1], tri[0]), sub(tri[2], tri[0]));
        EXPECT_GT(dot3(n, g), 0) << "triangle faces toward smaller φ";
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 2000);
}

TEST(TetrahedronCases, QuadHalvesShareTheirDiagonalInOppositeDirections) {
  for (int c = 0; c < 16; ++c) {
    const TetCase& tc = kTetCases.cases[c];
    if (tc.count != 2) continue;
    std::map<std::pair<int, int>, int> directed;
    for (int k = 0; k < 2; ++k)
      for (int j = 0; j < 3; ++j) ++directed[{tc.edges[k][j], tc.edges[k][(j + 1) % 3]}];
    int shared = 0;
    for (const auto& [e, n] : directed) {
      EXPECT_EQ(n, 1) << "case " << c;
      shared += directed.count({e.second, e.first}) != 0;
    }
    EXPECT_EQ(shared, 2) << "case " << c;  // the diagonal, once each way
  }
}

// --- Marching Cubes table -----------------------------------------------------------------------

TEST(MarchingCubesTable, EveryCaseIsAClosedPatchBoundedByTheFaceSegments) {
  int max_triangles = 0;
  for (int c = 0; c < 256; ++c) {
    const CubeCase& cc = kCubeCases.cases[c];
    max_triangles = std::max<int>(max_triangles, cc.count);
    std::map<std::pair<int, int>, int> directed;
    std::set<int> used;
    for (int k = 0; k < cc.count; ++k)
      for (int j = 0; j < 3; ++j) {
        ++directed[{cc.edges[k][j], cc.edges[k][(j + 1) % 3]}];
        used.insert(cc.edges[k][j]);
      }
    std::set<int> crossing;
    for (int e = 0; e < 12; ++e)
      if (((c >> kCubeEdgeCorners[e][0]) & 1) != ((c >> kCubeEdgeCorners[e][1]) & 1)) crossing.insert(e);
    EXPECT_EQ(used, crossing) << "case " << c;

    std::set<std::pair<int, int>> segments;
    for (int f = 0; f < 6; ++f) {
      int seg[2][2] = {};
      const int n = cube_face_segments(f, c, seg);
      for (int s = 0; s < n; ++s) segments.insert({seg[s][0], seg[s][1]});
    }
    // Each directed edge once; an edge inside the patch also appears reversed; the rest, the
    // patch's boundary, is exactly the face segments (so the loops are closed and lie on faces).
    std::set<std::pair<int, int>> boundary;
    for (const auto& [e, n] : directed) {
      EXPECT_EQ(n, 1) << "case " << c << " edge " << e.first << "-" << e.second;
      if (!directed.count({e.second, e.first})) {
        boundary.insert(e);
      } else {
        EXPECT_EQ((cube_edge_faces(e.first) & cube_edge_faces(e.second)), 0)
            << "case " << c << ": a diagonal lies in a face";
      }
    }
    EXPECT_EQ(boundary, segments) << "case " << c;
  }
  EXPECT_EQ(max_triangles, kCubeMaxTriangles);
}

TEST(MarchingCubesTable, EdgeFaceMasksMatchTheFaceCycles) {
  int expected[12] = {};
  for (int f = 0; f < 6; ++f) {
    int q[4] = {};
    cube_face_corners(f, q);
    for (int k = 0; k < 4; ++k) {
      const int e = cube_edge_of(q[k], q[(k + 1) % 4]);
      ASSERT_GE(e, 0) << "face " << f << " corners " << q[k] << ", " << q[(k + 1) % 4] << " are not adjacent";
      expected[e] |= 1 << f;
    }
  }
  for (int e = 0; e < 12; ++e) EXPECT_EQ(cube_edge_faces(e), expected[e]) << "edge " << e;
}

TEST(MarchingCubesTable, AmbiguousFacesSeparateTheInsideCorners) {
  int ambiguous = 0;
  for (int c = 0; c < 256; ++c)
    for (int f = 0; f < 6; ++f) {
      int q[4] = {};
      cube_face_corners(f, q);
      const bool in0 = (c >> q[0]) & 1, in1 = (c >> q[1]) & 1, in2 = (c >> q[2]) & 1, in3 = (c >> q[3]) & 1;
      if (!(in0 == in2 && in1 == in3 && in0 != in1)) continue;
      ++ambiguous;
      int seg[2][2] = {};
      ASSERT_EQ(cube_face_segments(f, c, seg), 2);
      for (int s = 0; s < 2; ++s) {
        // Both cut edges meet at one inside corner.
        const auto* e0 = kCubeEdgeCorners[seg[s][0]];
        const auto* e1 = kCubeEdgeCorners[seg[s][1]];
        int common = -1;
        for (int a : {e0[0], e0[1]})
          for (int b : {e1[0], e1[1]})
            if (a == b) common = a;
        ASSERT_GE(common, 0);
        EXPECT_TRUE((c >> common) & 1) << "case " << c << " face " << f << " cuts off an outside corner";
      }
    }
  EXPECT_GT(ambiguous, 0);
}

TEST(MarchingCubesTable, NormalsPointTowardLargerPhiForLinearFields) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  std::set<int> cases_seen;
  for (int trial = 0; trial < 20000; ++trial) {
    const Vec3d g{u(rng), u(rng), u(rng)};
    double phi[8];
    for (int k = 0; k < 8; ++k)
      phi[k] = g[0] * cube_corner_coord(k, 0) + g[1] * cube_corner_coord(k, 1) + g[2] * cube_corner_coord(k, 2);
    const double iso = 0.5 * (g[0] + g[1] + g[2]) + 0.8 * u(rng) * (std::abs(g[0]) + std::abs(g[1]) + std::abs(g[2]));
    int c = 0;
    for (int k = 0; k < 8; ++k) c |= int(phi[k] < iso) << k;
    cases_seen.insert(c);
    const CubeCase& cc = kCubeCases.cases[c];
    for (int k = 0; k < cc.count; ++k) {
      Vec3d p[3];
      for (int j = 0; j < 3; ++j) {
        const int a = kCubeEdgeCorners[cc.edges[k][j]][0], b = kCubeEdgeCorners[cc.edges[k][j]][1];
        const double t = double(edge_parameter(float(phi[a]), float(phi[b]), float(iso), kEdgeClamp));
        for (int ax = 0; ax < 3; ++ax)
          p[j][ax] = cube_corner_coord(a, ax) + t * (cube_corner_coord(b, ax) - cube_corner_coord(a, ax));
      }
      EXPECT_GT(dot3(cross3(sub(p[1], p[0]), sub(p[2], p[0])), g), 0) << "case " << c;
    }
  }
  // Planar cuts of a cube reach 104 of the 256 patterns (the threshold functions of 3 variables).
  EXPECT_GE(cases_seen.size(), 100u);
  EXPECT_LE(cases_seen.size(), 104u);
}

// --- global watertightness on random fields --------------------------------------------------------

/// A field over a box of `cells`³ cells with independent random samples in [-1, 1] (background 1,
/// iso 0): every ambiguity a lattice can produce appears many times.
SparseField random_field(SampleLattice::Kind kind, int cells, uint32_t seed) {
  SampleLattice lattice;
  lattice.kind = kind;
  lattice.cell_size = 1;
  const int n = lattice.block_cells(), blocks = (cells + n - 1) / n;
  std::vector<uint64_t> keys;
  for (int z = 0; z < blocks; ++z)
    for (int y = 0; y < blocks; ++y)
      for (int x = 0; x < blocks; ++x) keys.push_back(pack_coords(x, y, z));
  std::sort(keys.begin(), keys.end());
  SparseField field(lattice, keys, 1.0f);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1, 1);
  for (std::size_t b = 0; b < field.block_count(); ++b) {
    const Vec3i o = field.block_origin(b);
    for (int z = 0; z < n; ++z)
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x)
          for (int s = 0; s < lattice.samples_per_cell(); ++s)
            if (o.x + x < cells && o.y + y < cells && o.z + z < cells)
              field.block_values(b)[field.local_index({x, y, z}, s)] = u(rng);
  }
  return field;
}

void expect_watertight(const TriangleMesh& mesh, const char* what) {
  const TopologyReport r = analyze_topology(mesh);
  EXPECT_GT(r.triangles, 0u) << what;
  EXPECT_EQ(r.boundary_edges, 0u) << what;
  EXPECT_EQ(r.nonmanifold_edges, 0u) << what;
  EXPECT_EQ(r.misoriented_edges, 0u) << what;
  EXPECT_EQ(r.nonmanifold_vertices, 0u) << what;
  EXPECT_EQ(r.degenerate_triangles, 0u) << what;
  EXPECT_EQ(r.unreferenced_vertices, 0u) << what;
  EXPECT_GT(signed_volume(mesh), 0) << what;  // every component encloses its inside
}

TEST(MarchingCubesTable, RandomFieldGivesAClosedManifoldOrientedMesh) {
  for (uint32_t seed : {1u, 2u, 3u}) {
    const ExtractResult r = extract_surface(random_field(SampleLattice::Kind::cubic, 12, seed), 0.0f, Extractor::cubes);
    expect_watertight(r.mesh, "cubes");
    EXPECT_EQ(r.dropped_triangles, 0u);
  }
}

TEST(KuhnTetrahedra, RandomFieldGivesAClosedManifoldOrientedMesh) {
  for (uint32_t seed : {4u, 5u}) {
    const ExtractResult r =
        extract_surface(random_field(SampleLattice::Kind::cubic, 12, seed), 0.0f, Extractor::tetrahedra);
    expect_watertight(r.mesh, "tetrahedra");
  }
}

TEST(TileTable, RandomFieldGivesAClosedManifoldOrientedMesh) {
  for (uint32_t seed : {6u, 7u}) {
    const ExtractResult r = extract_surface(random_field(SampleLattice::Kind::a15, 6, seed), 0.0f, Extractor::tiles);
    expect_watertight(r.mesh, "tiles");
  }
}

}  // namespace
}  // namespace meniscus
