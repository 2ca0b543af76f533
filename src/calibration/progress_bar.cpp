#include "collision_response/calibration/progress_bar.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>

namespace collision_response::calibration {

ProgressBar::ProgressBar(bool enabled) : active_(enabled && isatty(STDERR_FILENO) == 1) {}

ProgressBar::~ProgressBar() {
  finish();
}

void ProgressBar::update(double fraction, const std::string& label) {
  if (!active_) return;
  constexpr int kWidth = 30;
  const int filled = static_cast<int>(std::clamp(fraction, 0.0, 1.0) * kWidth + 0.5);
  std::fprintf(stderr, "\r[%.*s%*s] %3d%% %-40.40s", filled, "##############################",
               kWidth - filled, "", static_cast<int>(100.0 * std::clamp(fraction, 0.0, 1.0)),
               label.c_str());
  std::fflush(stderr);
  drawn_ = true;
}

void ProgressBar::finish() {
  if (!active_ || !drawn_) return;
  std::fprintf(stderr, "\r%*s\r", 80, "");
  std::fflush(stderr);
  drawn_ = false;
}

}  // namespace collision_response::calibration
