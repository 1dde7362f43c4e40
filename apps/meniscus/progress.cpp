// meniscus CLI — progress bar.
#include "progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <fmt/format.h>

namespace meniscus::cli {

ProgressBar::ProgressBar(bool enabled) : active_(enabled && isatty(STDERR_FILENO)) {}
ProgressBar::~ProgressBar() { finish(); }

void ProgressBar::update(std::string_view stage, double fraction) {
  if (!active_) return;
  const auto now = std::chrono::steady_clock::now();
  if (stage == stage_ && now - last_ < std::chrono::milliseconds(50) && fraction < 1.0) return;
  last_ = now;
  stage_ = stage;
  constexpr int kWidth = 30;
  const int filled = std::clamp(int(fraction * kWidth + 0.5), 0, kWidth);
  fmt::print(stderr, "\r\033[K{:<14} [{}{}] {:3.0f}%", stage, std::string(std::size_t(filled), '#'),
             std::string(std::size_t(kWidth - filled), '.'), std::clamp(fraction, 0.0, 1.0) * 100);
  std::fflush(stderr);
  drawn_ = true;
}

void ProgressBar::finish() {
  if (active_ && drawn_) {
    fmt::print(stderr, "\r\033[K");
    std::fflush(stderr);
  }
  drawn_ = false;
}

}  // namespace meniscus::cli
