// meniscus — software prefetch for the passes that stream through arrays of hundreds of MB.
//
// The hardware prefetchers of some hosts barely run ahead of such passes (a min/max over the
// triangles of a large mesh stalls on its loads); asking for the line 2 KB ahead, once a line,
// keeps them fed. The hint costs one instruction a line where the hardware already streams, never
// faults, and changes no result.
#pragma once

#include <bit>
#include <cstddef>

namespace meniscus {

namespace detail {
/// Bytes ahead of the element being read that a stream prefetch asks for: far enough to cover a
/// miss to memory at a few bytes a cycle, near enough to stay in L1/L2 until it is read.
inline constexpr std::size_t kPrefetchAheadBytes = 2048;
template <class T>
inline constexpr std::size_t kPrefetchStep = sizeof(T) >= 64 ? 1 : std::bit_floor(64 / sizeof(T));
template <class T>
inline constexpr std::size_t kPrefetchAhead = (kPrefetchAheadBytes + sizeof(T) - 1) / sizeof(T);
}  // namespace detail

/// For a pass reading data[i] for increasing i < end: call at every i; once a cache line's worth
/// of elements it prefetches the element 2 KB ahead (if it is still within the array).
template <class T>
inline void prefetch_stream(const T* data, std::size_t i, std::size_t end) {
  if (i % detail::kPrefetchStep<T> == 0 && i + detail::kPrefetchAhead<T> < end)
    __builtin_prefetch(data + i + detail::kPrefetchAhead<T>, 0);
}

/// The same for a pass writing (or reading and writing) data[i] for increasing i < end: asks for
/// the line with intent to write, so the store finds it owned.
template <class T>
inline void prefetch_stream_write(T* data, std::size_t i, std::size_t end) {
  if (i % detail::kPrefetchStep<T> == 0 && i + detail::kPrefetchAhead<T> < end)
    __builtin_prefetch(data + i + detail::kPrefetchAhead<T>, 1);
}

}  // namespace meniscus
