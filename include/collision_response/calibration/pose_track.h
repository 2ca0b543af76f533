// A recorded motion of one object, as calibration reads it (docs/calibration.md): the poses of the
// object's body frame in a world frame whose z axis points up (against gravity), in time order.
// Read from a CSV file in the cube tosses' layout or from a rosbag (tf or PoseStamped); the
// landings are found in it afterwards.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace collision_response::calibration {

struct PoseTrack {
  /// Where the samples came from, for messages: "file.csv", "file.bag:/tf table->cube", ...
  std::string source;
  std::vector<double> time;                     ///< [s], strictly increasing
  std::vector<Eigen::Vector3d> position;        ///< body origin in the world frame [m]
  std::vector<Eigen::Quaterniond> orientation;  ///< body frame to world frame, unit
  int size() const { return static_cast<int>(time.size()); }
};

}  // namespace collision_response::calibration
