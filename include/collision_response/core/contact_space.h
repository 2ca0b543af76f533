#pragma once

#include <Eigen/Core>

#include "collision_response/core/rigid_body.h"

namespace collision_response::core {

/// The geometry of one contact between bodies a and b, with the symbols of docs/physics.md,
/// "Symbols and conventions": r_i = p - c_i, u = v_b(p) - v_a(p) the relative velocity at the
/// contact point, and K = sum over movable i of (I3 / m_i - [r_i]x Iw_i^-1 [r_i]x), the
/// contact-space inverse mass matrix: an impulse P applied +P on b and -P on a changes u by K P.
struct ContactSpace {
  Eigen::Vector3d r_a;
  Eigen::Vector3d r_b;
  Eigen::Matrix3d K;
  /// Added to every relative velocity; zero for impacts. The resting-contact analysis, which runs
  /// the same solvers on accelerations, puts the centripetal term w_b x (w_b x r_b) - w_a x (w_a x
  /// r_a) here.
  Eigen::Vector3d bias = Eigen::Vector3d::Zero();

  ContactSpace(const RigidBody& a, const RigidBody& b, const Eigen::Vector3d& point);

  /// u = v_b(p) - v_a(p) [m/s].
  Eigen::Vector3d relativeVelocity(const RigidBody& a, const RigidBody& b) const {
    return b.pointVelocity(r_b) - a.pointVelocity(r_a) + bias;
  }

  /// Applies +p to b and -p to a at the contact point.
  void applyImpulse(RigidBody& a, RigidBody& b, const Eigen::Vector3d& p) const {
    a.applyImpulse(-p, r_a);
    b.applyImpulse(p, r_b);
  }
};

/// Unit vectors t1, t2 completing n to a right-handed orthonormal basis (n must be unit).
void tangentBasis(const Eigen::Vector3d& n, Eigen::Vector3d& t1, Eigen::Vector3d& t2);

}  // namespace collision_response::core
