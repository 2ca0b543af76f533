#include "collision_response/ros/joint_state_cache.h"

#include <algorithm>

namespace collision_response {

JointStateCache::JointStateCache(const std::vector<std::string>& joint_names)
    : samples_(joint_names.size()) {
  for (std::size_t i = 0; i < joint_names.size(); ++i)
    index_of_.emplace(joint_names[i], static_cast<int>(i));
}

void JointStateCache::update(const sensor_msgs::JointState& message, const ros::Time& arrival) {
  const ros::Time stamp = message.header.stamp.isZero() ? arrival : message.header.stamp;
  const std::lock_guard<std::mutex> lock(mutex_);
  for (std::size_t k = 0; k < message.name.size(); ++k) {
    const auto it = index_of_.find(message.name[k]);
    if (it == index_of_.end()) continue;
    Sample& sample = samples_[it->second];
    const bool position = k < message.position.size();
    const bool velocity = k < message.velocity.size();
    const bool effort = k < message.effort.size();
    if (!position && !velocity && !effort) continue;
    if (position) {
      sample.position = message.position[k];
      sample.has_position = true;
    }
    if (velocity) {
      sample.velocity = message.velocity[k];
      sample.has_velocity = true;
    }
    if (effort) {
      sample.effort = message.effort[k];
      sample.has_effort = true;
      sample.effort_stamp = stamp;
    }
    sample.stamp = stamp;
  }
}

std::vector<JointStateCache::Sample> JointStateCache::snapshot() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return samples_;
}

}  // namespace collision_response
