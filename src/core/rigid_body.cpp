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

void setFreeAcceleration(const BodyState& state, RigidBody& body) {
  if (!body.movable()) {
    body.linear_acceleration.setZero();
    body.angular_acceleration.setZero();
    return;
  }
  const Eigen::Vector3d& w = body.angular_velocity;
  // Iw w from the body-frame tensor (not by inverting Iw^-1, which loses the small moments).
  const Eigen::Matrix3d R = state.orientation.normalized().toRotationMatrix();
  const Eigen::Vector3d Iw_w = R * (state.inertia * (R.transpose() * w));
  body.linear_acceleration = body.inverse_mass * state.force;
  body.angular_acceleration = body.inverse_inertia * (state.torque - w.cross(Iw_w));
}

void makeRigidBodies(const std::vector<BodyState>& states, std::vector<RigidBody>& bodies) {
  bodies.clear();
  bodies.reserve(states.size());
  for (const BodyState& state : states) bodies.push_back(makeRigidBody(state));
}

void setFreeAccelerations(const std::vector<BodyState>& states, std::vector<RigidBody>& bodies) {
  for (std::size_t i = 0; i < bodies.size(); ++i) setFreeAcceleration(states[i], bodies[i]);
}

Eigen::VectorXd RigidBody::velocity() const {
  Eigen::VectorXd v(velocityCount());
  if (movable()) v << linear_velocity, angular_velocity;
  return v;
}

Eigen::Matrix<double, 3, Eigen::Dynamic> RigidBody::pointJacobian(
    const Eigen::Vector3d& point) const {
  Eigen::Matrix<double, 3, Eigen::Dynamic> J(3, velocityCount());
  if (movable()) J << Eigen::Matrix3d::Identity(), -skew(point - com);  // v + w x r
  return J;
}

Eigen::Matrix<double, Eigen::Dynamic, 3> RigidBody::inverseMassJacobianTranspose(
    const Eigen::Vector3d& point) const {
  Eigen::Matrix<double, Eigen::Dynamic, 3> out(velocityCount(), 3);
  if (movable()) {
    out << inverse_mass * Eigen::Matrix3d::Identity(), inverse_inertia * skew(point - com);
  }
  return out;
}

void RigidBody::addVelocityChange(const Eigen::Ref<const Eigen::VectorXd>& change) {
  if (!movable()) return;
  linear_velocity += change.head<3>();
  angular_velocity += change.tail<3>();
}

}  // namespace collision_response::core
