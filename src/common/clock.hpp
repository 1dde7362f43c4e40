// meniscus — the stage clock: seconds since a steady_clock time point.
#pragma once

#include <chrono>

namespace meniscus {

inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace meniscus
