#pragma once

#include <Eigen/Core>

#include "collision_response/core/rigid_body.h"

namespace collision_response::core {

/// The geometry of one contact between two free rigid bodies a and b, with the symbols of
/// docs/physics.md, "Symbols and conventions": r_i = p - c_i, u = v_b(p) - v_a(p) the relative
/// velocity at the contact point, and K = sum over movable i of (I3 / m_i - [r_i]x Iw_i^-1 [r_i]x),
/// the contact-space inverse mass matrix: an impulse P applied +P on b and -P on a changes u by
/// K P. The contact problem (contact_problem.h) uses it for its rigid-body fast path; K is the
/// diagonal block W_ii of the problem's Delassus operator.
struct ContactSpace {
  Eigen::Vector3d r_a;
  Eigen::Vector3d r_b;
  Eigen::Matrix3d K;

  ContactSpace(const RigidBody& a, const RigidBody& b, const Eigen::Vector3d& point);

  /// u = v_b(p) - v_a(p) [m/s].
  Eigen::Vector3d relativeVelocity(const RigidBody& a, const RigidBody& b) const {
    return b.pointVelocity(r_b) - a.pointVelocity(r_a);
  }

  /// Applies +p to b and -p to a at the contact point.
  void applyImpulse(RigidBody& a, RigidBody& b, const Eigen::Vector3d& p) const {
    a.applyImpulse(-p, r_a);
    b.applyImpulse(p, r_b);
  }
};

/// Contribution I3 / m - [r]x Iw^-1 [r]x of one rigid body, touched at offset r, to K (zero for an
/// immovable body) [1/kg].
Eigen::Matrix3d rigidContactBlock(const RigidBody& body, const Eigen::Vector3d& r);

/// Unit vectors t1, t2 completing n to a right-handed orthonormal basis (n must be unit).
void tangentBasis(const Eigen::Vector3d& n, Eigen::Vector3d& t1, Eigen::Vector3d& t2);

}  // namespace collision_response::core
