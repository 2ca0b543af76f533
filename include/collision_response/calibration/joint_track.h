// A robot's recorded joint positions, as calibration reads them (docs/calibration.md, "Robot
// recordings"): named joints, their positions sampled in time order. Read from a CSV file
// (joint_csv.h) or from sensor_msgs/JointState messages in a rosbag (the ros library's
// readBagJointTrack()); the impacts are found in it afterwards (robot_impact_extraction.h).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace collision_response::calibration {

struct JointTrack {
  /// Where the samples came from, for messages: "strikes.csv", "strikes.bag:/joint_states".
  std::string source;
  std::vector<std::string> names;         ///< the recorded joints (URDF joint names), column order
  std::vector<double> time;               ///< [s], strictly increasing
  std::vector<Eigen::VectorXd> position;  ///< per sample, names' order [rad | m], finite
  int size() const { return static_cast<int>(time.size()); }
};

}  // namespace collision_response::calibration
