// meniscus — the parallel loop of the CPU backend. Per-element code is written once, as a
// MENISCUS_HD callable of the index, and run by for_each_index: here over oneTBB, on the device by
// the overload of cuda/for_each.hpp (a kernel, also on the emulated device). Code shared by the
// backends names the backend by a tag (Host here, cuda::Device there) and calls
// for_each_index(backend, n, f); overload resolution picks the loop.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cstddef>
#include <cstdint>

namespace meniscus {

/// The CPU backend, as a tag for code shared with the device.
struct Host {};

/// Indices per task when the caller names none: the element-wise passes are a few dozen
/// instructions an element.
inline constexpr std::size_t kDefaultGrain = 1024;

/// Calls f(i) for every i in [0, n), in parallel over ranges of at least `grain` indices.
template <class F>
void for_each_index(std::size_t n, F&& f, std::size_t grain = kDefaultGrain) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) f(i);
  });
}

/// for_each_index on the CPU backend named by its tag (code shared with the device).
template <class F>
void for_each_index(Host, std::size_t n, F&& f, std::size_t grain = kDefaultGrain) {
  for_each_index(n, f, grain);
}

/// Calls f(begin, end) for consecutive chunks covering [0, n), in parallel: for loops that keep
/// state over a chunk (a scratch buffer, a partial count, a prefetch stream).
template <class F>
void for_each_chunk(std::size_t n, std::size_t grain, F&& f) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain),
                    [&](const tbb::blocked_range<std::size_t>& r) { f(r.begin(), r.end()); });
}

}  // namespace meniscus
