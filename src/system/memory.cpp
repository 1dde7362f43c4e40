// meniscus — the allocator settings of meniscus/memory.hpp.
#include "meniscus/memory.hpp"

#include "system/memory_scope.hpp"

#include <sys/resource.h>

#include <atomic>
#include <climits>
#include <cstdlib>  // defines __GLIBC__ on glibc

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace meniscus {

std::size_t peak_resident_bytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return std::size_t(usage.ru_maxrss) * 1024;
}

namespace {

std::atomic<bool> g_reuse_between_stages{false};

}  // namespace

bool release_large_blocks_eagerly() {
#if defined(__GLIBC__)
  // Setting M_MMAP_THRESHOLD also turns off glibc's dynamic raising of it.
  constexpr int kThreshold = 1 << 20;
  return mallopt(M_MMAP_THRESHOLD, kThreshold) == 1;
#else
  return false;
#endif
}

bool reuse_freed_blocks_between_stages() {
#if defined(__GLIBC__)
  g_reuse_between_stages = true;
  return true;
#else
  return false;
#endif
}

HeapReuseScope::HeapReuseScope() {
#if defined(__GLIBC__)
  if (!g_reuse_between_stages) return;
  // Every block from the heap, and no free at its top given back: freed blocks are reused.
  const bool kept = mallopt(M_TRIM_THRESHOLD, INT_MAX) == 1;
  const bool heap = mallopt(M_MMAP_MAX, 0) == 1;
  used_ = kept || heap;  // end() restores both either way
#endif
}

void HeapReuseScope::end() {
#if defined(__GLIBC__)
  if (!used_) return;
  constexpr int kGlibcDefaultMmapMax = 65536, kGlibcDefaultTrimThreshold = 128 * 1024;
  mallopt(M_MMAP_MAX, kGlibcDefaultMmapMax);  // setting the defaults again is harmless
  mallopt(M_TRIM_THRESHOLD, kGlibcDefaultTrimThreshold);
  malloc_trim(0);  // the free pages anywhere in the heap, not only at its top
#endif
}

void give_back_free_heap_pages() {
#if defined(__GLIBC__)
  if (g_reuse_between_stages) malloc_trim(0);
#endif
}

}  // namespace meniscus
