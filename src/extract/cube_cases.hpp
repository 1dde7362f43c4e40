// meniscus — the Marching Cubes case table (Lorensen & Cline 1987), generated at compile time
// with a consistent face rule so the result is watertight (the classic table has holes on
// ambiguous faces).
//
// Generation, per case (bit c set: cube corner c inside, φ < iso):
//  1. Marching squares on each of the 6 faces. An ambiguous face (two diagonal corners inside)
//     always separates the inside corners. The decision depends only on the face's 4 corners, so
//     the two cubes sharing a face cut it identically.
//  2. Each segment is oriented by the right-hand rule for a surface whose normal points toward
//     larger φ: its direction τ satisfies τ · (g × n_F) > 0, with n_F the face's outward normal
//     and g the in-face direction from the inside to the outside corners it separates. The two
//     cubes sharing a face then traverse the shared segment in opposite directions.
//  3. Segments are chained head to tail into closed loops (every crossing edge starts exactly one
//     segment and ends exactly one — checked, a violation fails to compile).
//  4. Each loop is triangulated so that no diagonal joins two vertices on a common cube face:
//     such a diagonal would lie in the face, where the neighbouring cube could emit the same
//     edge (an edge with four triangles). The triangles inherit the loop's orientation.
// tests/unit/test_extract_tables.cpp checks all 256 cases, and a random field for global
// watertightness.
#pragma once

#include <cstdint>

#include "extract/edge_key.hpp"
#include "extract/tile_table.hpp"
#include "meniscus/vec.hpp"

namespace meniscus {

/// Cube corner c (0..7) is at (c & 1, (c >> 1) & 1, c >> 2) in cell units.
MENISCUS_HD constexpr int cube_corner_coord(int corner, int axis) { return (corner >> axis) & 1; }

/// Cube edge e runs along axis e / 4; its lowest corner has the other two coordinates (in axis
/// order: x-edges (y, z), y-edges (x, z), z-edges (x, y)) = (e & 1, (e >> 1) & 1).
inline constexpr int kCubeEdgeCorners[12][2] = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3},
                                                {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
MENISCUS_HD constexpr int cube_edge_axis(int edge) { return edge / 4; }

/// Key offset of each cube edge from the cube's cell key: based at its lowest corner, of the
/// cubic-lattice axis type (tile_table.hpp: x = 0, y = 1, z = 3).
constexpr auto build_cube_edge_key_deltas() {
  struct Deltas {
    uint64_t v[12];
  } d{};
  for (int e = 0; e < 12; ++e) {
    const int c = kCubeEdgeCorners[e][0], a = cube_edge_axis(e);
    d.v[e] = edge_key_delta(cube_corner_coord(c, 0), cube_corner_coord(c, 1), cube_corner_coord(c, 2),
                            cubic_edge_type(a == 0, a == 1, a == 2));
  }
  return d;
}
inline constexpr auto kCubeEdgeKeyDeltas = build_cube_edge_key_deltas();

/// The cubic-lattice edge types Marching Cubes keys its vertices by: the 3 axes.
inline constexpr uint64_t kCubeEdgeTypes = (uint64_t(1) << cubic_edge_type(1, 0, 0)) |
                                           (uint64_t(1) << cubic_edge_type(0, 1, 0)) |
                                           (uint64_t(1) << cubic_edge_type(0, 0, 1));

/// Upper bound of triangles per cube case (the generator checks the real maximum fits).
inline constexpr int kCubeMaxTriangles = 5;

struct CubeCase {
  uint8_t count;                        ///< triangles
  uint8_t edges[kCubeMaxTriangles][3];  ///< cube edge (0..11) of each corner
};

struct CubeCaseTable {
  CubeCase cases[256];
};

/// Face f = 2·axis + side (side 1: the face at coordinate 1), outward normal ±e_axis. Its corners
/// in cyclic order, counter-clockwise around the +axis direction.
constexpr void cube_face_corners(int face, int corners[4]) {
  const int a = face / 2, side = face % 2, b = (a + 1) % 3, c = (a + 2) % 3;
  const int uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  for (int k = 0; k < 4; ++k) corners[k] = (side << a) | (uv[k][0] << b) | (uv[k][1] << c);
}

/// The cube edge joining two corners, or -1.
constexpr int cube_edge_of(int c0, int c1) {
  for (int e = 0; e < 12; ++e)
    if ((kCubeEdgeCorners[e][0] == c0 && kCubeEdgeCorners[e][1] == c1) ||
        (kCubeEdgeCorners[e][0] == c1 && kCubeEdgeCorners[e][1] == c0))
      return e;
  return -1;
}

/// Bit f set if cube edge e lies on face f: the faces of the two other axes on the side of the
/// edge's corners (closed form: the generator calls this often enough to hit compile-time step
/// limits with a search).
constexpr int cube_edge_faces(int e) {
  const int a = cube_edge_axis(e), c = kCubeEdgeCorners[e][0];
  int mask = 0;
  for (int b = 0; b < 3; ++b)
    if (b != a) mask |= 1 << (2 * b + cube_corner_coord(c, b));
  return mask;
}

/// Marching squares with the separating rule on face f for corner pattern `inside_mask`: writes up
/// to 2 oriented segments (from cube edge seg[i][0] to seg[i][1]); returns their number.
constexpr int cube_face_segments(int face, int inside_mask, int seg[2][2]) {
  int q[4] = {};
  cube_face_corners(face, q);
  bool in[4] = {};
  int n_in = 0;
  for (int k = 0; k < 4; ++k) {
    in[k] = ((inside_mask >> q[k]) & 1) != 0;
    n_in += in[k] ? 1 : 0;
  }
  // Face edge k joins corners q[k] and q[k+1]; corner k lies between face edges k−1 and k.
  int pairs[2][2] = {};  // face edges paired into segments
  int count = 0;
  if (n_in == 1 || n_in == 3) {
    for (int k = 0; k < 4; ++k)
      if (in[k] == (n_in == 1)) {  // around the lone corner
        pairs[0][0] = (k + 3) % 4;
        pairs[0][1] = k;
        count = 1;
      }
  } else if (n_in == 2) {
    if (in[0] == in[2]) {  // ambiguous: cut off each inside corner
      for (int k = 0; k < 4; ++k)
        if (in[k]) {
          pairs[count][0] = (k + 3) % 4;
          pairs[count][1] = k;
          ++count;
        }
    } else {
      int k0 = -1;
      for (int k = 0; k < 4; ++k)
        if (in[k] != in[(k + 1) % 4]) {
          if (k0 < 0) {
            k0 = k;
          } else {
            pairs[0][0] = k0;
            pairs[0][1] = k;
          }
        }
      count = 1;
    }
  }
  const int a = face / 2;
  const int normal[3] = {a == 0 ? (face % 2 ? 1 : -1) : 0, a == 1 ? (face % 2 ? 1 : -1) : 0,
                         a == 2 ? (face % 2 ? 1 : -1) : 0};
  for (int s = 0; s < count; ++s) {
    // Doubled midpoints of the two crossing edges, and g = Σ (outside end − inside end).
    int m[2][3] = {}, g[3] = {};
    for (int i = 0; i < 2; ++i) {
      const int k = pairs[s][i], c0 = q[k], c1 = q[(k + 1) % 4];
      const int cin = in[k] ? c0 : c1, cout = in[k] ? c1 : c0;
      for (int ax = 0; ax < 3; ++ax) {
        m[i][ax] = cube_corner_coord(c0, ax) + cube_corner_coord(c1, ax);
        g[ax] += cube_corner_coord(cout, ax) - cube_corner_coord(cin, ax);
      }
    }
    const int gxn[3] = {g[1] * normal[2] - g[2] * normal[1], g[2] * normal[0] - g[0] * normal[2],
                        g[0] * normal[1] - g[1] * normal[0]};
    const int dir = (m[1][0] - m[0][0]) * gxn[0] + (m[1][1] - m[0][1]) * gxn[1] + (m[1][2] - m[0][2]) * gxn[2];
    if (dir == 0) throw "segment orientation undefined";  // compile-time error
    const int e0 = cube_edge_of(q[pairs[s][0]], q[(pairs[s][0] + 1) % 4]);
    const int e1 = cube_edge_of(q[pairs[s][1]], q[(pairs[s][1] + 1) % 4]);
    seg[s][0] = dir > 0 ? e0 : e1;
    seg[s][1] = dir > 0 ? e1 : e0;
  }
  return count;
}

/// Triangulates the polygon loop[0..n) so that every diagonal joins two cube edges with no face
/// in common (interval dynamic programming; sides are always allowed). Appends the triangles,
/// oriented like the loop, to `out`; returns false if no such triangulation exists.
constexpr bool triangulate_cube_loop(const int* loop, int n, CubeCase& out) {
  auto allowed = [&](int i, int j) {
    return j == i + 1 || (i == 0 && j == n - 1) || (cube_edge_faces(loop[i]) & cube_edge_faces(loop[j])) == 0;
  };
  // split[i][j]: apex k of the triangle on side (i, j) of the sub-polygon i..j; -1 if impossible.
  int split[12][12] = {};
  for (int len = 2; len < n; ++len) {
    for (int i = 0; i + len < n; ++i) {
      const int j = i + len;
      split[i][j] = -1;
      for (int k = i + 1; k < j; ++k) {
        const bool left = k == i + 1 || (allowed(i, k) && split[i][k] >= 0);
        const bool right = j == k + 1 || (allowed(k, j) && split[k][j] >= 0);
        if (left && right) {
          split[i][j] = k;
          break;
        }
      }
    }
  }
  if (split[0][n - 1] < 0) return false;
  int stack[12][2] = {{0, n - 1}};
  int top = 1;
  while (top > 0) {
    --top;
    const int i = stack[top][0], j = stack[top][1];
    const int k = split[i][j];
    if (out.count == kCubeMaxTriangles) throw "kCubeMaxTriangles too small";  // compile-time error
    out.edges[out.count][0] = uint8_t(loop[i]);
    out.edges[out.count][1] = uint8_t(loop[k]);
    out.edges[out.count][2] = uint8_t(loop[j]);
    ++out.count;
    if (j > k + 1) {
      stack[top][0] = k;
      stack[top][1] = j;
      ++top;
    }
    if (k > i + 1) {
      stack[top][0] = i;
      stack[top][1] = k;
      ++top;
    }
  }
  return true;
}

constexpr CubeCaseTable build_cube_cases() {
  CubeCaseTable table{};
  for (int c = 0; c < 256; ++c) {
    int next[12], incoming[12] = {};
    for (int& e : next) e = -1;
    for (int f = 0; f < 6; ++f) {
      int seg[2][2] = {};
      const int count = cube_face_segments(f, c, seg);
      for (int s = 0; s < count; ++s) {
        if (next[seg[s][0]] >= 0) throw "two segments leave one edge";  // compile-time error
        next[seg[s][0]] = seg[s][1];
        ++incoming[seg[s][1]];
      }
    }
    for (int e = 0; e < 12; ++e)
      if ((next[e] >= 0) != (incoming[e] == 1) || incoming[e] > 1) throw "open loop";  // compile-time error
    bool used[12] = {};
    CubeCase& cc = table.cases[c];
    for (int start = 0; start < 12; ++start) {
      if (next[start] < 0 || used[start]) continue;
      int loop[12] = {}, n = 0;
      for (int e = start; !used[e]; e = next[e]) {
        used[e] = true;
        loop[n++] = e;
      }
      if (!triangulate_cube_loop(loop, n, cc)) throw "no face-safe triangulation";  // compile-time error
    }
  }
  return table;
}

inline constexpr CubeCaseTable kCubeCases = build_cube_cases();

}  // namespace meniscus
