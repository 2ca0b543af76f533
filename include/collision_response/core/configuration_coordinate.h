#pragma once

#include <functional>

#include "collision_response/core/body_model.h"

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
  /// The body whose model the coordinate moves and its index among that body's own coordinates
  /// (BodyModel::configurationCount()), when the body can differentiate by it: the impact's
  /// derivative by the coordinate is then taken in closed form where the island's is
  /// (computeBodyImpactDerivatives()). nullptr (the default): central differences through set().
  const BodyModel* body = nullptr;
  int index = -1;
};

}  // namespace collision_response::core
