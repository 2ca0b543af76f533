#pragma once

#include <Eigen/Core>
#include <kdl/frames.hpp>
#include <string>
#include <vector>

#include "collision_response/robot/robot_model.h"

namespace collision_response::robot {

/// Mass properties of a rigid body in the world frame, about the world origin: mass m [kg], first
/// moment h = m c [kg m] (c its centre of mass), rotational inertia I_o about the origin [kg m^2].
/// Such inertias of bodies add (composite bodies).
struct SpatialInertia {
  double mass = 0.0;
  Eigen::Vector3d first_moment = Eigen::Vector3d::Zero();
  Eigen::Matrix3d rotational = Eigen::Matrix3d::Zero();
  SpatialInertia& operator+=(const SpatialInertia& other) {
    mass += other.mass;
    first_moment += other.first_moment;
    rotational += other.rotational;
    return *this;
  }
};

/// A link's spatial acceleration, world, at the world origin: angular [rad/s^2] and the derivative
/// of the velocity field at the origin [m/s^2] (the time derivative of a twist).
struct SpatialAcceleration {
  Eigen::Vector3d angular = Eigen::Vector3d::Zero();
  Eigen::Vector3d linear = Eigen::Vector3d::Zero();
};

/// One request's robot (Pinocchio's data; docs/robots.md, "Model and data"): everything that
/// changes with the state, for one RobotModel (sized by RobotData(model)). Copying it copies only
/// these values; the model is shared. Written by the functions of robot/algorithms.h; world frame,
/// twists and inertias at the world origin (KDL's Twist: vel = velocity of the material point at
/// the origin, rot = angular velocity).
struct RobotData {
  explicit RobotData(const RobotModel& model);

  // --- State
  Eigen::VectorXd q;     ///< joint positions [rad | m], joint order (followers derived)
  Eigen::VectorXd qdot;  ///< joint velocities [rad/s | m/s]
  KDL::Frame base_pose = KDL::Frame::Identity();                    ///< base frame in the world
  Eigen::Vector3d base_linear_velocity = Eigen::Vector3d::Zero();   ///< of the base origin [m/s]
  Eigen::Vector3d base_angular_velocity = Eigen::Vector3d::Zero();  ///< [rad/s], world

  // --- This request's locks and the velocity unknowns they leave
  /// Joints this request locks on top of the model's kLocked ones (jointCount() entries).
  std::vector<bool> locked;
  std::vector<int> unknown_of_joint;  ///< -1 for a locked joint; a follower shares its root's
  std::vector<int> joint_of_unknown;  ///< -1 for the base twist's six
  int unknowns = 0;

  // --- Kinematics (per link, link order)
  std::vector<KDL::Frame> frames;  ///< world frame of each link (segment tip)
  std::vector<KDL::Twist> axes;    ///< motion of a unit velocity of the link's joint (0 if fixed)
  std::vector<KDL::Twist> twists;  ///< link twists
  KDL::Twist base_axes[6];         ///< the base's unknowns: (e_k, 0) and (o x e_k, e_k)

  // --- Mass matrix
  std::vector<SpatialInertia> composite;  ///< each link's subtree (M(q) only)
  /// Each link's own inertia in the world (worldInertia() at `frames`), kept by computeMassMatrix()
  /// for the inverse dynamics at the same frames; valid until forwardKinematics() moves them.
  std::vector<SpatialInertia> link_inertias;
  bool link_inertias_valid = false;
  Eigen::MatrixXd mass_matrix;  ///< M(q), unknowns square, armature included
  Eigen::MatrixXd cholesky;     ///< M = L L^T, L in the lower triangle
  std::string singular;         ///< why M is singular, empty if it is not

  // --- Loads (resting contacts)
  Eigen::VectorXd torques;                            ///< the actuators' tau [N m | N], joint order
  bool gravity_compensation = false;                  ///< tau = g(q) instead
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();  ///< g [m/s^2], world
  /// The links' accelerations under the loads alone, computed on the first query after a change
  /// of state or loads (a cache: updateFreeAccelerations() fills it on a const data).
  mutable std::vector<SpatialAcceleration> free_accelerations;
  mutable bool free_accelerations_valid = false;
};

}  // namespace collision_response::robot
