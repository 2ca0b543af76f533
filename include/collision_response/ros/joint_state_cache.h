#pragma once

#include <ros/time.h>
#include <sensor_msgs/JointState.h>

#include <mutex>
#include <string>
#include <unordered_map>
#include <vector>

namespace collision_response {

/// The latest position, velocity and effort of each joint of one robot, as they arrive on its
/// joint-state topic (docs/robots.md, "Robots through ROS"). Kept per joint, so that several
/// publishers of parts of the robot (an arm and its gripper) on one topic combine; joints of other
/// robots on the same topic are ignored. Thread-safe: the subscriber writes while requests read.
class JointStateCache {
 public:
  /// One joint's latest values; `stamp` is the message's header.stamp, or its arrival time if the
  /// message was not stamped. has_position / has_velocity / has_effort: a message gave the value.
  struct Sample {
    double position = 0.0;  ///< [rad | m]
    double velocity = 0.0;  ///< [rad/s | m/s]
    double effort = 0.0;    ///< [N m | N]
    bool has_position = false;
    bool has_velocity = false;
    bool has_effort = false;
    ros::Time stamp;
    ros::Time effort_stamp;  ///< the stamp of the message that gave `effort` (publishers differ)
  };

  /// The joints to keep, in the model's order (ArticulatedBody::jointNames()).
  explicit JointStateCache(const std::vector<std::string>& joint_names);

  /// Takes the values of the known joints in `message` (arrays shorter than name are read as far
  /// as they go; a message with mismatched arrays is otherwise used as it is, as robot drivers
  /// often publish positions only). `arrival`: when it was received.
  void update(const sensor_msgs::JointState& message, const ros::Time& arrival);

  /// A copy of every joint's latest values, in the model's order.
  std::vector<Sample> snapshot() const;

 private:
  std::unordered_map<std::string, int> index_of_;
  mutable std::mutex mutex_;
  std::vector<Sample> samples_;
};

}  // namespace collision_response
