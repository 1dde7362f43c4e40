// meniscus — how the process's allocator treats the pipeline's large arrays.
#pragma once

namespace meniscus {

/// Makes the C library's malloc serve every block of 1 MiB or more from its own mapping and give
/// it back to the system when freed. By default glibc raises that threshold to the size of the
/// first large block freed, after which arrays of up to that size come from the heap and their
/// pages stay resident after free: the stages of a run each allocate and free arrays of tens to
/// hundreds of MB, so the peak resident memory then counts freed arrays of earlier stages too.
/// Measured on a 1 M-particle block (default schedule, 2 threads): peak 291 MB → 246 MB, time
/// unchanged. Process-wide and not reversible; the CLI and the benchmarks call it at start-up, a
/// host application decides for itself. Returns false where it does not apply (not glibc).
bool release_large_blocks_eagerly();

}  // namespace meniscus
