// meniscus — the cap of a box cut in a build without CGAL (post/clip.hpp): refused.
#include "meniscus/errors.hpp"
#include "post/clip.hpp"

namespace meniscus {

const char* clip_cap_unavailable() {
  return "clip_cap: this meniscus was built without CGAL (Debian: libcgal-dev), which triangulates the cap; "
         "clip without the cap or rebuild with CGAL";
}

void cap_box_faces(TriangleMesh&, const ClipBox&, const TriangleBvh&, ClipOutcome&) {
  throw InvalidParameter(clip_cap_unavailable());
}

}  // namespace meniscus
