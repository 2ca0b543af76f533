#include "collision_response/core/rigid_episode_body.h"

#include <limits>

#include "collision_response/core/free_flight.h"

namespace collision_response::core {

RigidEpisodeBody::RigidEpisodeBody(const BodyState& state) : state_(state) {
  state_.orientation.normalize();
}

BodyState RigidEpisodeBody::partGeometry(int /*part*/) const {
  return state_;
}

void RigidEpisodeBody::partPose(int /*part*/, BodyState& out) const {
  out.position = state_.position;
  out.orientation = state_.orientation;
}

double RigidEpisodeBody::partSpeedBound(int /*part*/, double radius) const {
  const double spin = angularSpeedBound(state_);
  return state_.linear_velocity.norm() + (spin > 0.0 ? spin * radius : 0.0);
}

double RigidEpisodeBody::partAccelerationBound(int /*part*/, double /*radius*/) const {
  // The centre of mass' speed grows at most by |g| per second; the spin bound holds over the
  // whole torque-free flight (angularSpeedBound()); an immovable body's velocity is constant.
  if (state_.immovable()) return 0.0;
  return held_ ? held_acceleration_.norm() : gravity_.norm();
}

void RigidEpisodeBody::advance(double dt) {
  advanceFreeFlight(state_, dt, held_ ? held_acceleration_ : gravity_);
}

double RigidEpisodeBody::stepLimit() const {
  // Until the velocity's component against the acceleration is used up (a slip stopping under
  // friction); never for a body that the acceleration speeds up (sliding off from rest).
  const double a2 = held_acceleration_.squaredNorm();
  const double against = -state_.linear_velocity.dot(held_acceleration_);
  if (!held_ || !(a2 > 0.0) || !(against > 0.0)) return std::numeric_limits<double>::infinity();
  return against / a2;
}

bool RigidEpisodeBody::hold(const Eigen::Vector3d& contact_force) {
  if (state_.immovable()) return false;
  held_ = true;
  held_acceleration_ = gravity_ + (state_.force + contact_force) / state_.mass;
  return true;
}

BodyModel& RigidEpisodeBody::model() {
  BodyState loaded = state_;
  if (!loaded.immovable()) loaded.force += loaded.mass * gravity_;
  model_ = makeRigidBody(loaded);
  setFreeAcceleration(loaded, model_);
  return model_;
}

void RigidEpisodeBody::syncFromModel() {
  if (state_.immovable()) return;
  state_.linear_velocity = model_.linear_velocity;
  state_.angular_velocity = model_.angular_velocity;
}

void RigidEpisodeBody::saveState(Eigen::VectorXd& out) const {
  out.resize(13);
  out << state_.position, state_.orientation.coeffs(), state_.linear_velocity,
      state_.angular_velocity;
}

void RigidEpisodeBody::restoreState(const Eigen::VectorXd& state) {
  state_.position = state.segment<3>(0);
  state_.orientation.coeffs() = state.segment<4>(3);
  state_.linear_velocity = state.segment<3>(7);
  state_.angular_velocity = state.segment<3>(10);
}

bool RigidEpisodeBody::translate(const Eigen::Vector3d& shift) {
  if (state_.immovable()) return false;
  state_.position += shift;
  return true;
}

BodyState RigidEpisodeBody::stateFrom(const BodyState& body, const Eigen::VectorXd& saved) {
  RigidEpisodeBody copy(body);
  copy.restoreState(saved);
  return copy.state_;
}

double RigidEpisodeBody::kineticEnergy() const {
  return core::kineticEnergy(state_);
}

}  // namespace collision_response::core
