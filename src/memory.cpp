// meniscus — the allocator setting of meniscus/memory.hpp.
#include "meniscus/memory.hpp"

#include <cstdlib>  // defines __GLIBC__ on glibc

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace meniscus {

bool release_large_blocks_eagerly() {
#if defined(__GLIBC__)
  // Setting M_MMAP_THRESHOLD also turns off glibc's dynamic raising of it.
  constexpr int kThreshold = 1 << 20;
  return mallopt(M_MMAP_THRESHOLD, kThreshold) == 1;
#else
  return false;
#endif
}

}  // namespace meniscus
