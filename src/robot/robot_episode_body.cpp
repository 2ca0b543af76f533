#include "collision_response/robot/robot_episode_body.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "collision_response/core/errors.h"
#include "collision_response/robot/articulated_body_algorithm.h"
#include "collision_response/robot/link_bodies.h"

namespace collision_response::robot {
namespace {

Eigen::Vector3d toEigen(const KDL::Vector& v) {
  return Eigen::Vector3d(v.x(), v.y(), v.z());
}

}  // namespace

RobotEpisodeBody::RobotEpisodeBody(ArticulatedBody robot) : robot_(std::move(robot)) {
  if (robot_.baseType() == BaseType::kFloating) {
    throw core::InvalidInput("base", "is floating: episodes follow fixed-base robots only");
  }
  robot_.requireRegular();
  const KDL::Frame& f = robot_.data().base_pose;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) base_pose_.linear()(r, c) = f.M(r, c);
    base_pose_.translation()(r) = f.p(r);
  }
}

core::BodyState RobotEpisodeBody::partGeometry(int part) const {
  return linkBody(robot_, part, robot_.linkName(part));
}

void RobotEpisodeBody::partPose(int part, core::BodyState& out) const {
  const KDL::Frame& f = robot_.data().frames[part];
  out.position = toEigen(f.p);
  double x, y, z, w;
  f.M.GetQuaternion(x, y, z, w);
  out.orientation = Eigen::Quaterniond(w, x, y, z);
}

double RobotEpisodeBody::partSpeedBound(int part, double radius) const {
  const RobotData& data = robot_.data();
  const KDL::Twist& twist = data.twists[part];
  const Eigen::Vector3d origin = toEigen(data.frames[part].p);
  const Eigen::Vector3d w = toEigen(twist.rot);
  return (toEigen(twist.vel) + w.cross(origin)).norm() + w.norm() * radius;
}

double RobotEpisodeBody::partAccelerationBound(int part, double radius) const {
  const RobotData& data = robot_.data();
  updateFreeAccelerations(robot_.model(), data);
  const SpatialAcceleration& a = data.free_accelerations[part];
  const KDL::Twist& twist = data.twists[part];
  const Eigen::Vector3d origin = toEigen(data.frames[part].p);
  const Eigen::Vector3d w = toEigen(twist.rot);
  const Eigen::Vector3d v_o = toEigen(twist.vel) + w.cross(origin);
  // a_o = dv/dt at the origin + alpha x o + w x v_o (the material point at the link origin).
  const Eigen::Vector3d a_o = a.linear + a.angular.cross(origin) + w.cross(v_o);
  return 2.0 * (a_o.norm() + (a.angular.norm() + w.squaredNorm()) * radius);
}

bool RobotEpisodeBody::partAngularVelocity(int part, Eigen::Vector3d& w) const {
  w = toEigen(robot_.data().twists[part].rot);
  return true;
}

void RobotEpisodeBody::setGravity(const Eigen::Vector3d& gravity) {
  accelerations_valid_ = false;
  // A new episode: its flight does not depend on the step size an earlier one ended with.
  hint_ = 0.0;
  if (robot_.data().gravity_compensation) {
    robot_.setGravityCompensation(gravity);
  } else {
    robot_.setLoads(robot_.data().torques, gravity);
  }
}

const Eigen::VectorXd& RobotEpisodeBody::jointAccelerations() const {
  if (accelerations_valid_) return accelerations_;
  const int n = robot_.jointCount();
  accelerations_.setZero(n);
  accelerations_valid_ = true;
  if (robot_.velocityCount() == 0) return accelerations_;
  const Eigen::VectorXd vdot = robot_.freeAcceleration();
  for (int j = 0; j < n; ++j) {
    const int u = robot_.unknownOfJoint(j);
    if (u >= 0) accelerations_(j) = robot_.mimicMultiplier(j) * vdot(u);
  }
  return accelerations_;
}

void RobotEpisodeBody::derivative(const Eigen::VectorXd& y, Eigen::VectorXd& dy) {
  const int n = robot_.jointCount();
  dy.resize(2 * n);
  dy.head(n) = y.tail(n);
  if (robot::articulatedBodyApplies(robot_.model())) {
    // Kinematics and the articulated-body algorithm, O(links), without M(q) (advance() sets the
    // full state at its end).
    robot_.setFlightState(y.head(n), y.tail(n), base_pose_);
    accelerations_valid_ = false;
    robot_.flightAcceleration(workspace_, vdot_);
    for (int j = 0; j < n; ++j) {
      const int u = robot_.unknownOfJoint(j);
      dy(n + j) = u >= 0 ? vdot_(u) : 0.0;
    }
    return;
  }
  robot_.setState(y.head(n), y.tail(n), base_pose_);
  accelerations_valid_ = false;
  dy.tail(n) = jointAccelerations();
}

void RobotEpisodeBody::advance(double dt) {
  if (!(dt > 0.0) || robot_.velocityCount() == 0) {
    // Nothing moves but the locked joints' constant velocities.
    if (dt > 0.0 && (robot_.jointVelocities().array() != 0.0).any()) {
      accelerations_valid_ = false;
      robot_.setState(robot_.jointPositions() + dt * robot_.jointVelocities(),
                      robot_.jointVelocities(), base_pose_);
    }
    return;
  }
  // Dormand-Prince 5(4), first same as last.
  static constexpr double c2 = 1.0 / 5, c3 = 3.0 / 10, c4 = 4.0 / 5, c5 = 8.0 / 9;
  static constexpr double a21 = 1.0 / 5;
  static constexpr double a31 = 3.0 / 40, a32 = 9.0 / 40;
  static constexpr double a41 = 44.0 / 45, a42 = -56.0 / 15, a43 = 32.0 / 9;
  static constexpr double a51 = 19372.0 / 6561, a52 = -25360.0 / 2187, a53 = 64448.0 / 6561,
                          a54 = -212.0 / 729;
  static constexpr double a61 = 9017.0 / 3168, a62 = -355.0 / 33, a63 = 46732.0 / 5247,
                          a64 = 49.0 / 176, a65 = -5103.0 / 18656;
  static constexpr double b1 = 35.0 / 384, b3 = 500.0 / 1113, b4 = 125.0 / 192, b5 = -2187.0 / 6784,
                          b6 = 11.0 / 84;
  static constexpr double e1 = 71.0 / 57600, e3 = -71.0 / 16695, e4 = 71.0 / 1920,
                          e5 = -17253.0 / 339200, e6 = 22.0 / 525, e7 = -1.0 / 40;
  (void)c2;
  (void)c3;
  (void)c4;
  (void)c5;
  const int n = robot_.jointCount();
  Eigen::VectorXd y(2 * n), k1, k2, k3, k4, k5, k6, k7, trial, error;
  y << robot_.jointPositions(), robot_.jointVelocities();
  k1.resize(2 * n);
  k1.head(n) = y.tail(n);
  k1.tail(n) = jointAccelerations();
  double t = 0.0;
  double h = hint_ > 0.0 ? std::min(hint_, dt) : std::min(dt, 1e-3);
  bool at_y = true;  // the robot's state is y
  while (t < dt) {
    const bool last = h >= dt - t;
    if (last) h = dt - t;
    stage_ = y + h * a21 * k1;
    derivative(stage_, k2);
    stage_ = y + h * (a31 * k1 + a32 * k2);
    derivative(stage_, k3);
    stage_ = y + h * (a41 * k1 + a42 * k2 + a43 * k3);
    derivative(stage_, k4);
    stage_ = y + h * (a51 * k1 + a52 * k2 + a53 * k3 + a54 * k4);
    derivative(stage_, k5);
    stage_ = y + h * (a61 * k1 + a62 * k2 + a63 * k3 + a64 * k4 + a65 * k5);
    derivative(stage_, k6);
    trial = y + h * (b1 * k1 + b3 * k3 + b4 * k4 + b5 * k5 + b6 * k6);
    derivative(trial, k7);
    error = h * (e1 * k1 + e3 * k3 + e4 * k4 + e5 * k5 + e6 * k6 + e7 * k7);
    double norm = 0.0;
    for (int i = 0; i < 2 * n; ++i) {
      const double scale =
          kRobotFlightTolerance * (1.0 + std::max(std::abs(y(i)), std::abs(trial(i))));
      norm = std::max(norm, std::abs(error(i)) / scale);
    }
    if (!std::isfinite(norm)) {
      throw core::InvalidInput("q", "the robot's flight diverged (joint accelerations not finite)");
    }
    const double factor = norm > 0.0 ? std::clamp(0.9 * std::pow(norm, -0.2), 0.2, 5.0) : 5.0;
    if (norm <= 1.0) {
      ++steps_;
      t = last ? dt : t + h;
      y = trial;
      k1 = k7;
      at_y = true;
      if (!last || factor < 1.0) hint_ = h * factor;
      h *= factor;
    } else {
      at_y = false;
      h *= std::max(factor, 0.1);
      if (h < 1e-14 * std::max(dt, 1e-300)) {
        throw core::InvalidInput("q", "the robot's flight needs steps below 1e-14 of the span");
      }
    }
  }
  if (!at_y) {
    robot_.setState(y.head(n), y.tail(n), base_pose_);
    accelerations_valid_ = false;
  } else {
    // The last right-hand side was at y (its kinematics are y's); the articulated-body path left
    // M(q) stale there.
    if (robot::articulatedBodyApplies(robot_.model())) robot_.completeFlightState();
    accelerations_ = k1.tail(n);  // k7 of the last accepted step: qdd at y
    accelerations_valid_ = true;
  }
}

void RobotEpisodeBody::saveState(Eigen::VectorXd& out) const {
  const int n = robot_.jointCount();
  out.resize(2 * n);
  out << robot_.jointPositions(), robot_.jointVelocities();
}

void RobotEpisodeBody::restoreState(const Eigen::VectorXd& state) {
  const int n = robot_.jointCount();
  robot_.setState(state.head(n), state.tail(n), base_pose_);
  accelerations_valid_ = false;
}

double RobotEpisodeBody::stepLimit() const {
  if (robot_.velocityCount() == 0) return std::numeric_limits<double>::infinity();
  const double speed = robot_.jointVelocities().cwiseAbs().maxCoeff();
  const double acceleration = jointAccelerations().cwiseAbs().maxCoeff();
  // Largest s with speed s + acceleration s^2 / 2 <= kRobotStepAngle.
  if (acceleration <= 0.0) {
    return speed > 0.0 ? kRobotStepAngle / speed : std::numeric_limits<double>::infinity();
  }
  return 2.0 * kRobotStepAngle /
         (speed + std::sqrt(speed * speed + 2.0 * acceleration * kRobotStepAngle));
}

}  // namespace collision_response::robot
