#pragma once

#include <functional>

namespace collision_response::core {

/// A coordinate of a body's configuration that the impact map depends on through the body's
/// model (a robot's joint position changes its mass matrix M(q) and its links' point Jacobians),
/// offered to computeBodyImpactDerivatives() to differentiate by. The core knows no
/// configurations: the body's owner says how to move one (robot/joint_position_coordinates.h).
struct ConfigurationCoordinate {
  double value = 0.0;  ///< the coordinate now [rad | m]
  /// Puts the coordinate at x and recomputes everything the body's model derives from it; the
  /// body's velocity unknowns may change (the caller resets them). set(value) restores the body's
  /// model exactly (the same computations from the same numbers).
  std::function<void(double x)> set;
};

}  // namespace collision_response::core
