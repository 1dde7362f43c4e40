// meniscus — the adjacency's neighbour lists in 16 bits an entry (see the header).
#include "smooth/compact_neighbors.hpp"

#include <numeric>

#include "common/for_each.hpp"

namespace meniscus {

CompactNeighborLists compact_neighbor_lists(std::span<const uint32_t> offsets, std::span<const uint32_t> neighbors) {
  const std::size_t nv = offsets.empty() ? 0 : offsets.size() - 1;
  constexpr std::size_t kChunk = std::size_t(1) << CompactNeighbors::kChunkShift;
  const std::size_t chunks = (nv + kChunk - 1) / kChunk;
  auto near = [](uint32_t i, uint32_t n) {
    const int64_t d = int64_t(n) - int64_t(i);
    return d >= -CompactNeighbors::kNear && d <= CompactNeighbors::kNear;
  };
  auto rows_of = [&](std::size_t q) { return std::pair(uint32_t(q * kChunk), uint32_t(std::min(nv, (q + 1) * kChunk))); };
  CompactNeighborLists out;
  // The far entries of each chunk of rows counted, then listed in order (entries ascending).
  out.chunk_far.assign(chunks + 1, 0);
  for_each_index(chunks, [&](std::size_t q) {
    const auto [b, e] = rows_of(q);
    uint32_t far = 0;
    for (uint32_t i = b; i < e; ++i)
      for (uint32_t k = offsets[i]; k < offsets[i + 1]; ++k) far += !near(i, neighbors[k]);
    out.chunk_far[q + 1] = far;
  });
  std::inclusive_scan(out.chunk_far.begin(), out.chunk_far.end(), out.chunk_far.begin());
  resize_huge(out.delta, neighbors.size());
  out.far_entry.resize(out.chunk_far.back());
  out.far_vertex.resize(out.chunk_far.back());
  for_each_index(chunks, [&](std::size_t q) {
    const auto [b, e] = rows_of(q);
    uint32_t f = out.chunk_far[q];
    for (uint32_t i = b; i < e; ++i)
      for (uint32_t k = offsets[i]; k < offsets[i + 1]; ++k) {
        const uint32_t n = neighbors[k];
        if (near(i, n)) {
          out.delta[k] = int16_t(int32_t(n) - int32_t(i));
        } else {
          const uint32_t in_chunk = f - out.chunk_far[q];
          out.delta[k] = in_chunk < CompactNeighbors::kIndexed ? int16_t(CompactNeighbors::kIndexBase + int32_t(in_chunk))
                                                               : CompactNeighbors::kFar;
          out.far_entry[f] = k;
          out.far_vertex[f++] = n;
        }
      }
  });
  return out;
}

}  // namespace meniscus
