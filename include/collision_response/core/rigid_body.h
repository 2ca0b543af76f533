#pragma once

#include <Eigen/Core>

#include "collision_response/core/body_state.h"

namespace collision_response::core {

/// A body prepared for the solvers: world-frame inverse mass properties and velocities of the
/// centre of mass. An immovable body has inverse_mass 0 and a zero inverse inertia, and is never
/// changed.
struct RigidBody {
  double inverse_mass = 0.0;                                   ///< [1/kg]
  Eigen::Matrix3d inverse_inertia = Eigen::Matrix3d::Zero();   ///< R I^-1 R^T, world [1/(kg m^2)]
  Eigen::Vector3d com = Eigen::Vector3d::Zero();               ///< centre of mass, world [m]
  Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero();   ///< world [m/s]
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  ///< world [rad/s]

  bool movable() const { return inverse_mass > 0.0; }

  /// Velocity of the material point at offset r from the centre of mass [m/s].
  Eigen::Vector3d pointVelocity(const Eigen::Vector3d& r) const {
    return linear_velocity + angular_velocity.cross(r);
  }

  /// Applies the impulse p [N s] at offset r from the centre of mass (no-op for immovable bodies).
  void applyImpulse(const Eigen::Vector3d& p, const Eigen::Vector3d& r) {
    if (!movable()) return;
    linear_velocity += inverse_mass * p;
    angular_velocity += inverse_inertia * r.cross(p);
  }
};

/// Builds the solver's view of a validated body state.
RigidBody makeRigidBody(const BodyState& state);

}  // namespace collision_response::core
