// meniscus — what post-processing this build can do: the optional library behind --clip-cap
// (CGAL).
#pragma once

#include "meniscus/params.hpp"

namespace meniscus {

/// Throws InvalidParameter, naming the missing library, when `params` ask for post-processing this
/// build has not got; reconstruct() and the CLI call it before any work.
void check_post_processing_available(const Params& params);

}  // namespace meniscus
