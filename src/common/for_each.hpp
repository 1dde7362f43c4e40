// meniscus — the parallel loop of the CPU backend. Per-element code is written once, as a
// MENISCUS_HD callable of the index, and run by for_each_index: here over oneTBB, on the device by
// the overload of cuda/for_each.hpp (a kernel, also on the emulated device). Code shared by the
// backends names the backend by a tag (Host here, cuda::Device there) and calls
// for_each_index(backend, n, f); overload resolution picks the loop. The CPU's other parallel
// primitives (reductions, sort, per-thread scratch, chunked prefix counts) are in
// common/primitives.hpp.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cstddef>
#include <cstdint>

namespace meniscus {

/// The CPU backend, as a tag for code shared with the device.
struct Host {};

/// Calls f(i) for every i in [0, n), in parallel over ranges of at least `grain` indices (oneTBB's
/// auto partitioner splits further only while threads are idle).
template <class F>
void for_each_index(std::size_t n, std::size_t grain, F&& f) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) f(i);
  });
}

/// for_each_index with no least range: for loops whose elements are chunks, blocks or slabs of
/// work, or whose work per element varies.
template <class F>
void for_each_index(std::size_t n, F&& f) {
  for_each_index(n, 1, f);
}

/// Indices per task in the shared per-element passes (a few dozen instructions an element).
inline constexpr std::size_t kElementGrain = 1024;

/// for_each_index on the CPU backend named by its tag (code shared with the device).
template <class F>
void for_each_index(Host, std::size_t n, F&& f) {
  for_each_index(n, kElementGrain, f);
}

/// Calls f(begin, end) for consecutive chunks covering [0, n), each at least `grain` long, in
/// parallel: for loops that keep state over a chunk (a scratch buffer, a partial count, a
/// prefetch stream).
template <class F>
void for_each_chunk(std::size_t n, std::size_t grain, F&& f) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain),
                    [&](const tbb::blocked_range<std::size_t>& r) { f(r.begin(), r.end()); });
}

}  // namespace meniscus
