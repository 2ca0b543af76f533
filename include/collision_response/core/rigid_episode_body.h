#pragma once

#include <Eigen/Core>

#include "collision_response/core/body_state.h"
#include "collision_response/core/episode_body.h"
#include "collision_response/core/rigid_body.h"

namespace collision_response::core {

/// A free rigid body (or an immovable one, moving at its prescribed velocities) as an episode body
/// (episode_body.h): one part, its pose the body's, its reference point its centre of mass; free
/// flight by advanceFreeFlight() (free_flight.h: the parabola in closed form, torque-free
/// rotation); bounds V = |v| + |w|max r (|w|max = angularSpeedBound(), over the whole flight) and A
/// = |g| (0 when immovable); its model a RigidBody with the free accelerations of its weight m g
/// plus its own force and torque (setFreeAcceleration()). Held (hold()): constant linear and
/// angular accelerations a and alpha, A = |a| + |alpha| r, stepLimit() where its slip or spin
/// stops, it has turned by kHeldTurn, or (sliding and spinning at once) v or w has changed by about
/// kHeldTurn of itself.
class RigidEpisodeBody final : public EpisodeBody {
 public:
  /// The angle [rad] a held body (hold()) turns by at most before its step limit, where the
  /// episode redoes the resting analysis: its held contact forces, constant in the world, follow
  /// its turning slip directions to first order in this angle.
  static constexpr double kHeldTurn = 0.02;
  /// The shortest step [s] the slide-and-spin limit of stepLimit() takes: near a stop the
  /// relative changes of v and w grow without bound (steps shrinking geometrically), while a step
  /// this short moves the body by at most |a| h^2 / 2 off the followed path (0.2 um at 4 m/s^2).
  static constexpr double kHeldMinimumStep = 1e-4;

  /// `state` must be valid (core::SceneValidator); its orientation is normalised.
  explicit RigidEpisodeBody(const BodyState& state);

  const BodyState& state() const { return state_; }
  /// `body` with the pose and velocities of a saveState() of a RigidEpisodeBody (13 numbers:
  /// position, orientation quaternion x y z w, linear and angular velocity).
  static BodyState stateFrom(const BodyState& body, const Eigen::VectorXd& saved);

  int partCount() const override { return 1; }
  BodyState partGeometry(int part) const override;
  void partPose(int part, BodyState& out) const override;
  double partSpeedBound(int part, double radius) const override;
  double partAccelerationBound(int part, double radius) const override;
  bool movable() const override { return !state_.immovable(); }
  void setGravity(const Eigen::Vector3d& gravity) override { gravity_ = gravity; }
  void advance(double dt) override;
  BodyModel& model() override;
  void syncFromModel() override;
  void saveState(Eigen::VectorXd& out) const override;
  void restoreState(const Eigen::VectorXd& state) override;
  bool translate(const Eigen::Vector3d& shift) override;
  double stepLimit() const override;
  bool hold(const Eigen::Vector3d& contact_force, const Eigen::Vector3d& contact_torque) override;
  void release() override { held_ = false; }
  double kineticEnergy() const override;

 private:
  BodyState state_;
  RigidBody model_;
  Eigen::Vector3d gravity_ = Eigen::Vector3d::Zero();
  bool held_ = false;                                            // hold()
  Eigen::Vector3d held_acceleration_ = Eigen::Vector3d::Zero();  // of the centre of mass [m/s^2]
  // Held: the constant angular acceleration [rad/s^2], world.
  Eigen::Vector3d held_angular_acceleration_ = Eigen::Vector3d::Zero();
};

}  // namespace collision_response::core
