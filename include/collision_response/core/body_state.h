#pragma once

#include <Eigen/Geometry>
#include <string>

namespace collision_response::core {

/// State of one rigid body, as given to and returned by computeResponse(). All vectors are in one
/// common frame, the "world" of the request (for the ROS node: the request's header.frame_id).
struct BodyState {
  std::string id;                                 ///< unique within a scene
  double mass = 0.0;                              ///< [kg]; 0 means immovable (infinite mass)
  Eigen::Vector3d com = Eigen::Vector3d::Zero();  ///< centre of mass in the body frame [m]
  Eigen::Matrix3d inertia =
      Eigen::Matrix3d::Zero();  ///< about the centre of mass, body axes [kg m^2]
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< origin of the body frame, world [m]
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  ///< body frame in world (unit)
  Eigen::Vector3d linear_velocity =
      Eigen::Vector3d::Zero();  ///< of the centre of mass, world [m/s]
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  ///< world [rad/s]
  /// External wrench for the resting-contact analysis (gravity, a push): force through the centre
  /// of mass [N] and torque [N m], world. Impacts ignore it (impulsive forces dominate).
  Eigen::Vector3d force = Eigen::Vector3d::Zero();
  Eigen::Vector3d torque = Eigen::Vector3d::Zero();

  bool immovable() const { return mass == 0.0; }
  /// Centre of mass in world coordinates [m].
  Eigen::Vector3d worldCom() const { return position + orientation.normalized() * com; }
};

/// Kinetic energy [J] of a movable body; 0 for an immovable one (whose mass is infinite, so its
/// kinetic energy is left out of every total).
double kineticEnergy(const BodyState& body);

/// The same state expressed in another frame: new_T_old maps coordinates of the frame the body is
/// given in (old) to the new one (pose composed, velocities and wrench rotated). Velocities are
/// rotated only: the frames must not move relative to each other.
BodyState transformed(const BodyState& body, const Eigen::Isometry3d& new_T_old);

}  // namespace collision_response::core
