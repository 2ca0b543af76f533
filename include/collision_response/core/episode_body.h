#pragma once

#include <Eigen/Core>
#include <limits>

#include "collision_response/core/body_model.h"
#include "collision_response/core/body_state.h"

namespace collision_response::core {

/// A body as an impact episode of general bodies follows it (body_episode.h; docs/physics.md,
/// "Impact episodes", "Robots in episodes"): what it shows the geometry (its parts' poses), how it
/// moves between impacts (its own free motion under its loads), how fast its parts can close on
/// others (bounds for conservative advancement) and the BodyModel the impacts and the resting
/// analysis act on. A free rigid body (RigidEpisodeBody, rigid_episode_body.h) has one part; a
/// robot (robot/robot_episode_body.h) one part per link, its motion its forward dynamics. The
/// core never sees what is behind it.
class EpisodeBody {
 public:
  virtual ~EpisodeBody() = default;

  /// Parts the geometry may name (a robot's links, by link index; a rigid body's one part, 0).
  virtual int partCount() const = 0;
  /// Part `part` as a body of the geometry (core::GapQuery): its id, a movable stand-in (mass > 0)
  /// or, for a body whose motion is prescribed, mass 0, and its pose now. Its centre of mass
  /// (BodyState::com, body frame) is the part's reference point: the point about which the
  /// geometry measures radius() and the bounds below are taken. Only position and orientation
  /// change as the body moves.
  virtual BodyState partGeometry(int part) const = 0;
  /// Writes the pose now of part `part` (position and orientation of partGeometry()) into `out`.
  virtual void partPose(int part, BodyState& out) const = 0;
  /// A bound [m/s] on the speed now of every material point of the part within `radius` [m] of
  /// its reference point, and one [m/s^2] on how fast that bound can grow during free motion:
  /// over a span s of free motion the part's points then travel at most V s + A s^2 / 2
  /// (conservative advancement). Exact for a rigid body's torque-free flight (A = |g|, the spin
  /// bounded over the whole flight); for a robot from its state and free acceleration now, with a
  /// margin (robot_episode_body.h).
  virtual double partSpeedBound(int part, double radius) const = 0;
  virtual double partAccelerationBound(int part, double radius) const = 0;
  /// The part's angular velocity now [rad/s], world, into `w`, if partAccelerationBound() also
  /// bounds how fast each of its points' velocity changes over the step (a robot's link): an
  /// episode then takes the points' turning along a direction from the angular velocity now and
  /// the part's shape. False (the default; a rigid body, whose speed bound covers its spin over
  /// the whole flight instead): the turning share of partSpeedBound() is used.
  virtual bool partAngularVelocity(int /*part*/, Eigen::Vector3d& /*w*/) const { return false; }
  /// Whether the body moves on its own (false: immovable, its velocity prescribed and constant).
  virtual bool movable() const = 0;
  /// Gravity [m/s^2], world, under which the body moves and rests (set once, before the start).
  virtual void setGravity(const Eigen::Vector3d& gravity) = 0;
  /// Advances the body's own free motion (no contact) by dt [s] >= 0, in place.
  virtual void advance(double dt) = 0;
  /// The body at its state now as a body of the contact problem, its free accelerations under its
  /// loads (gravity included) ready for the resting analysis. The episode applies impulses to it;
  /// then syncFromModel().
  virtual BodyModel& model() = 0;
  /// Takes the velocities the impact left in model() into the body's own state.
  virtual void syncFromModel() = 0;
  /// The whole state (positions and velocities) as numbers, and back: a step taken too long is
  /// undone with them.
  virtual void saveState(Eigen::VectorXd& out) const = 0;
  virtual void restoreState(const Eigen::VectorXd& state) = 0;
  /// The longest step [s] over which the bounds above hold (a robot's: while its joints turn by
  /// a small angle; infinity for a rigid body, whose bounds hold over the whole flight).
  virtual double stepLimit() const { return std::numeric_limits<double>::infinity(); }
  /// Moves the body rigidly by `shift` [m], world, if it can (a rigid body; false: a robot, which
  /// is not moved): how a plastic touch's depth is taken back out of a resting contact.
  virtual bool translate(const Eigen::Vector3d& /*shift*/) { return false; }
  /// Sustained contact while other bodies fly (body_episode.h): from now until release(), the body
  /// moves as if the wrench of `contact_force` [N], world (the resting analysis' total contact
  /// force on it) and `contact_torque` [N m], world, about the world origin (the moment of those
  /// forces about the origin, sum p x F) acted on it besides its own loads, both constant: a rigid
  /// body's centre of mass at the constant acceleration g + (F_own + contact_force) / m, its
  /// angular velocity at the constant angular acceleration alpha = I^-1 (tau_own + tau_contact - w
  /// x I w) taken now (tau_contact the contact torque about its centre of mass), its orientation
  /// turned accordingly; its acceleration bound those accelerations' share (|a| + |alpha| r), and
  /// stepLimit() the time its velocity's or its angular velocity's component against its
  /// acceleration takes to run out, whichever comes first (infinity if the accelerations speed it
  /// up), where the episode redoes the resting analysis. False if the body cannot be held so (a
  /// robot): it then keeps its own motion, its touches solved plastic.
  virtual bool hold(const Eigen::Vector3d& /*contact_force*/,
                    const Eigen::Vector3d& /*contact_torque*/) {
    return false;
  }
  virtual void release() {}
  /// Kinetic energy [J] (diagnostics and tests).
  virtual double kineticEnergy() const = 0;
};

}  // namespace collision_response::core
