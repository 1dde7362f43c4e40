// meniscus — the Marching Tetrahedra case table (Doi & Koide 1991), shared by Marching Tiles
// (Williams 2008) and the Kuhn split: for a positively oriented tetrahedron and each of the 16
// inside/outside patterns of its vertices (bit v set: vertex v inside, φ < iso), 0, 1 or 2
// triangles whose corners are tetrahedron edges (kTetEdgeVertices), counter-clockwise seen
// from the outside (their normal points toward larger φ).
//
// The orientation is derived, not written by hand: each triangle is built on the reference
// tetrahedron (0,0,0), (1,0,0), (0,1,0), (0,0,1) with corners at edge midpoints and flipped if its
// normal points from the outside vertices toward the inside ones. Orientation is invariant under
// orientation-preserving affine maps and stays valid for any crossing parameter in (0, 1) (the
// inside vertex never becomes coplanar with a triangle), so the table holds for every positive
// tetrahedron and every clamped interpolation.
#pragma once

#include <cstdint>

#include "extract/tile_table.hpp"
#include "meniscus/vec.hpp"

namespace meniscus {

struct TetCase {
  uint8_t count;        ///< triangles: 0, 1 or 2
  uint8_t edges[2][3];  ///< tetrahedron edge (0..5) of each corner
};

struct TetCaseTable {
  TetCase cases[16];
};

/// Index into kTetEdgeVertices of the edge joining vertex slots a and b.
constexpr int tet_edge_index(int a, int b) {
  for (int e = 0; e < 6; ++e)
    if ((kTetEdgeVertices[e][0] == a && kTetEdgeVertices[e][1] == b) ||
        (kTetEdgeVertices[e][0] == b && kTetEdgeVertices[e][1] == a))
      return e;
  return -1;
}

constexpr TetCaseTable build_tet_cases() {
  // Reference positive tetrahedron, doubled so edge midpoints are integers.
  constexpr int kRef[4][3] = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {0, 0, 2}};
  auto midpoint = [&](int e, int axis) {
    return (kRef[kTetEdgeVertices[e][0]][axis] + kRef[kTetEdgeVertices[e][1]][axis]) / 2;
  };
  TetCaseTable table{};
  for (int c = 0; c < 16; ++c) {
    int in[4] = {}, out[4] = {}, n_in = 0, n_out = 0;
    for (int v = 0; v < 4; ++v) {
      if ((c >> v) & 1)
        in[n_in++] = v;
      else
        out[n_out++] = v;
    }
    // Direction from the inside vertices to the outside ones (scaled to stay integer).
    int g[3] = {};
    for (int a = 0; a < 3; ++a) {
      for (int k = 0; k < n_out; ++k) g[a] += n_in * kRef[out[k]][a];
      for (int k = 0; k < n_in; ++k) g[a] -= n_out * kRef[in[k]][a];
    }
    int tris[2][3] = {};
    int count = 0;
    if (n_in == 1 || n_in == 3) {
      const int lone = n_in == 1 ? in[0] : out[0];
      int k = 0;
      for (int v = 0; v < 4; ++v)
        if (v != lone) tris[0][k++] = tet_edge_index(lone, v);
      count = 1;
    } else if (n_in == 2) {
      // The quad ac, ad, bd, bc (a, b inside; c, d outside) is a cycle: consecutive corners share
      // a face of the tetrahedron. Its diagonal lies inside the tetrahedron, so either split is
      // watertight; we cut along ac–bd.
      const int a = in[0], b = in[1], cc = out[0], d = out[1];
      const int quad[4] = {tet_edge_index(a, cc), tet_edge_index(a, d), tet_edge_index(b, d), tet_edge_index(b, cc)};
      tris[0][0] = quad[0], tris[0][1] = quad[1], tris[0][2] = quad[2];
      tris[1][0] = quad[0], tris[1][1] = quad[2], tris[1][2] = quad[3];
      count = 2;
    }
    for (int t = 0; t < count; ++t) {
      int p[3][3] = {};
      for (int k = 0; k < 3; ++k)
        for (int a = 0; a < 3; ++a) p[k][a] = midpoint(tris[t][k], a);
      const int u[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
      const int w[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
      const int n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
      const int side = n[0] * g[0] + n[1] * g[1] + n[2] * g[2];
      if (side == 0) throw "degenerate reference triangle";  // compile-time error
      if (side < 0) {
        const int s = tris[t][1];
        tris[t][1] = tris[t][2];
        tris[t][2] = s;
      }
      for (int k = 0; k < 3; ++k) table.cases[c].edges[t][k] = uint8_t(tris[t][k]);
    }
    table.cases[c].count = uint8_t(count);
  }
  return table;
}

inline constexpr TetCaseTable kTetCases = build_tet_cases();

/// Inside/outside pattern of a tetrahedron from its vertices' inside flags.
MENISCUS_HD constexpr int tet_case(bool in0, bool in1, bool in2, bool in3) {
  return int(in0) | (int(in1) << 1) | (int(in2) << 2) | (int(in3) << 3);
}

}  // namespace meniscus
