// An object's recorded poses from a rosbag, for calibration (issue 25; docs/calibration.md): on tf
// (tf2_msgs/TFMessage on /tf and /tf_static, a chain of transforms composed) or as
// geometry_msgs/PoseStamped on a topic of their own.
#pragma once

#include <string>

#include "collision_response/calibration/joint_track.h"
#include "collision_response/calibration/pose_track.h"

// In the ROS layer's namespace, collision_response (not collision_response::ros, which would hide
// ::ros from the generated message headers: docs/embedding.md).
namespace collision_response {

/// Where in a bag the object's poses are.
struct BagSource {
  /// The .bag file.
  std::string path;
  /// A geometry_msgs/PoseStamped topic ("/cube/pose"); empty: read tf (/tf and /tf_static).
  std::string topic;
  /// tf: the fixed frame the poses are given in, z up against gravity (required).
  /// PoseStamped: the header.frame_id every message must have; empty: any.
  std::string world_frame;
  /// tf: the object's (body) frame (required). PoseStamped: not used.
  std::string object_frame;
};

/// Reads the object's poses in time order (calibration::PoseTrack: time [s] the messages' header
/// stamps as seconds, the body origin [m] in the world frame, unit quaternions body to world).
///
/// tf: one sample per transform whose child frame is `object_frame` on /tf or /tf_static, at its
/// header stamp, in the bag's order (its receive times). The pose is tf2's lookup of world_frame <-
/// object_frame at that stamp in a tf2::BufferCore fed every transform of the bag (its cache as
/// long as the bag), so a chain (world -> table -> cube) is composed, the other links of the chain
/// static or interpolated by tf2 at the object's stamps (they must cover them: no extrapolation).
/// PoseStamped: one sample per message on `topic`, at its header stamp.
///
/// Quaternions within 1e-3 of unit norm are normalized; PoseTrack::source names the bag and the
/// topic or frames ("tosses.bag:/tf world->cube", "tosses.bag:/cube/pose").
///
/// Throws core::InvalidInput, its field naming the bag and the topic or frames, when the bag
/// cannot be opened or read, the topic is missing or is not PoseStamped, the world or object
/// frame is missing or the two are not connected by tf, a message has the wrong frame_id (when
/// world_frame is set), a sample (or a transform of the object's chain) has a non-finite value, a
/// quaternion further from unit norm, a zero stamp, or a stamp not after the previous sample's
/// (time going backwards or repeated), or there are no samples.
calibration::PoseTrack readBagPoseTrack(const BagSource& source);

/// A robot's recorded joint positions (docs/calibration.md, "Robot recordings"): the
/// sensor_msgs/JointState messages of `topic` in the bag at `path`, one sample per message at its
/// header stamp [s], in the bag's order. The first message's `name` list sets the joints and their
/// order (JointTrack::names); every later message must name the same joints (in any order), each
/// with a position [rad | m]; velocities and efforts are not read (the identification fits the
/// positions). JointTrack::source is "<bag>:<topic>".
///
/// Throws core::InvalidInput, its field naming the bag and topic, when the bag cannot be opened or
/// read, the topic is missing or is not sensor_msgs/JointState, a message has no joints, a joint
/// named twice, other joints than the first message, fewer positions than names, a non-finite
/// position (naming the joint), a zero stamp or a stamp not after the previous one, or there are
/// fewer than 2 messages.
calibration::JointTrack readBagJointTrack(const std::string& path, const std::string& topic);

}  // namespace collision_response
