#include "collision_response/ros/served_robot.h"

#include <map>
#include <stdexcept>

#include "collision_response/core/errors.h"
#include "collision_response/robot/urdf_loader.h"
#include "collision_response/ros/robot_geometry.h"

namespace collision_response {
namespace {

robot::ArticulatedBody parse(const RobotParameters& parameters, const std::string& urdf,
                             const std::string& field) {
  try {
    return robot::robotFromUrdfString(
        urdf, parameters.floating ? robot::BaseType::kFloating : robot::BaseType::kFixed);
  } catch (const std::invalid_argument& e) {
    throw core::InvalidInput(
        field + ".description_param",
        "the URDF in '" + parameters.description_param + "' is not a usable robot: " + e.what());
  }
}

}  // namespace

ServedRobot::ServedRobot(const RobotParameters& parameters, const std::string& urdf,
                         const std::string& field)
    : parameters_(parameters),
      model_(parse(parameters, urdf, field)),
      joint_states_(model_.jointNames()) {
  base_frame_ = parameters.base_frame.empty() ? model_.linkName(0) : parameters.base_frame;
  for (const auto& entry : parameters.armature)
    jointIndex(entry.first, field + ".armature." + entry.first);
  setJointModels(model_, parameters.locked_joints, field + ".locked_joints");
  if (!model_.singularJoint().empty()) throw core::InvalidInput(field, model_.singularJoint());
  std::map<std::string, detection::BodyGeometry> geometry;
  try {
    geometry = linkCollisionGeometryFromUrdf(urdf);
  } catch (const std::invalid_argument& e) {
    throw core::InvalidInput(field + ".description_param",
                             "the collision geometry of the URDF in '" +
                                 parameters.description_param + "' cannot be read: " + e.what());
  }
  link_ids_.reserve(model_.linkCount());
  link_geometry_.resize(model_.linkCount());
  for (int link = 0; link < model_.linkCount(); ++link) {
    link_ids_.push_back(parameters.name + "/" + model_.linkName(link));
    const auto it = geometry.find(model_.linkName(link));
    if (it != geometry.end()) link_geometry_[link] = std::move(it->second);
    has_geometry_ |= !link_geometry_[link].shapes.empty();
  }
}

void ServedRobot::setJointModels(robot::ArticulatedBody& model,
                                 const std::vector<std::string>& locked,
                                 const std::string& field) const {
  std::vector<bool> is_locked(model.jointCount(), false);
  for (std::size_t k = 0; k < locked.size(); ++k) {
    is_locked[jointIndex(locked[k], field + "[" + std::to_string(k) + "]")] = true;
  }
  for (int joint = 0; joint < model.jointCount(); ++joint) {
    robot::JointModel wanted = robot::JointModel::kFree;
    double armature = 0.0;
    if (is_locked[joint]) {
      wanted = robot::JointModel::kLocked;
    } else if (const auto it = parameters_.armature.find(model.jointNames()[joint]);
               it != parameters_.armature.end() && it->second > 0.0) {
      wanted = robot::JointModel::kArmature;
      armature = it->second;
    }
    if (model.jointModel(joint) != wanted) model.setJointModel(joint, wanted, armature);
  }
}

int ServedRobot::jointIndex(const std::string& name, const std::string& field) const {
  try {
    return model_.jointIndex(name);
  } catch (const std::invalid_argument&) {
    throw core::InvalidInput(field, "the robot '" + parameters_.name + "' has no joint '" + name +
                                        "' with a coordinate");
  }
}

robot::ArticulatedBody ServedRobot::modelWithLockedJoints(const std::vector<std::string>& locked,
                                                          const std::string& field) const {
  robot::ArticulatedBody model = model_;
  setJointModels(model, locked, field);
  return model;
}

}  // namespace collision_response
