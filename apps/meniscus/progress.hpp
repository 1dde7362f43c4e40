// meniscus CLI — a one-line progress bar on stderr, shown only on a terminal.
#pragma once

#include <chrono>
#include <cstdio>
#include <string>
#include <string_view>

namespace meniscus::cli {

class ProgressBar {
 public:
  /// Enabled only when `enabled` and stderr is a terminal. `eta`: the fraction is of the whole
  /// job (a sequence), so the time left is shown, extrapolated from the time so far.
  explicit ProgressBar(bool enabled, bool eta = false);
  ~ProgressBar();
  /// Redraws at most ~20 times a second (and whenever the stage changes).
  void update(std::string_view stage, double fraction);
  /// Clears the line.
  void finish();
  bool active() const { return active_; }

 private:
  bool active_ = false;
  bool drawn_ = false;
  bool eta_ = false;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  std::string stage_;
  std::chrono::steady_clock::time_point last_{};
};

}  // namespace meniscus::cli
