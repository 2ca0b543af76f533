#include "collision_response/robot/link_bodies.h"

#include <utility>

namespace collision_response::robot {

core::BodyState linkBody(const ArticulatedBody& robot, int link, std::string id) {
  core::BodyState body;
  body.id = std::move(id);
  body.mass = 1.0;
  body.inertia = Eigen::Matrix3d::Identity();
  const Eigen::Isometry3d pose = robot.linkPose(link);
  body.position = pose.translation();
  body.orientation = Eigen::Quaterniond(pose.linear());
  return body;
}

}  // namespace collision_response::robot
