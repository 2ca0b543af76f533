#pragma once

#include <chrono>
#include <string>

#include "collision_response/core/errors.h"

namespace collision_response::core {

/// A wall-clock limit for a solve. A default-constructed Deadline never expires.
class Deadline {
 public:
  using Clock = std::chrono::steady_clock;

  Deadline() = default;
  /// Expires `seconds` from now.
  static Deadline in(double seconds) {
    Deadline deadline;
    deadline.end_ = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                       std::chrono::duration<double>(seconds));
    deadline.budget_ = seconds;
    return deadline;
  }

  bool expired() const { return end_ != Clock::time_point::max() && Clock::now() > end_; }

  /// Throws SolverTimeout naming `where` once expired.
  void check(const char* where) const {
    if (expired()) {
      throw SolverTimeout(std::string(where) + " exceeded the time budget of " +
                          std::to_string(budget_) + " s");
    }
  }

 private:
  Clock::time_point end_ = Clock::time_point::max();
  double budget_ = 0.0;
};

}  // namespace collision_response::core
