// Test helpers: the rigid two-body geometry (ContactSpace: lever arms, K, relative velocity) of a
// ContactPoint between bodies given by the test.
#pragma once

#include <Eigen/Core>

#include "collision_response/core/contact_point.h"
#include "collision_response/core/contact_space.h"
#include "collision_response/core/rigid_body.h"

namespace collision_response::testing {

inline core::ContactSpace spaceOf(const core::ContactPoint& contact, const core::RigidBody& a,
                                  const core::RigidBody& b) {
  return core::ContactSpace(a, b, contact.point);
}

/// u = v_b(p) - v_a(p) [m/s] of the contact.
inline Eigen::Vector3d velocityAt(const core::ContactPoint& contact, const core::RigidBody& a,
                                  const core::RigidBody& b) {
  return spaceOf(contact, a, b).relativeVelocity(a, b);
}

}  // namespace collision_response::testing
