// Tests of meniscus/memory.hpp: blocks of 1 MiB and more stay mapped (and are unmapped on free)
// even after a larger block was freed, which by default would raise glibc's mmap threshold; and
// between stages (HeapReuseScope) freed blocks are reused from the heap, then given back.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "system/memory_scope.hpp"
#include "meniscus/memory.hpp"
#include "support/test_support.hpp"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace meniscus {
namespace {

TEST(Memory, LargeBlocksStayMappedAfterALargerOneWasFreed) {
#if !defined(__GLIBC__)
  GTEST_SKIP() << "glibc's own malloc only";
#else
  if (test::kSanitized) GTEST_SKIP() << "glibc's own malloc only (a sanitizer replaces it)";
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

TEST(Memory, BetweenStagesFreedBlocksAreReusedAndThenGivenBack) {
#if !defined(__GLIBC__)
  GTEST_SKIP() << "glibc's own malloc only";
#else
  if (test::kSanitized) GTEST_SKIP() << "glibc's own malloc only (a sanitizer replaces it)";
  ASSERT_TRUE(release_large_blocks_eagerly());
  constexpr std::size_t kBlock = std::size_t(64) << 20;
  {
    HeapReuseScope off;  // the policy is not on yet: a large block gets its own mapping
    const std::size_t mapped_before = mallinfo2().hblkhd;
    void* volatile block = std::malloc(kBlock);
    ASSERT_NE(block, nullptr);
    EXPECT_GE(mallinfo2().hblkhd, mapped_before + kBlock);
    std::free(block);
  }
  ASSERT_TRUE(reuse_freed_blocks_between_stages());
  HeapReuseScope scope;
  const std::size_t mapped_before = mallinfo2().hblkhd;
  void* volatile first = std::malloc(kBlock);
  ASSERT_NE(first, nullptr);
  std::memset(first, 1, kBlock);
  EXPECT_EQ(mallinfo2().hblkhd, mapped_before) << "from the heap, not a mapping of its own";
  void* const where = first;
  std::free(first);
  EXPECT_GE(mallinfo2().fordblks, kBlock) << "kept by the heap after free";
  void* volatile second = std::malloc(kBlock);  // the next stage's array: the same, resident pages
  EXPECT_EQ(second, where);
  std::free(second);
  scope.end();
  EXPECT_LT(mallinfo2().fordblks, kBlock / 2) << "free heap pages given back at the end";
  void* volatile after = std::malloc(kBlock);  // and large blocks are mapped again
  ASSERT_NE(after, nullptr);
  EXPECT_GE(mallinfo2().hblkhd, mapped_before + kBlock);
  std::free(after);
#endif
}

/// The process's resident set, in bytes (0 where /proc is not there).
[[maybe_unused]] std::size_t resident_bytes() {
  std::FILE* f = std::fopen("/proc/self/status", "r");
  if (f == nullptr) return 0;
  char line[256];
  std::size_t kb = 0;
  while (std::fgets(line, sizeof line, f) != nullptr)
    if (std::strncmp(line, "VmRSS:", 6) == 0) kb = std::strtoull(line + 6, nullptr, 10);
  std::fclose(f);
  return kb * 1024;
}

TEST(Memory, FreeHeapPagesGivenBackInTheMiddleOfTheHeap) {
#if !defined(__GLIBC__)
  GTEST_SKIP() << "glibc's own malloc only";
#else
  if (test::kSanitized) GTEST_SKIP() << "glibc's own malloc only (a sanitizer replaces it)";
  ASSERT_TRUE(release_large_blocks_eagerly());
  ASSERT_TRUE(reuse_freed_blocks_between_stages());
  constexpr std::size_t kBlock = std::size_t(64) << 20;
  void* volatile block = nullptr;
  void* volatile above = nullptr;
  {
    HeapReuseScope scope;  // a stage's array in the heap, and a later one above it
    block = std::malloc(kBlock);
    above = std::malloc(std::size_t(4) << 20);
    ASSERT_NE(block, nullptr);
    ASSERT_NE(above, nullptr);
    std::memset(block, 1, kBlock);
    std::memset(above, 1, std::size_t(4) << 20);
  }
  std::free(block);  // freed after the scope: in the middle of the heap, still resident
  const std::size_t before = resident_bytes();
  if (before == 0) GTEST_SKIP() << "no /proc/self/status";
  give_back_free_heap_pages();
  EXPECT_LT(resident_bytes() + kBlock / 2, before) << "the freed block's pages leave the resident set";
  std::free(above);
#endif
}

}  // namespace
}  // namespace meniscus
