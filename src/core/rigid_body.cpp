#include "collision_response/core/rigid_body.h"

#include <Eigen/LU>

namespace collision_response::core {

RigidBody makeRigidBody(const BodyState& state) {
  RigidBody body;
  body.com = state.worldCom();
  body.linear_velocity = state.linear_velocity;
  body.angular_velocity = state.angular_velocity;
  if (!state.immovable()) {
    const Eigen::Matrix3d R = state.orientation.normalized().toRotationMatrix();
    body.inverse_mass = 1.0 / state.mass;
    body.inverse_inertia = R * state.inertia.inverse() * R.transpose();
    // Symmetrise: R I^-1 R^T is symmetric in exact arithmetic, and K must be.
    body.inverse_inertia = 0.5 * (body.inverse_inertia + body.inverse_inertia.transpose()).eval();
  }
  return body;
}

}  // namespace collision_response::core
