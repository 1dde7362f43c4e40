// meniscus — area-weighted vertex normals, erosion along them.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "meniscus/mesh.hpp"

namespace meniscus {

/// Unit area-weighted vertex normals (sum of the incident triangles' cross products).
/// Vertices without triangles get (0,0,0). The order of each vertex's sum, whatever the threads:
/// the triangles go in chunks of kNormalChunk, and the chunks in waves of chunks
/// normal_wave_stride() apart, wave 0 first; so a vertex adds its triangles' terms from 0 up by
/// (chunk mod stride, triangle index) — what the MPI gather reproduces (meniscus/distributed.hpp).
std::vector<Vec3f> vertex_normals(std::span<const Vec3f> x, std::span<const Triangle> triangles);

/// Triangles per chunk of vertex_normals' scatter.
inline constexpr std::size_t kNormalChunk = std::size_t(1) << 16;

/// vertex_normals' stride between the chunks of one wave, from each chunk's smallest (`lo`) and
/// largest (`hi`) corner: the smallest w with max(hi[..c]) < min(lo[c + w..]) for every c, so that
/// no two chunks of a wave share a vertex (at most the number of chunks: one chunk at a time).
std::size_t normal_wave_stride(std::span<const uint32_t> lo, std::span<const uint32_t> hi);

/// Moves every vertex inwards by `distance` along its area-weighted normal (x ← x − e·n).
/// Returns the number of triangles whose orientation flipped (a sign of self-intersection).
std::size_t erode(std::vector<Vec3f>& x, std::span<const Triangle> triangles, float distance);

}  // namespace meniscus
