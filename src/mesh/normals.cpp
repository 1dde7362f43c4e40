// meniscus — area-weighted vertex normals and erosion (docs/method.md): the CPU's scatter of the
// normals; erosion's passes shared with the device (normals_impl.hpp).
#include "mesh/normals.hpp"
#include "common/for_each.hpp"
#include "common/huge_pages.hpp"
#include "common/prefetch.hpp"
#include "mesh/normals_impl.hpp"

#include <algorithm>
#include <cstdint>

namespace meniscus {

std::size_t normal_wave_stride(std::span<const uint32_t> lo, std::span<const uint32_t> hi) {
  const std::size_t chunks = lo.size();
  std::vector<uint32_t> suffix_lo(chunks + 1, UINT32_MAX);
  for (std::size_t c = chunks; c-- > 0;) suffix_lo[c] = std::min(suffix_lo[c + 1], lo[c]);
  std::size_t stride = 1, j = 1;
  uint32_t prefix_hi = 0;
  for (std::size_t c = 0; c < chunks; ++c) {
    prefix_hi = std::max(prefix_hi, hi[c]);
    j = std::max(j, c + 1);
    while (j < chunks && suffix_lo[j] <= prefix_hi) ++j;  // suffix_lo rises with j, prefix_hi with c
    stride = std::max(stride, j - c);
  }
  return std::min(stride, std::max<std::size_t>(chunks, 1));
}

std::vector<Vec3f> vertex_normals(std::span<const Vec3f> x, std::span<const Triangle> triangles) {
  // Each triangle's (area-weighted) cross product scattered onto its corners, chunk by chunk, in
  // waves of chunks far enough apart (normal_wave_stride) that no two of a wave share a vertex: a
  // wave runs in parallel without atomics, and every vertex takes its terms in the same order
  // whatever the threads (chunk order within a wave, wave order across). Cheaper than building
  // the vertex → triangle incidence for a gather. A mesh in spatial order has a short stride (the
  // extracted mesh's blocks over its row-ordered vertices, or the smoothed mesh's Morton order),
  // so the waves are wide.
  std::vector<Vec3f> n;
  assign_huge(n, x.size(), Vec3f{0, 0, 0});
  const std::size_t nt = triangles.size(), chunks = (nt + kNormalChunk - 1) / kNormalChunk;
  std::vector<uint32_t> lo(chunks, UINT32_MAX), hi(chunks, 0);
  for_each_index(chunks, [&](std::size_t c) {
    uint32_t l = UINT32_MAX, h = 0;
    for (std::size_t f = c * kNormalChunk, end = std::min(nt, f + kNormalChunk); f < end; ++f) {
      prefetch_stream(triangles.data(), f, nt);
      for (const uint32_t v : triangles[f]) {
        l = std::min(l, v);
        h = std::max(h, v);
      }
    }
    lo[c] = l;
    hi[c] = h;
  });
  const std::size_t stride = normal_wave_stride(lo, hi);
  // The corners of the triangle kAhead on are prefetched: the extraction's triangles come block
  // by block while its vertices are in row order, so a block's corners are spread over a dozen
  // rows of the arrays. The triangles themselves stream in with software prefetch
  // (common/prefetch.hpp), as in the range pass above and the normalisation below.
  constexpr std::size_t kAhead = 64;
  const auto scatter = [&](std::size_t c) {
    const std::size_t end = std::min(nt, (c + 1) * kNormalChunk);
    for (std::size_t f = c * kNormalChunk; f < end; ++f) {
      prefetch_stream(triangles.data(), f, end);
      if (f + kAhead < end)
        for (const uint32_t v : triangles[f + kAhead]) {
          __builtin_prefetch(&x[v]);
          __builtin_prefetch(&n[v], 1);
        }
      const Triangle& t = triangles[f];
      const Vec3f cr = cross(x[t[1]] - x[t[0]], x[t[2]] - x[t[0]]);
      n[t[0]] += cr;
      n[t[1]] += cr;
      n[t[2]] += cr;
    }
  };
  for (std::size_t wave = 0; wave < std::min(stride, chunks); ++wave)
    for_each_index((chunks - wave + stride - 1) / stride, [&](std::size_t k) { scatter(wave + k * stride); });
  for_each_chunk(n.size(), 4096, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i != end; ++i) {
      prefetch_stream_write(n.data(), i, end);
      n[i] = normalized(n[i]);
    }
  });
  return n;
}

std::size_t erode(std::vector<Vec3f>& x, std::span<const Triangle> triangles, float distance) {
  const std::vector<Vec3f> n = vertex_normals(x, triangles);
  std::vector<Vec3f> before(triangles.size());
  unsigned long long flipped = 0;
  erode_along(Host{}, x.data(), triangles.data(), x.size(), triangles.size(), n.data(), before.data(), distance, &flipped);
  return std::size_t(flipped);
}

}  // namespace meniscus
