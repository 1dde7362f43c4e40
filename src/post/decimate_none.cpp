// meniscus — simplification in a build without meshoptimizer (post/decimate.hpp): refused.
#include "meniscus/errors.hpp"
#include "post/decimate.hpp"

namespace meniscus {

const char* decimate_unavailable() {
  return "decimate: this meniscus was built without meshoptimizer (Debian: libmeshoptimizer-dev), whose edge "
         "collapses it runs; surface without decimate or rebuild with meshoptimizer";
}

DecimateOutcome decimate(TriangleMesh&, double) { throw InvalidParameter(decimate_unavailable()); }

}  // namespace meniscus
