// meniscus — a parallel loop over the indices [0, n), for the element-wise passes of the smoothing
// set-up (adjacency, renumbering) and the Jacobi sweeps.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cstddef>

namespace meniscus {

/// Calls f(i) for every i in [0, n), in parallel over ranges of at least `grain` indices.
template <class F>
void parallel_for_index(std::size_t n, std::size_t grain, F&& f) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) f(i);
  });
}

}  // namespace meniscus
