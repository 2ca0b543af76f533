// A progress bar on stderr for the identify program, drawn only when stderr is a terminal.
#pragma once

#include <string>

namespace collision_response::calibration {

class ProgressBar {
 public:
  /// `enabled` false (or stderr not a terminal): every call does nothing.
  explicit ProgressBar(bool enabled = true);
  ~ProgressBar();
  /// Redraws the bar at fraction in [0, 1] with a label.
  void update(double fraction, const std::string& label);
  /// Clears the line.
  void finish();

 private:
  bool active_;
  bool drawn_ = false;
};

}  // namespace collision_response::calibration
