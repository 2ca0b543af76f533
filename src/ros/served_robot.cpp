#include "collision_response/ros/served_robot.h"

#include <map>
#include <memory>
#include <stdexcept>

#include "collision_response/core/errors.h"
#include "collision_response/robot/urdf_loader.h"
#include "collision_response/ros/robot_geometry.h"

namespace collision_response {
namespace {

// The robot's model as the entry configures it once: the URDF's tree and mimics, the entry's base
// type and armatures. The entry's locked joints are not in it: they are the served prototype's
// data (ServedRobot::model()), so that a request may replace them without another model.
std::shared_ptr<const robot::RobotModel> buildModel(const RobotParameters& parameters,
                                                    const std::string& urdf,
                                                    const std::string& field) {
  std::shared_ptr<robot::RobotModel> model;
  try {
    model = robot::robotModelFromUrdfString(
        urdf, parameters.floating ? robot::BaseType::kFloating : robot::BaseType::kFixed);
  } catch (const core::InvalidInput& e) {
    // The library names the document ("URDF"); here it is the entry's parameter.
    throw core::InvalidInput(
        field + ".description_param",
        "the URDF in '" + parameters.description_param + "' is not a usable robot: " + e.what());
  }
  for (const auto& [name, armature] : parameters.armature) {
    const int joint = model->findJoint(name);
    if (joint < 0) {
      throw core::InvalidInput(
          field + ".armature." + name,
          "the robot '" + parameters.name + "' has no joint '" + name + "' with a coordinate");
    }
    if (armature > 0.0) model->setJointModel(joint, robot::JointModel::kArmature, armature);
  }
  return model;
}

}  // namespace

ServedRobot::ServedRobot(const RobotParameters& parameters, const std::string& urdf,
                         const std::string& field)
    : parameters_(parameters),
      model_(buildModel(parameters, urdf, field)),
      joint_states_(model_.jointNames()) {
  base_frame_ = parameters.base_frame.empty() ? model_.linkName(0) : parameters.base_frame;
  model_.setLockedJoints(lockedFlags(parameters.locked_joints, field + ".locked_joints"));
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

std::vector<bool> ServedRobot::lockedFlags(const std::vector<std::string>& locked,
                                           const std::string& field) const {
  std::vector<bool> is_locked(model_.jointCount(), false);
  for (std::size_t k = 0; k < locked.size(); ++k) {
    is_locked[jointIndex(locked[k], field + "[" + std::to_string(k) + "]")] = true;
  }
  return is_locked;
}

int ServedRobot::jointIndex(const std::string& name, const std::string& field) const {
  const int joint = model_.model().findJoint(name);
  if (joint < 0) {
    throw core::InvalidInput(field, "the robot '" + parameters_.name + "' has no joint '" + name +
                                        "' with a coordinate");
  }
  return joint;
}

robot::ArticulatedBody ServedRobot::modelWithLockedJoints(const std::vector<std::string>& locked,
                                                          const std::string& field) const {
  robot::ArticulatedBody model = model_;  // the data alone: the model is shared
  model.setLockedJoints(lockedFlags(locked, field));
  return model;
}

}  // namespace collision_response
