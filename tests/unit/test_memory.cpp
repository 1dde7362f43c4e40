// Tests of meniscus/memory.hpp: blocks of 1 MiB and more stay mapped (and are unmapped on free)
// even after a larger block was freed, which by default would raise glibc's mmap threshold.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>

#include "meniscus/memory.hpp"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#if defined(__SANITIZE_ADDRESS__)
#define MENISCUS_TEST_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define MENISCUS_TEST_SANITIZED 1
#endif
#endif

namespace meniscus {
namespace {

TEST(Memory, LargeBlocksStayMappedAfterALargerOneWasFreed) {
#if !defined(__GLIBC__) || defined(MENISCUS_TEST_SANITIZED)
  GTEST_SKIP() << "glibc's own malloc only (a sanitizer replaces it)";
#else
  ASSERT_TRUE(release_large_blocks_eagerly());
  // Freeing a 16 MiB mapping would raise the dynamic threshold to 16 MiB (it rises up to 32) ...
  constexpr std::size_t kBig = std::size_t(16) << 20, kBlock = std::size_t(4) << 20;
  void* volatile big = std::malloc(kBig);  // volatile: the compiler may not drop the pair
  ASSERT_NE(big, nullptr);
  std::memset(big, 1, kBig);
  std::free(big);
  // ... and a 4 MiB block would then come from the heap; with the fixed threshold it is mapped.
  const std::size_t mapped_before = mallinfo2().hblkhd;
  void* volatile block = std::malloc(kBlock);
  ASSERT_NE(block, nullptr);
  std::memset(block, 1, kBlock);
  EXPECT_GE(mallinfo2().hblkhd, mapped_before + kBlock);
  std::free(block);
  EXPECT_EQ(mallinfo2().hblkhd, mapped_before);  // and unmapped again on free
#endif
}

}  // namespace
}  // namespace meniscus
