#include "collision_response/ros/bag_recording.h"

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/JointState.h>
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <sstream>
#include <utility>
#include <vector>

#include "collision_response/core/errors.h"

namespace collision_response {
namespace {

/// How far a quaternion's norm may be from 1 before it is an error (closer ones are normalized).
constexpr double kUnitTolerance = 1e-3;

std::string stripSlash(const std::string& name) {
  std::size_t start = 0;
  while (start < name.size() && name[start] == '/') ++start;
  return name.substr(start);
}

std::string formatTime(const ::ros::Time& stamp) {
  std::ostringstream out;
  out.precision(15);
  out << stamp.toSec() << " s";
  return out.str();
}

/// Errors of this recording: the field is one segment naming the bag and the topic or frames.
class Errors {
 public:
  explicit Errors(std::string source) : source_(std::move(source)) {}
  core::InvalidInput operator()(const std::string& reason) const {
    return core::InvalidInput(std::vector<std::string>{source_}, reason);
  }
  const std::string& source() const { return source_; }

 private:
  std::string source_;
};

/// Reason a pose is not usable ("" if it is): non-finite values or a quaternion off unit norm.
std::string poseProblem(double x, double y, double z, double qw, double qx, double qy, double qz,
                        const char* translation, const char* rotation) {
  const double position[3] = {x, y, z};
  const char* axes[3] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(position[i])) {
      return std::string(translation) + "." + axes[i] + " is not finite";
    }
  }
  const double quaternion[4] = {qw, qx, qy, qz};
  const char* parts[4] = {"w", "x", "y", "z"};
  for (int i = 0; i < 4; ++i) {
    if (!std::isfinite(quaternion[i])) {
      return std::string(rotation) + "." + parts[i] + " is not finite";
    }
  }
  const double norm = std::sqrt(qw * qw + qx * qx + qy * qy + qz * qz);
  if (std::abs(norm - 1.0) > kUnitTolerance) {
    std::ostringstream out;
    out << rotation << " is not a unit quaternion (norm " << norm << ")";
    return out.str();
  }
  return "";
}

/// Appends a sample, checking its time against the previous one.
void append(calibration::PoseTrack& track, const ::ros::Time& stamp,
            const Eigen::Vector3d& position, const Eigen::Quaterniond& orientation,
            const std::string& what, const Errors& error) {
  if (stamp.isZero()) throw error(what + ": header.stamp is 0 (unset)");
  const double time = stamp.toSec();
  if (!track.time.empty() && !(time > track.time.back())) {
    std::ostringstream out;
    out.precision(15);
    out << what << ": time " << time << " s is not after the previous sample's "
        << track.time.back() << " s (time goes backwards or repeats)";
    throw error(out.str());
  }
  track.time.push_back(time);
  track.position.push_back(position);
  track.orientation.push_back(orientation.normalized());
}

rosbag::Bag openBag(const std::string& path, const Errors& error) {
  if (path.empty()) throw error("no bag file given");
  try {
    return rosbag::Bag(path, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    throw error(std::string("cannot open the bag: ") + e.what());
  }
}

/// "/a (type), /b (type)": the bag's topics, for messages about a missing topic.
std::string topicList(const rosbag::Bag& bag) {
  rosbag::View all(bag);
  std::map<std::string, std::string> topics;
  for (const rosbag::ConnectionInfo* connection : all.getConnections()) {
    topics[connection->topic] = connection->datatype;
  }
  std::string list;
  for (const auto& [topic, type] : topics) {
    list += (list.empty() ? "" : ", ") + topic + " (" + type + ")";
  }
  return list.empty() ? "none" : list;
}

calibration::PoseTrack readPoseStamped(const BagSource& source) {
  const std::string topic = "/" + stripSlash(source.topic);
  const Errors error(source.path + ":" + topic);
  calibration::PoseTrack track;
  track.source = error.source();
  const std::string world = stripSlash(source.world_frame);
  try {
    rosbag::Bag bag = openBag(source.path, error);
    rosbag::View view(bag, rosbag::TopicQuery(std::vector<std::string>{topic, topic.substr(1)}));
    if (view.getConnections().empty()) {
      throw error("no such topic in the bag (its topics: " + topicList(bag) + ")");
    }
    for (const rosbag::ConnectionInfo* connection : view.getConnections()) {
      if (connection->datatype != "geometry_msgs/PoseStamped") {
        throw error("the topic has type " + connection->datatype +
                    ", not geometry_msgs/PoseStamped");
      }
    }
    int index = 0;
    for (const rosbag::MessageInstance& instance : view) {
      const geometry_msgs::PoseStamped::ConstPtr message =
          instance.instantiate<geometry_msgs::PoseStamped>();
      const std::string what = "message " + std::to_string(index) + " (header.stamp " +
                               formatTime(message->header.stamp) + ")";
      if (!world.empty() && stripSlash(message->header.frame_id) != world) {
        throw error(what + ": header.frame_id is '" + message->header.frame_id + "', not '" +
                    world + "'");
      }
      const geometry_msgs::Pose& pose = message->pose;
      const std::string problem = poseProblem(
          pose.position.x, pose.position.y, pose.position.z, pose.orientation.w, pose.orientation.x,
          pose.orientation.y, pose.orientation.z, "pose.position", "pose.orientation");
      if (!problem.empty()) throw error(what + ": " + problem);
      append(track, message->header.stamp,
             Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z),
             Eigen::Quaterniond(pose.orientation.w, pose.orientation.x, pose.orientation.y,
                                pose.orientation.z),
             what, error);
      ++index;
    }
  } catch (const rosbag::BagException& e) {
    throw error(std::string("cannot read the bag: ") + e.what());
  }
  if (track.time.empty()) throw error("the topic has no messages");
  return track;
}

/// Calls f(transform, is_static, topic) for every transform on /tf and /tf_static in the bag's
/// order, frame names without leading slashes.
template <typename F>
void forEachTransform(const BagSource& source, const Errors& error, F&& f) {
  try {
    rosbag::Bag bag = openBag(source.path, error);
    const std::vector<std::string> topics{"/tf", "/tf_static", "tf", "tf_static"};
    rosbag::View view(bag, rosbag::TopicQuery(topics));
    if (view.getConnections().empty()) {
      throw error("the bag has no /tf or /tf_static (its topics: " + topicList(bag) + ")");
    }
    for (const rosbag::ConnectionInfo* connection : view.getConnections()) {
      if (connection->datatype != "tf2_msgs/TFMessage") {
        throw error("the topic " + connection->topic + " has type " + connection->datatype +
                    ", not tf2_msgs/TFMessage");
      }
    }
    for (const rosbag::MessageInstance& instance : view) {
      const tf2_msgs::TFMessage::ConstPtr message = instance.instantiate<tf2_msgs::TFMessage>();
      const bool is_static = stripSlash(instance.getTopic()) == "tf_static";
      for (geometry_msgs::TransformStamped transform : message->transforms) {
        transform.header.frame_id = stripSlash(transform.header.frame_id);
        transform.child_frame_id = stripSlash(transform.child_frame_id);
        f(transform, is_static, instance.getTopic());
      }
    }
  } catch (const rosbag::BagException& e) {
    throw error(std::string("cannot read the bag: ") + e.what());
  }
}

calibration::PoseTrack readTf(const BagSource& source) {
  const std::string world = stripSlash(source.world_frame);
  const std::string object = stripSlash(source.object_frame);
  const Errors error(source.path + ":/tf " + world + "->" + object);
  if (world.empty()) throw error("no world frame given (the fixed frame the poses are wanted in)");
  if (object.empty()) throw error("no object frame given (the tf frame of the recorded object)");

  // First pass: the tree (every parent each frame had) and the stamps' span.
  std::map<std::string, std::set<std::string>> parents;
  std::set<std::string> frames;
  double first = 0.0;
  double last = 0.0;
  bool any = false;
  forEachTransform(source, error,
                   [&](const geometry_msgs::TransformStamped& transform, bool, const std::string&) {
                     parents[transform.child_frame_id].insert(transform.header.frame_id);
                     frames.insert(transform.child_frame_id);
                     frames.insert(transform.header.frame_id);
                     const double t = transform.header.stamp.toSec();
                     first = any ? std::min(first, t) : t;
                     last = any ? std::max(last, t) : t;
                     any = true;
                   });
  auto frameList = [&frames] {
    std::string list;
    for (const std::string& frame : frames) list += (list.empty() ? "" : ", ") + frame;
    return list.empty() ? std::string("none") : list;
  };
  if (parents.count(object) == 0) {
    throw error("no transform has the child frame '" + object + "' (the frames: " + frameList() +
                ")");
  }
  if (frames.count(world) == 0) {
    throw error("no transform has the frame '" + world + "' (the frames: " + frameList() + ")");
  }
  // The path from the object to the world frame runs through their ancestors (up from each to
  // a common one): those transforms are checked and composed; a transform elsewhere in the tree
  // does not concern the object and is left out (a bad one there is no error).
  std::set<std::string> path{object, world};
  std::vector<std::string> todo{object, world};
  while (!todo.empty()) {
    const std::string frame = todo.back();
    todo.pop_back();
    for (const std::string& parent : parents[frame]) {
      if (path.insert(parent).second) todo.push_back(parent);
    }
  }

  // Second pass: the path's transforms into tf2, with a cache as long as the recording (tf2
  // drops transforms older than the newest by more than the cache time).
  tf2::BufferCore buffer(::ros::Duration(last - first + 10.0));
  std::vector<std::pair<::ros::Time, std::string>> samples;  // the object's stamps, bag order
  int index = 0;
  forEachTransform(source, error,
                   [&](const geometry_msgs::TransformStamped& transform, bool is_static,
                       const std::string& topic) {
                     const int this_index = index++;
                     if (path.count(transform.child_frame_id) == 0) return;
                     const geometry_msgs::Transform& t = transform.transform;
                     const std::string what = topic + " transform " + std::to_string(this_index) +
                                              " (" + transform.header.frame_id + "->" +
                                              transform.child_frame_id + ", header.stamp " +
                                              formatTime(transform.header.stamp) + ")";
                     const std::string problem =
                         poseProblem(t.translation.x, t.translation.y, t.translation.z,
                                     t.rotation.w, t.rotation.x, t.rotation.y, t.rotation.z,
                                     "transform.translation", "transform.rotation");
                     if (!problem.empty()) throw error(what + ": " + problem);
                     if (transform.child_frame_id == object) {
                       samples.emplace_back(transform.header.stamp, what);
                     }
                     if (!buffer.setTransform(transform, "bag", is_static)) {
                       throw error(what + ": tf2 refused the transform");
                     }
                   });

  calibration::PoseTrack track;
  track.source = error.source();
  for (const auto& [stamp, what] : samples) {
    if (stamp.isZero()) throw error(what + ": header.stamp is 0 (unset)");
    geometry_msgs::TransformStamped pose;
    try {
      pose = buffer.lookupTransform(world, object, stamp);
    } catch (const tf2::TransformException& e) {
      throw error(what + ": no transform " + world + "->" + object + " at its stamp: " + e.what());
    }
    const geometry_msgs::Transform& t = pose.transform;
    append(track, stamp, Eigen::Vector3d(t.translation.x, t.translation.y, t.translation.z),
           Eigen::Quaterniond(t.rotation.w, t.rotation.x, t.rotation.y, t.rotation.z), what, error);
  }
  return track;
}

}  // namespace

calibration::PoseTrack readBagPoseTrack(const BagSource& source) {
  return source.topic.empty() ? readTf(source) : readPoseStamped(source);
}

calibration::JointTrack readBagJointTrack(const std::string& path, const std::string& topic_name) {
  const std::string topic = "/" + stripSlash(topic_name);
  const Errors error(path + ":" + topic);
  calibration::JointTrack track;
  track.source = error.source();
  try {
    rosbag::Bag bag = openBag(path, error);
    rosbag::View view(bag, rosbag::TopicQuery(std::vector<std::string>{topic, topic.substr(1)}));
    if (view.getConnections().empty()) {
      throw error("no such topic in the bag (its topics: " + topicList(bag) + ")");
    }
    for (const rosbag::ConnectionInfo* connection : view.getConnections()) {
      if (connection->datatype != "sensor_msgs/JointState") {
        throw error("the topic has type " + connection->datatype + ", not sensor_msgs/JointState");
      }
    }
    int index = 0;
    for (const rosbag::MessageInstance& instance : view) {
      const sensor_msgs::JointState::ConstPtr message =
          instance.instantiate<sensor_msgs::JointState>();
      const std::string what = "message " + std::to_string(index) + " (header.stamp " +
                               formatTime(message->header.stamp) + ")";
      if (message->name.empty()) throw error(what + ": no joints (name is empty)");
      if (message->position.size() != message->name.size()) {
        throw error(what + ": " + std::to_string(message->position.size()) + " positions for " +
                    std::to_string(message->name.size()) + " names");
      }
      std::set<std::string> names(message->name.begin(), message->name.end());
      if (names.size() != message->name.size()) throw error(what + ": a joint is named twice");
      if (track.names.empty()) track.names = message->name;
      Eigen::VectorXd q(track.names.size());
      if (message->name.size() != track.names.size()) {
        throw error(what + ": " + std::to_string(message->name.size()) + " joints, not the " +
                    std::to_string(track.names.size()) + " of the first message");
      }
      for (std::size_t j = 0; j < track.names.size(); ++j) {
        const auto at = std::find(message->name.begin(), message->name.end(), track.names[j]);
        if (at == message->name.end()) {
          throw error(what + ": joint '" + track.names[j] + "' (of the first message) is missing");
        }
        const double value = message->position[at - message->name.begin()];
        if (!std::isfinite(value)) {
          throw error(what + ": the position of joint '" + track.names[j] + "' is not finite");
        }
        q[j] = value;
      }
      if (message->header.stamp.isZero()) throw error(what + ": header.stamp is 0 (unset)");
      const double time = message->header.stamp.toSec();
      if (!track.time.empty() && !(time > track.time.back())) {
        throw error(what +
                    ": time is not after the previous message's (time goes backwards or "
                    "repeats)");
      }
      track.time.push_back(time);
      track.position.push_back(q);
      ++index;
    }
  } catch (const rosbag::BagException& e) {
    throw error(std::string("cannot read the bag: ") + e.what());
  }
  if (track.size() < 2) throw error("the topic has fewer than 2 messages");
  return track;
}

}  // namespace collision_response
