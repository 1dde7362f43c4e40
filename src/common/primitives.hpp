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
#include "common/radix_sort.hpp"

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
/// blocked_range(0, n, grain), the tree the device's deterministic_sum (cuda/primitives.hpp) evaluates.
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

// --- the backend primitives' CPU versions ---------------------------------------------------------
// The same calls as the device's (cuda/primitives.hpp), over plain pointers, so that a stage
// written once over the backend tag calls exclusive_sum(backend, …) and gets either.

/// out[i] = Σ_{k<i} in[k] for i ≤ n (out has n + 1 elements, out[n] the total); in and out may be
/// the same array. Chunk totals in parallel, their scan serially, then each chunk in parallel.
template <class T>
void exclusive_sum(Host, const T* in, T* out, std::size_t n) {
  const std::size_t chunks = (n + kOffsetChunk - 1) / kOffsetChunk;
  std::vector<T> base(chunks + 1, T(0));
  for_each_index(chunks, [&](std::size_t c) {
    T total = 0;
    for (std::size_t i = c * kOffsetChunk, end = std::min(n, i + kOffsetChunk); i < end; ++i) total += in[i];
    base[c + 1] = total;
  });
  for (std::size_t c = 0; c < chunks; ++c) base[c + 1] += base[c];
  for_each_index(chunks, [&](std::size_t c) {
    T total = base[c];
    for (std::size_t i = c * kOffsetChunk, end = std::min(n, i + kOffsetChunk); i < end; ++i) {
      const T v = in[i];
      out[i] = total;
      total += v;
    }
  });
  out[n] = base[chunks];
}

/// Sorts the n pairs (keys[i], values[i]) stably by the key bits [begin_bit, end_bit), in place.
template <class K>
void sort_pairs(Host, K* keys, uint32_t* values, std::size_t n, int begin_bit = 0, int end_bit = 8 * sizeof(K)) {
  if (n < 2) return;
  std::vector<std::pair<K, uint32_t>> items(n);
  for_each_index(n, kElementGrain, [&](std::size_t i) { items[i] = {keys[i], values[i]}; });
  radix_sort_by(items, [](const std::pair<K, uint32_t>& p) { return uint64_t(p.first); }, begin_bit, end_bit);
  for_each_index(n, kElementGrain, [&](std::size_t i) { keys[i] = items[i].first, values[i] = items[i].second; });
}

/// Sorts the n keys in place.
inline void sort_keys(Host, uint64_t* keys, std::size_t n) { tbb::parallel_sort(keys, keys + n); }

/// Moves the distinct values of the sorted keys[0, n) to the front; returns their count.
inline std::size_t unique_sorted(Host, uint64_t* keys, std::size_t n) {
  return std::size_t(std::unique(keys, keys + n) - keys);
}

/// combine(… combine(combine(identity, f(0)), f(1)) …, f(n − 1)) for an associative, exact combine
/// (min, max, counts: the cut of [0, n) into ranges depends on the threads).
template <class T, class F, class Combine>
T reduce_index(Host, std::size_t n, T identity, F f, Combine combine) {
  return reduce(
      n, kElementGrain, identity,
      [&](std::size_t begin, std::size_t end, T acc) {
        for (std::size_t i = begin; i < end; ++i) acc = combine(acc, f(i));
        return acc;
      },
      combine);
}

/// Σ_{i<n} term(i) in doubles, in deterministic_reduce's fixed tree over [0, n) with `grain`: each
/// leaf summed in index order from 0.0, each node left + right. The same bits on any number of
/// threads, and as the device's deterministic_sum (cuda/primitives.hpp), which evaluates the same
/// tree in parallel. term is a MENISCUS_HD callable of the index returning a double.
template <class F>
double deterministic_sum(Host, std::size_t n, std::size_t grain, F term) {
  return deterministic_reduce(
      n, grain, 0.0,
      [&](std::size_t begin, std::size_t end, double acc) {
        for (std::size_t i = begin; i < end; ++i) acc += term(i);
        return acc;
      },
      [](double a, double b) { return a + b; });
}

}  // namespace meniscus
