// meniscus CLI — progress bar.
#include "progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <fmt/format.h>
#include <string>

namespace meniscus::cli {

namespace {

/// "42 s", "3 min 05 s", "1 h 02 min".
std::string duration_text(double seconds) {
  const long s = long(seconds + 0.5);
  if (s < 60) return fmt::format("{} s", s);
  if (s < 3600) return fmt::format("{} min {:02} s", s / 60, s % 60);
  return fmt::format("{} h {:02} min", s / 3600, (s % 3600) / 60);
}

}  // namespace

ProgressBar::ProgressBar(bool enabled, bool eta) : active_(enabled && isatty(STDERR_FILENO)), eta_(eta) {}
ProgressBar::~ProgressBar() { finish(); }

void ProgressBar::update(std::string_view stage, double fraction) {
  if (!active_) return;
  const auto now = std::chrono::steady_clock::now();
  if (stage == stage_ && now - last_ < std::chrono::milliseconds(50) && fraction < 1.0) return;
  last_ = now;
  stage_ = stage;
  constexpr int kWidth = 30;
  const int filled = std::clamp(int(fraction * kWidth + 0.5), 0, kWidth);
  std::string left;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  // Extrapolated once a little of the job is done, so that the first frame's set-up does not
  // dominate the estimate.
  if (eta_ && fraction >= 0.01 && fraction < 1 && elapsed >= 0.25)
    left = fmt::format(", {} left", duration_text(elapsed * (1 - fraction) / fraction));
  fmt::print(stderr, "\r\033[K{:<14} [{}{}] {:3.0f}%{}", stage, std::string(std::size_t(filled), '#'),
             std::string(std::size_t(kWidth - filled), '.'), std::clamp(fraction, 0.0, 1.0) * 100, left);
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
