// The robot benchmark's scene (docs/robots.md, "Cost"): the 7-DOF arm of urdf/arm7.urdf (fixed
// base, 9 joints with the gripper's) strikes a free box with its hand at one frictional contact.
// bench_robot times our prediction of it; robot_peer_dart gives DART the same state and contact.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace collision_response::bench {

struct ArmBoxScene {
  /// Joint positions [rad, m] and velocities [rad/s, m/s], in the URDF's joint order (joint1 ..
  /// joint7, left_finger_joint, right_finger_joint).
  Eigen::Matrix<double, 9, 1> q, qdot;
  /// Contact normal, unit, from the hand towards the box; the contact point is the origin of the
  /// hand's link frame (given by the arm's kinematics at q).
  Eigen::Vector3d normal;
  double restitution = 0.5;       ///< e, Newton's on u_n or Stronge's energetic
  double static_friction = 0.6;   ///< mu_s
  double dynamic_friction = 0.5;  ///< mu_d
  /// The box: 0.2 x 0.1 x 0.3 m, 1.5 kg, axes along the world's, its centre `box_offset` along the
  /// normal beyond the contact point [m], moving at `box_velocity` [m/s] without rotating.
  Eigen::Vector3d box_size{0.2, 0.1, 0.3};
  double box_mass = 1.5;
  double box_offset = 0.05;
  Eigen::Vector3d box_velocity;

  ArmBoxScene() {
    q << 0.3, -0.8, 0.2, 1.4, -0.3, 0.9, 0.1, 0.02, 0.02;
    qdot << 0.5, 0.2, -0.3, 0.4, 0.1, -0.2, 0.3, 0.0, 0.0;
    normal = Eigen::Vector3d(1, 0.3, -0.2).normalized();
    box_velocity = -2.0 * normal + Eigen::Vector3d(0.3, -0.2, 0.1);
  }

  /// The box's principal moments about its centre [kg m^2].
  Eigen::Vector3d boxInertia() const {
    const Eigen::Vector3d s2 = box_size.cwiseProduct(box_size);
    return box_mass / 12.0 * Eigen::Vector3d(s2.y() + s2.z(), s2.x() + s2.z(), s2.x() + s2.y());
  }
};

}  // namespace collision_response::bench
