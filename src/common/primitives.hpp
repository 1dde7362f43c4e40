// meniscus — the parallel primitives of the CPU backend besides the loop (common/for_each.hpp):
// reductions, sort, per-thread scratch and the chunked prefix count behind the compactions. All
// CPU parallelism of src/ goes through these two headers, which alone call oneTBB's algorithms
// (tests/check_host_primitives.py holds the rest of src/ to that), so the scheduling and the
// determinism of every parallel pass is decided here.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "common/for_each.hpp"

namespace meniscus {

/// Folds [0, n) to one value: body(begin, end, acc) folds the indices [begin, end) into acc and
/// returns it (ranges are split only while longer than `grain`, so per-range scratch costs
/// little), combine(a, b) joins the results of adjacent ranges, left before right. How [0, n) is
/// cut depends on the threads, so combine must be associative and the result exact whatever the
/// cut (counts, min/max, or): floating-point sums go through deterministic_reduce. Exceptions
/// from body propagate.
template <class T, class Body, class Combine>
T reduce(std::size_t n, std::size_t grain, T identity, Body&& body, Combine&& combine) {
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, grain), std::move(identity),
      [&](const tbb::blocked_range<std::size_t>& r, T acc) { return body(r.begin(), r.end(), std::move(acc)); },
      [&](T a, T b) { return combine(std::move(a), std::move(b)); });
}

/// reduce over a fixed tree, so a floating-point sum comes out the same on any number of threads:
/// a range longer than `grain` splits at begin + (end − begin)/2, each leaf is folded by body from
/// `identity`, each node is combine(left, right). It is oneTBB's parallel_deterministic_reduce over
/// blocked_range(0, n, grain), the tree smooth/operators_impl.hpp's sum_tree_* rebuilds for the device.
template <class T, class Body, class Combine>
T deterministic_reduce(std::size_t n, std::size_t grain, T identity, Body&& body, Combine&& combine) {
  return tbb::parallel_deterministic_reduce(
      tbb::blocked_range<std::size_t>(0, n, grain), std::move(identity),
      [&](const tbb::blocked_range<std::size_t>& r, T acc) { return body(r.begin(), r.end(), std::move(acc)); },
      [&](T a, T b) { return combine(std::move(a), std::move(b)); });
}

/// Sorts [begin, end) (random access) by operator<, in parallel; not stable, so elements that
/// compare equal must be indistinguishable for the result not to depend on the threads. The tag
/// names the backend and keeps std::sort, found by argument-dependent lookup, out of the call.
template <class It>
void sort(Host, It begin, It end) {
  tbb::parallel_sort(begin, end);
}

/// sort by `less` (a strict weak order; the same caveat on equal elements).
template <class It, class Less>
void sort(Host, It begin, It end, const Less& less) {
  tbb::parallel_sort(begin, end, less);
}

/// One T per thread that asks for it, made on a thread's first local() (value-initialised, or by
/// `make()`), for scratch that a parallel loop fills without locks. Iterating visits every T made,
/// in an order that depends on the threads: what is gathered from them must be sorted or otherwise
/// made independent of it. local() is thread-safe; iterating is not, during the loop.
template <class T>
class PerThread {
 public:
  PerThread() = default;
  template <class Make>
  explicit PerThread(Make make) : values_(std::move(make)) {}

  /// The calling thread's T.
  T& local() { return values_.local(); }

  auto begin() { return values_.begin(); }
  auto end() { return values_.end(); }
  auto begin() const { return values_.begin(); }
  auto end() const { return values_.end(); }

 private:
  tbb::enumerable_thread_specific<T> values_;
};

/// Indices per chunk of chunk_offsets and for_each_set.
inline constexpr std::size_t kOffsetChunk = std::size_t(1) << 15;

/// Per chunk of kOffsetChunk indices of [0, n), the position of its first index with set(i) among
/// all such indices (an exclusive scan of the chunks' counts, in chunk order; offsets gets
/// chunks + 1 entries, the last the total); returns the total. Counts in parallel, scans serially.
template <class Set>
std::size_t chunk_offsets(std::size_t n, Set&& set, std::vector<std::size_t>& offsets) {
  const std::size_t chunks = (n + kOffsetChunk - 1) / kOffsetChunk;
  offsets.assign(chunks + 1, 0);
  for_each_index(chunks, [&](std::size_t c) {
    std::size_t count = 0;
    for (std::size_t i = c * kOffsetChunk, end = std::min(n, i + kOffsetChunk); i < end; ++i) count += set(i) ? 1 : 0;
    offsets[c + 1] = count;
  });
  for (std::size_t c = 0; c < chunks; ++c) offsets[c + 1] += offsets[c];
  return offsets[chunks];
}

/// Calls f(i, rank) for every index i of [0, n) with set(i), rank its position among them;
/// parallel over the chunks of `offsets` (as chunk_offsets made them for the same n and set).
template <class Set, class F>
void for_each_set(std::size_t n, Set&& set, const std::vector<std::size_t>& offsets, F&& f) {
  for_each_index(offsets.size() - 1, [&](std::size_t c) {
    std::size_t rank = offsets[c];
    for (std::size_t i = c * kOffsetChunk, end = std::min(n, i + kOffsetChunk); i < end; ++i)
      if (set(i)) f(i, rank++);
  });
}

/// The flags' versions: index i is set where flags[i] is.
inline std::size_t chunk_offsets(const std::vector<uint8_t>& flags, std::vector<std::size_t>& offsets) {
  return chunk_offsets(flags.size(), [&](std::size_t i) { return flags[i] != 0; }, offsets);
}
template <class F>
void for_each_set(const std::vector<uint8_t>& flags, const std::vector<std::size_t>& offsets, F&& f) {
  for_each_set(flags.size(), [&](std::size_t i) { return flags[i] != 0; }, offsets, std::forward<F>(f));
}

}  // namespace meniscus
