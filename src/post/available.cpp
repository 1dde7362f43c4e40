#include "post/available.hpp"

#include "meniscus/errors.hpp"
#include "post/clip.hpp"

namespace meniscus {

void check_post_processing_available(const Params& params) {
  if (const char* why = clip_cap_unavailable(); why && params.clip_cap && !params.clip_box.empty())
    throw InvalidParameter(why);
}

}  // namespace meniscus
