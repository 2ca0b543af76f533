#pragma once

#include <Eigen/Core>

namespace collision_response::core {

/// Impulse exchanged at one contact: +total() acts on body b, -total() on body a.
struct ContactImpulse {
  double normal_impulse = 0.0;                                 ///< j_r >= 0 [N s], along the normal
  Eigen::Vector3d friction_impulse = Eigen::Vector3d::Zero();  ///< tangential [N s]
  /// Friction holds the contact: no tangential slip at the end of the impact. Always false for a
  /// frictionless contact (nothing holds it, whatever its tangential velocity).
  bool sticking = false;
  double normal_velocity_before = 0.0;  ///< u_n before [m/s], negative when approaching
  double normal_velocity_after = 0.0;   ///< u_n after [m/s]
  /// Resting contacts (force-based Coulomb model, no impulse): the contact forces that hold the
  /// bodies' external wrenches; +force on b, -force on a. `sticking` then says whether it holds.
  bool resting = false;
  double normal_force = 0.0;                                 ///< [N], >= 0
  Eigen::Vector3d friction_force = Eigen::Vector3d::Zero();  ///< tangential [N]

  Eigen::Vector3d total(const Eigen::Vector3d& normal) const {
    return normal_impulse * normal + friction_impulse;
  }
};

}  // namespace collision_response::core
