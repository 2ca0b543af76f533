#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "collision_response/core/episode_body.h"
#include "collision_response/robot/articulated_body.h"
#include "collision_response/robot/articulated_body_algorithm.h"

namespace collision_response::robot {

/// Local error tolerance of a robot's flight in an episode (RobotEpisodeBody::advance()): per
/// integration step, each joint position's error [rad | m] and velocity's error [rad/s | m/s] is
/// kept below this times (1 + its magnitude).
constexpr double kRobotFlightTolerance = 1e-10;

/// Joint angle [rad] (or travel [m]) a robot's joints may turn through in one step of an episode's
/// conservative advancement (RobotEpisodeBody::stepLimit()): over it the links' Jacobians and
/// accelerations change little, so that the acceleration bound (with its margin of 2) holds.
constexpr double kRobotStepAngle = 0.05;

/// A robot in an impact episode (core::EpisodeBody; docs/robots.md, "Robots in episodes"): its
/// parts are its links (link index; linkBody() poses them for the geometry, their reference point
/// the link frame's origin). Between impacts it moves by its forward dynamics,
/// qdd = M(q)^-1 (tau - h(q, qdot)), under the torque model its ArticulatedBody was given
/// (setLoads(): constant torques, none included; setGravityCompensation(): tau = g(q)), with the
/// episode's gravity (setGravity() keeps the model and replaces the gravity): an embedded
/// Runge-Kutta 5(4) pair (Dormand-Prince) with step control to kRobotFlightTolerance. Locked joints
/// keep their velocity (zero acceleration); mimic joints follow their roots. Its model for impacts
/// and resting contacts is the ArticulatedBody itself.
///
/// Bounds for conservative advancement, per link at its state: V = |v_o| + |w| r (v_o the velocity
/// of the link frame's origin), A = 2 (|a_o| + (|alpha| + |w|^2) r) from the links' free
/// accelerations (a margin of 2 for their change over a step); stepLimit() keeps each step to
/// joints turning by at most kRobotStepAngle (from their velocities and accelerations now).
class RobotEpisodeBody final : public core::EpisodeBody {
 public:
  /// `robot` at its state (setState()) with its loads. Throws core::InvalidInput naming "base" for
  /// a floating base (episodes follow fixed-base robots) and "joint_models" for a singular M.
  explicit RobotEpisodeBody(ArticulatedBody robot);

  const ArticulatedBody& robot() const { return robot_; }
  /// Integration steps taken and right-hand sides evaluated so far (diagnostics).
  int integrationSteps() const { return steps_; }

  int partCount() const override { return robot_.linkCount(); }
  core::BodyState partGeometry(int part) const override;
  void partPose(int part, core::BodyState& out) const override;
  double partSpeedBound(int part, double radius) const override;
  double partAccelerationBound(int part, double radius) const override;
  /// The link's angular velocity now (its acceleration bound covers its points' velocity changes
  /// over a step within stepLimit(), with the margin of 2).
  bool partAngularVelocity(int part, Eigen::Vector3d& w) const override;
  bool movable() const override { return robot_.velocityCount() > 0; }
  /// Also starts the integrator afresh (an episode's flight does not depend on an earlier one's).
  void setGravity(const Eigen::Vector3d& gravity) override;
  void advance(double dt) override;
  core::BodyModel& model() override { return robot_; }
  void syncFromModel() override { accelerations_valid_ = false; }
  void saveState(Eigen::VectorXd& out) const override;
  void restoreState(const Eigen::VectorXd& state) override;
  double stepLimit() const override;
  double kineticEnergy() const override { return robot_.kineticEnergy(); }

 private:
  // (qdot, qdd) at (q, qdot): the robot set to that state.
  void derivative(const Eigen::VectorXd& y, Eigen::VectorXd& dy);
  // qdd at the state now (joint order), kept until the state changes.
  const Eigen::VectorXd& jointAccelerations() const;

  ArticulatedBody robot_;
  Eigen::Isometry3d base_pose_ = Eigen::Isometry3d::Identity();
  double hint_ = 0.0;  // the integrator's last step [s]
  // The flight's scratch (per request): the articulated-body algorithm's, its answer and each
  // Runge-Kutta stage's state, reused so that a right-hand side allocates nothing.
  ArticulatedBodyWorkspace workspace_;
  Eigen::VectorXd vdot_, stage_;
  mutable Eigen::VectorXd accelerations_;
  mutable bool accelerations_valid_ = false;
  int steps_ = 0;
};

}  // namespace collision_response::robot
