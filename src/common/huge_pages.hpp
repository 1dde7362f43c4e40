// meniscus — transparent huge pages for the large arrays of a run (Linux; elsewhere a no-op).
//
// The union-find of the void pass, the vertex positions and the normals of a splash frame run to
// hundreds of MB and are read at random (by triangle corner): with 4 KiB pages most of those reads
// miss the TLB. Where the system leaves THP to the program (`madvise` mode, Debian's default),
// asking for it on these arrays cut the void pass by about a fifth and the mesh write by about a
// quarter on splash 1M (bench/RESULTS.md). The smoothing's per-vertex arrays (adjacency, operator,
// constraint caches, W x, colour classes, the reordered mesh) are read at random some sixty times
// each: on huge pages its sweeps took about 4 % less on splash 1M. Arrays written once in order
// and then streamed (the field, the march pages, the weld's keys, the radix scratch) are better
// off without: a huge page is zeroed whole at its first touch, ahead of the writes, which then
// miss the cache — the field and the extraction measured 10-15 % slower with it. glibc's own
// switch (GLIBC_TUNABLES=glibc.malloc.hugetlb=1) is read at process start only, so a library
// cannot set it, and it would apply to every array alike.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace meniscus {

/// Arrays below this size keep ordinary pages (a huge page is 2 MiB; small arrays gain nothing).
inline constexpr std::size_t kHugePageMinBytes = std::size_t(8) << 20;

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

/// Storage for n elements of an empty vector, advised for huge pages before anything touches it
/// (a vector that already holds storage keeps it).
template <class T, class A>
void reserve_huge(std::vector<T, A>& v, std::size_t n) {
  if (v.capacity() != 0) return;
  v.reserve(n);
  advise_huge_pages(v.data(), n * sizeof(T));
}

/// v.resize(n) on huge pages where v was empty.
template <class T, class A>
void resize_huge(std::vector<T, A>& v, std::size_t n) {
  reserve_huge(v, n);
  v.resize(n);
}

/// v.assign(n, value) on huge pages where v was empty.
template <class T, class A>
void assign_huge(std::vector<T, A>& v, std::size_t n, const T& value) {
  reserve_huge(v, n);
  v.assign(n, value);
}

}  // namespace meniscus
