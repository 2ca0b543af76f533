#pragma once

#include <cmath>
#include <string>

namespace collision_response::core {

/// The accepted range of a numeric option: min <= value <= max, or min < value when min_exclusive.
/// Values outside, and non-finite ones, are rejected naming the field (never clamped).
struct OptionRange {
  double min;
  double max;
  bool min_exclusive = false;

  constexpr bool contains(double value) const {
    return (min_exclusive ? value > min : value >= min) && value <= max;
  }
  /// "[0, 1]" or "(0, 3600]".
  std::string text() const;
};

/// Every range of the solver and detection options, defined once: validate() checks a request's
/// options against them, the node checks its parameters against them at start-up, and
/// dynamic_reconfigure's cfg/Solver.cfg reads its bounds from this file (it parses the lines
/// `inline constexpr OptionRange kName{min, max...};`: keep that form).
namespace option_ranges {
/// SolverOptions::tolerance, ~tolerance: relative impulse change of the iterative solver.
inline constexpr OptionRange kTolerance{0.0, 1.0};
/// SolverOptions::max_iterations, ~max_iterations.
inline constexpr OptionRange kMaxIterations{1.0, 1e8};
/// SolverOptions::integration_tolerance, ~integration_tolerance: relative error.
inline constexpr OptionRange kIntegrationTolerance{1e-15, 1.0};
/// SolverOptions::resting_velocity [m/s].
inline constexpr OptionRange kRestingVelocity{0.0, 1e7};
/// SolverOptions::time_budget, ~time_budget [s].
inline constexpr OptionRange kTimeBudget{0.0, 3600.0, true};
/// DetectionOptions::contact_tolerance, ~contact_tolerance [m].
inline constexpr OptionRange kContactTolerance{0.0, 1.0};
}  // namespace option_ranges

}  // namespace collision_response::core
