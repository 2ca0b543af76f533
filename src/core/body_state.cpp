#include "collision_response/core/body_state.h"

namespace collision_response::core {

double kineticEnergy(const BodyState& body) {
  if (body.immovable()) return 0.0;
  const Eigen::Matrix3d R = body.orientation.normalized().toRotationMatrix();
  const Eigen::Vector3d w_body = R.transpose() * body.angular_velocity;
  return 0.5 * body.mass * body.linear_velocity.squaredNorm() +
         0.5 * w_body.dot(body.inertia * w_body);
}

BodyState transformed(const BodyState& body, const Eigen::Isometry3d& new_T_old) {
  BodyState out = body;
  const Eigen::Matrix3d R = new_T_old.rotation();
  out.position = new_T_old * body.position;
  out.orientation = Eigen::Quaterniond(R) * body.orientation;
  out.linear_velocity = R * body.linear_velocity;
  out.angular_velocity = R * body.angular_velocity;
  out.force = R * body.force;
  out.torque = R * body.torque;
  return out;
}

}  // namespace collision_response::core
