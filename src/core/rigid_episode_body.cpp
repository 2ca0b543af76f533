#include "collision_response/core/rigid_episode_body.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
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

double RigidEpisodeBody::partAccelerationBound(int /*part*/, double radius) const {
  // The centre of mass' speed grows at most by |g| per second; the spin bound holds over the
  // whole torque-free flight (angularSpeedBound()); an immovable body's velocity is constant.
  // Held: |v(t)| + |w(t)| r grows at most by |a| + |alpha| r per second (w = w0 + alpha t).
  if (state_.immovable()) return 0.0;
  if (!held_) return gravity_.norm();
  return held_acceleration_.norm() + held_angular_acceleration_.norm() * radius;
}

void RigidEpisodeBody::advance(double dt) {
  if (!held_) {
    advanceFreeFlight(state_, dt, gravity_);
    return;
  }
  if (!(dt > 0.0)) return;
  // The centre of mass on its parabola under a, the angular velocity w0 + alpha t; the orientation
  // turned by Magnus' expansion of dR/dt = [w(t)]x R to its second term, w0 t + alpha t^2 / 2 +
  // (alpha x w0) t^3 / 12: exact when alpha is parallel to w0 (a spin about a fixed axis, as of a
  // body turning on a plane about its normal), else to O(t^4).
  const Eigen::Quaterniond q0 = state_.orientation.normalized();
  const Eigen::Vector3d com = state_.position + q0 * state_.com;
  const Eigen::Vector3d& w0 = state_.angular_velocity;
  const Eigen::Vector3d& alpha = held_angular_acceleration_;
  const Eigen::Vector3d turn =
      dt * w0 + 0.5 * dt * dt * alpha + (dt * dt * dt / 12.0) * alpha.cross(w0);
  const double angle = turn.norm();
  Eigen::Quaterniond q1 = q0;
  if (angle > 0.0) q1 = Eigen::Quaterniond(Eigen::AngleAxisd(angle, turn / angle)) * q0;
  q1.normalize();
  const Eigen::Vector3d com1 =
      com + dt * state_.linear_velocity + 0.5 * dt * dt * held_acceleration_;
  state_.linear_velocity += dt * held_acceleration_;
  state_.angular_velocity += dt * alpha;
  state_.orientation = q1;
  state_.position = com1 - q1 * state_.com;
}

double RigidEpisodeBody::stepLimit() const {
  // Until the velocity's or the angular velocity's component against its acceleration is used up
  // (a slip or a spin stopping under friction); never for a body that the accelerations speed up
  // (sliding off from rest).
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  if (!held_) return kInfinity;
  const auto until = [](const Eigen::Vector3d& velocity, const Eigen::Vector3d& acceleration) {
    const double a2 = acceleration.squaredNorm();
    const double against = -velocity.dot(acceleration);
    return a2 > 0.0 && against > 0.0 ? against / a2 : kInfinity;
  };
  const Eigen::Vector3d& w = state_.angular_velocity;
  const Eigen::Vector3d& alpha = held_angular_acceleration_;
  // And until it turns by kHeldTurn: the contact forces, held constant in the world, turn with the
  // body's slip directions (exactly so in torque alone for a spin about a contact normal, only to
  // first order in the angle once it also slides). |w| stays at most |w0| while the spin slows (up
  // to its stop), and grows at most by |alpha| per second otherwise.
  const double spin = w.norm();
  const double speeding = w.dot(alpha) > 0.0 ? alpha.norm() : 0.0;
  const double turn =
      spin > 0.0 ? 2.0 * kHeldTurn / (spin + std::sqrt(spin * spin + 2.0 * speeding * kHeldTurn))
      : speeding > 0.0 ? std::sqrt(2.0 * kHeldTurn / speeding)
                       : kInfinity;
  // And, sliding and spinning at once, until v or w has changed by about kHeldTurn of itself: the
  // slip directions of the contacts (v + w x r) then turn with the ratio of slide to spin even
  // without the body turning, and the held forces follow them to first order in that change. The
  // relative rates grow without bound towards a stop, so the step is at least kHeldMinimumStep.
  // Round-off velocities (a body held at rest: below kHeldRoundOff) do not count: their relative
  // rates mean nothing.
  constexpr double kHeldRoundOff = 1e-9;  // [m/s], [rad/s]
  const double v = state_.linear_velocity.norm();
  const double rate = v > kHeldRoundOff && spin > kHeldRoundOff
                          ? held_acceleration_.norm() / v + alpha.norm() / spin
                          : 0.0;
  const double mix = rate > 0.0 ? std::max(kHeldMinimumStep, kHeldTurn / rate) : kInfinity;
  return std::min({until(state_.linear_velocity, held_acceleration_), until(w, alpha), turn, mix});
}

bool RigidEpisodeBody::hold(const Eigen::Vector3d& contact_force,
                            const Eigen::Vector3d& contact_torque) {
  if (state_.immovable()) return false;
  held_ = true;
  held_acceleration_ = gravity_ + (state_.force + contact_force) / state_.mass;
  // alpha = I^-1 (tau_own - w x I w) (setFreeAcceleration()) + I^-1 tau_contact, the contact
  // torque taken about the centre of mass: tau_origin - c x F.
  RigidBody rigid = makeRigidBody(state_);
  setFreeAcceleration(state_, rigid);
  held_angular_acceleration_ =
      rigid.angular_acceleration +
      rigid.inverse_inertia * (contact_torque - rigid.com.cross(contact_force));
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
