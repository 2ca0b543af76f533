// The state of a recorded rigid object at one moment, as the calibration fits and predicts it.
#pragma once

#include <Eigen/Geometry>

namespace collision_response::calibration {

/// World frame: z up (against gravity); after extraction the floor is the plane z = 0.
struct MotionState {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< body origin (centre of mass) [m]
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  ///< body frame to world
  Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero();        ///< of the origin [m/s]
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();       ///< world [rad/s]
};

}  // namespace collision_response::calibration
