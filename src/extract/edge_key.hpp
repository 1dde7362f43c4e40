// meniscus — integer keys of sampling-lattice edges, the weld keys of the extractors (Williams
// 2008: vertices are identified by the tiling edge they lie on, never by a float position).
//
// Key layout (63 bits): bits 6..62 hold the edge's base cell, 19 bits per axis (z major, then y,
// then x, each offset by 2^18), bits 0..5 the edge type (index into the lattice's table of
// canonical edges, < 64). pack_coords (grid/key_index.hpp) uses 21 bits per axis and would leave
// no room for the type, hence this narrower packing: base cells must satisfy |coord| < 2^18
// (kEdgeKeyMaxCoord); extract_surface checks that before marching and throws ResourceError.
// Sorting keys sorts edges by (z, y, x, type) of their base cell.
#pragma once

#include <cstdint>

#include "meniscus/vec.hpp"

namespace meniscus {

inline constexpr int kEdgeKeyAxisBits = 19;
inline constexpr int kEdgeKeyTypeBits = 6;
/// Largest |coordinate| of a base cell an edge key can hold.
inline constexpr int32_t kEdgeKeyMaxCoord = (int32_t(1) << (kEdgeKeyAxisBits - 1)) - 1;

/// Key of the edge of type `type` (0..63) based at `cell` (each |coord| ≤ kEdgeKeyMaxCoord).
MENISCUS_HD constexpr uint64_t edge_key(Vec3i cell, int type) {
  constexpr int64_t kOffset = int64_t(1) << (kEdgeKeyAxisBits - 1);
  const uint64_t packed = (uint64_t(int64_t(cell.z) + kOffset) << (2 * kEdgeKeyAxisBits)) |
                          (uint64_t(int64_t(cell.y) + kOffset) << kEdgeKeyAxisBits) |
                          uint64_t(int64_t(cell.x) + kOffset);
  return (packed << kEdgeKeyTypeBits) | uint64_t(type);
}

/// The base cell of an edge key.
MENISCUS_HD constexpr Vec3i edge_key_cell(uint64_t key) {
  constexpr int64_t kOffset = int64_t(1) << (kEdgeKeyAxisBits - 1);
  constexpr uint64_t kMask = (uint64_t(1) << kEdgeKeyAxisBits) - 1;
  const uint64_t packed = key >> kEdgeKeyTypeBits;
  return {int32_t(int64_t(packed & kMask) - kOffset), int32_t(int64_t((packed >> kEdgeKeyAxisBits) & kMask) - kOffset),
          int32_t(int64_t((packed >> (2 * kEdgeKeyAxisBits)) & kMask) - kOffset)};
}

/// The type of an edge key.
MENISCUS_HD constexpr int edge_key_type(uint64_t key) { return int(key & ((uint64_t(1) << kEdgeKeyTypeBits) - 1)); }

/// What to add (mod 2^64) to edge_key(cell, 0) to get edge_key(cell + d, type). The packing is
/// linear in each coordinate as long as every field stays in range, so the inner loops turn a
/// cell's key into its edges' keys with one addition instead of a pack per edge.
MENISCUS_HD constexpr uint64_t edge_key_delta(int dx, int dy, int dz, int type) {
  const int64_t cells = int64_t(dz) * (int64_t(1) << (2 * kEdgeKeyAxisBits)) +
                        int64_t(dy) * (int64_t(1) << kEdgeKeyAxisBits) + int64_t(dx);
  return uint64_t(cells * (int64_t(1) << kEdgeKeyTypeBits) + type);
}

static_assert(edge_key(Vec3i{-3, 7, -kEdgeKeyMaxCoord}, 0) + edge_key_delta(1, -1, 2, 5) ==
              edge_key(Vec3i{-2, 6, -kEdgeKeyMaxCoord + 2}, 5));
static_assert(edge_key_cell(edge_key(Vec3i{kEdgeKeyMaxCoord, -kEdgeKeyMaxCoord, 0}, 63)) ==
              Vec3i{kEdgeKeyMaxCoord, -kEdgeKeyMaxCoord, 0});
static_assert(edge_key(Vec3i{kEdgeKeyMaxCoord, kEdgeKeyMaxCoord, kEdgeKeyMaxCoord}, 63) < (uint64_t(1) << 63));

/// Interpolation parameter of the crossing {φ = iso} between samples with values v0 and v1,
/// clamped to [clamp, 1 − clamp] so that vertices never sit on a sample: two triangle corners on
/// different edges of one cell then never coincide (no degenerate triangles, no repeated
/// positions). Written so that NaN or an infinite background also land in range.
MENISCUS_HD inline float edge_parameter(float v0, float v1, float iso, float clamp) {
  const float t = (iso - v0) / (v1 - v0);
  if (!(t >= clamp)) return clamp;  // also catches NaN
  if (t > 1 - clamp) return 1 - clamp;
  return t;
}

/// The vertex where {φ = iso} crosses the edge from p0 (value v0) to p1 (value v1), at the clamped
/// parameter (edge_parameter): every weld, on either backend, places its vertices with it.
MENISCUS_HD inline Vec3f edge_vertex(Vec3f p0, Vec3f p1, float v0, float v1, float iso, float clamp) {
  return p0 + (p1 - p0) * edge_parameter(v0, v1, iso, clamp);
}

}  // namespace meniscus
