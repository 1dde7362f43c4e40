// meniscus — the pipeline's side of reuse_freed_blocks_between_stages() (meniscus/memory.hpp).
#pragma once

namespace meniscus {

/// While alive (and until end()), and only where reuse_freed_blocks_between_stages() was called,
/// every block comes from the C library's heap, so arrays freed by one stage are reused by the
/// next. end() restores large blocks' own mappings and gives the heap's free pages back; called
/// again, it gives back what was freed since (the heap's arrays that later stages replace).
class HeapReuseScope {
 public:
  HeapReuseScope();
  ~HeapReuseScope() { end(); }
  HeapReuseScope(const HeapReuseScope&) = delete;
  HeapReuseScope& operator=(const HeapReuseScope&) = delete;
  void end();

 private:
  bool used_ = false;  ///< the policy was on and this scope changed malloc's settings
};

/// Where reuse_freed_blocks_between_stages() was called: gives the heap's free pages back to the
/// system now (malloc_trim). For a stage that runs after HeapReuseScope::end() and frees arrays the
/// scope placed in the heap, so that they do not stay resident beside the stage's new ones.
void give_back_free_heap_pages();

}  // namespace meniscus
