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

  /// When it expires (Clock::time_point::max(): never).
  Clock::time_point end() const { return end_; }
  bool expired() const { return end_ != Clock::time_point::max() && Clock::now() > end_; }

  /// A deadline `fraction` (0..1) of the way from now to this one, with the same budget in its
  /// message; this one if it never expires or has expired.
  Deadline portion(double fraction) const {
    Deadline out = *this;
    const Clock::time_point now = Clock::now();
    if (end_ != Clock::time_point::max() && now < end_) {
      out.end_ = now + std::chrono::duration_cast<Clock::duration>((end_ - now) * fraction);
    }
    return out;
  }

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
