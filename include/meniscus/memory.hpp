// meniscus — the process's peak memory, and how its allocator treats the pipeline's large arrays.
#pragma once

#include <cstddef>

namespace meniscus {

/// The process's peak resident memory so far, in bytes (getrusage's ru_maxrss): what --stats
/// reports as peak_memory_bytes.
std::size_t peak_resident_bytes();

/// Makes the C library's malloc serve every block of 1 MiB or more from its own mapping and give
/// it back to the system when freed. By default glibc raises that threshold to the size of the
/// first large block freed, after which arrays of up to that size come from the heap and their
/// pages stay resident after free: the stages of a run each allocate and free arrays of tens to
/// hundreds of MB, so the peak resident memory then counts freed arrays of earlier stages too.
/// On a 1 M-particle block it lowers the peak by about a sixth, at the same speed. Process-wide
/// and not reversible; the CLI and the benchmarks call it at start-up, a
/// host application decides for itself. Returns false where it does not apply (not glibc).
bool release_large_blocks_eagerly();

/// Lets reconstruct() keep the large arrays its stages free up to the smoothing in the C library's
/// heap, where the next stage reuses their pages instead of faulting in fresh ones that the
/// kernel must zero first (each stage's arrays are about the size of the last one's). Before the
/// smoothing and at the end of the run the heap's free pages go back to the system (malloc_trim)
/// and large blocks get their own mappings again, so the peak stays that of
/// release_large_blocks_eagerly(): the smoothing's arrays are many and of many sizes, and a heap
/// would fragment under them. The stages before the smoothing then spend less time in page
/// faults, for a peak hardly higher (docs/method.md "Memory"). Process-wide: it changes malloc's
/// settings while a run is in those stages and then leaves glibc's default mmap count and trim
/// threshold (its dynamic thresholds off, as release_large_blocks_eagerly() leaves them). The CLI
/// and the benchmarks turn it on at start-up. Returns false where it does not apply (not glibc).
bool reuse_freed_blocks_between_stages();

}  // namespace meniscus
