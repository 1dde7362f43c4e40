// meniscus — transparent huge pages for the large arrays of a run (Linux; elsewhere a no-op).
//
// The union-find of the void pass, the vertex positions and the normals of a large frame run to
// hundreds of MB and are read at random (by triangle corner): with 4 KiB pages most of those reads
// miss the TLB. Where the system leaves THP to the program (`madvise` mode, Debian's default),
// asking for it on these arrays shortens the void pass and the mesh write. The smoothing's
// per-vertex arrays (adjacency, operator, constraint caches, W x, colour classes, the reordered
// mesh) are read at random dozens of times each, so its sweeps gain too. Arrays written once in
// order and then streamed (the field, the march pages, the weld's keys, the radix scratch) are
// better off without: a huge page is zeroed whole at its first touch, ahead of the writes, which
// then miss the cache and make the field and the extraction slower. glibc's own switch
// (GLIBC_TUNABLES=glibc.malloc.hugetlb=1) is read at process start only, so a library cannot set
// it, and it would apply to every array alike. The vertex positions of the numbered weld
// (weld_numbered in weld.cpp) stay on ordinary pages: with the kernel's `defrag` = `madvise` their
// first touch can stall in compaction (bench/RESULTS.md#caveats), and the later passes' prefetched
// reads do not gain from huge pages.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>

#include "common/for_each.hpp"
#endif

namespace meniscus {

/// std::allocator, except that a value-less construct default-initialises: resize() of a vector
/// of trivial elements writes nothing. A large array that a parallel pass fills whole is then
/// touched first by that pass, on every thread, instead of being zeroed serially before it (serial
/// memsets of the smoothing set-up's arrays would leave the other cores idle meanwhile).
template <class T>
struct DefaultInitAllocator : std::allocator<T> {
  using value_type = T;
  template <class U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };
  DefaultInitAllocator() noexcept = default;
  template <class U>
  DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    std::allocator_traits<std::allocator<T>>::construct(static_cast<std::allocator<T>&>(*this), p,
                                                        std::forward<Args>(args)...);
  }
};

/// A vector whose resize() leaves trivial elements unwritten (for arrays a parallel pass fills).
template <class T>
using UninitVector = std::vector<T, DefaultInitAllocator<T>>;

/// Arrays below this size keep ordinary pages (a huge page is 2 MiB; small arrays gain nothing).
inline constexpr std::size_t kHugePageMinBytes = std::size_t(8) << 20;

/// Arrays below this size fault in from one thread (a few pages; a task would cost more).
inline constexpr std::size_t kPopulateMinBytes = std::size_t(1) << 20;

/// Asks the kernel to back the whole 2 MiB pages inside [data, data + bytes) with huge pages.
/// Only a hint: it fails quietly where THP is off or unsupported, and it changes no values. It
/// pays only on memory not touched yet (call it between allocation and first write).
inline void advise_huge_pages(void* data, std::size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  if (bytes < kHugePageMinBytes || data == nullptr) return;
  constexpr std::uintptr_t kHuge = std::uintptr_t(2) << 20;
  const std::uintptr_t begin = (reinterpret_cast<std::uintptr_t>(data) + kHuge - 1) & ~(kHuge - 1);
  const std::uintptr_t end = (reinterpret_cast<std::uintptr_t>(data) + bytes) & ~(kHuge - 1);
  if (end > begin) (void)madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
#else
  (void)data;
  (void)bytes;
#endif
}

/// Faults in the pages of [data, data + bytes) from all threads, so the kernel zeroes them in
/// parallel: one `madvise(MADV_POPULATE_WRITE)` (Linux 5.14) per 4 MiB chunk, a system call and
/// not a write, so it may cover storage a vector has reserved but not yet constructed. A
/// `resize` or `assign` that value-initialises a fresh array faults it in from the calling thread
/// alone, while the other cores wait: on a large frame those serial faults (the vertex positions,
/// the triangles, the weld's and radix sort's scratch, the field's values, the normals) are a
/// large part of the stages without smoothing. Where the call is not supported it does nothing
/// and the pages fault in at their first write.
inline void populate_pages(void* data, std::size_t bytes) {
#if defined(__linux__) && defined(MADV_POPULATE_WRITE)
  constexpr std::uintptr_t kPage = 4096, kChunk = std::uintptr_t(4) << 20;
  if (bytes < kPopulateMinBytes || data == nullptr) return;
  const std::uintptr_t begin = reinterpret_cast<std::uintptr_t>(data) & ~(kPage - 1);
  const std::uintptr_t end = (reinterpret_cast<std::uintptr_t>(data) + bytes + kPage - 1) & ~(kPage - 1);
  const std::size_t chunks = (end - begin + kChunk - 1) / kChunk;
  for_each_index(chunks, [&](std::size_t c) {
    const std::uintptr_t first = begin + c * kChunk, last = std::min(end, first + kChunk);
    (void)madvise(reinterpret_cast<void*>(first), last - first, MADV_POPULATE_WRITE);
  });
#else
  (void)data;
  (void)bytes;
#endif
}

/// Whether resize() writes the new elements (so that faulting them in ahead, in parallel, pays):
/// every allocator but DefaultInitAllocator, and that one for types with a default initialiser.
template <class T, class A>
inline constexpr bool kResizeWrites =
    !(std::is_same_v<A, DefaultInitAllocator<T>> && std::is_trivially_default_constructible_v<T>);

/// Storage for n elements of an empty vector, advised for huge pages (when `huge`) before anything
/// touches it and, when `populate`, faulted in from all threads (a vector that already holds
/// storage keeps it).
template <class T, class A>
void reserve_fresh(std::vector<T, A>& v, std::size_t n, bool huge, bool populate) {
  if (v.capacity() != 0) return;
  v.reserve(n);
  if (huge) advise_huge_pages(v.data(), n * sizeof(T));
  if (populate) populate_pages(v.data(), n * sizeof(T));
}

/// Storage for n elements of an empty vector, advised for huge pages before anything touches it.
template <class T, class A>
void reserve_huge(std::vector<T, A>& v, std::size_t n) {
  reserve_fresh(v, n, true, false);
}

/// v.resize(n) on huge pages where v was empty, faulted in from all threads when resize writes.
template <class T, class A>
void resize_huge(std::vector<T, A>& v, std::size_t n) {
  reserve_fresh(v, n, true, kResizeWrites<T, A>);
  v.resize(n);
}

/// v.assign(n, value) on huge pages where v was empty, faulted in from all threads first.
template <class T, class A>
void assign_huge(std::vector<T, A>& v, std::size_t n, const T& value) {
  reserve_fresh(v, n, true, true);
  v.assign(n, value);
}

/// v.resize(n) on ordinary pages, faulted in from all threads where v was empty (for arrays
/// written once in order, which huge pages slow: see the top of this file).
template <class T, class A>
void resize_populated(std::vector<T, A>& v, std::size_t n) {
  reserve_fresh(v, n, false, kResizeWrites<T, A>);
  v.resize(n);
}

/// v.assign(n, value) on ordinary pages, faulted in from all threads where v was empty.
template <class T, class A>
void assign_populated(std::vector<T, A>& v, std::size_t n, const T& value) {
  reserve_fresh(v, n, false, true);
  v.assign(n, value);
}

}  // namespace meniscus
