#pragma once

#include <memory>
#include <string>
#include <vector>

#include "collision_response/detection/shapes.h"
#include "collision_response/robot/articulated_body.h"
#include "collision_response/ros/joint_state_cache.h"
#include "collision_response/ros/server_parameters.h"

namespace collision_response {

/// A robot the node serves (one ~robots entry, docs/robots.md, "Robots through ROS"): its model
/// built once from the URDF with the entry's base type and armatures (robot::RobotModel, const and
/// shared), a prototype body of it whose data locks the entry's locked joints, and the latest
/// joint state of its topic. A request copies the prototype, which copies only its data (the
/// model is shared by every request and thread), locks its own joints in that data if it says so,
/// and sets its state there: concurrent requests share the const model and the joint-state cache.
class ServedRobot {
 public:
  /// Builds the model from the URDF document `urdf` (the string of parameters.description_param).
  /// Throws core::InvalidInput naming `field` (the entry, "~robots[i]"): ".description_param" for
  /// a document that does not parse or whose collision geometry cannot be read (a mesh that does
  /// not load), ".locked_joints[k]" / ".armature.<joint>" for a joint the
  /// model does not have, and the entry itself for a joint-space inertia that is singular with
  /// the listed joints locked (naming the joint that moves no mass: lock it or give its links
  /// mass).
  ServedRobot(const RobotParameters& parameters, const std::string& urdf, const std::string& field);

  const RobotParameters& parameters() const { return parameters_; }
  const std::string& name() const { return parameters_.name; }
  /// The prototype: the shared model at q = 0 with the entry's locked joints (in its data).
  const robot::ArticulatedBody& model() const { return model_; }
  /// The one model every request of this robot shares.
  const std::shared_ptr<const robot::RobotModel>& sharedModel() const {
    return model_.sharedModel();
  }
  /// The tf frame that places the root link when a request gives no base pose.
  const std::string& baseFrame() const { return base_frame_; }
  /// Link names prefixed with the robot's name, "<name>/<link>", by link index: the body ids
  /// contacts use.
  const std::vector<std::string>& linkIds() const { return link_ids_; }
  /// Each link's URDF collision geometry in the link's frame (robot_geometry.h), by link index;
  /// empty for a link without <collision>.
  const std::vector<detection::BodyGeometry>& linkGeometry() const { return link_geometry_; }
  /// Whether any link has collision geometry.
  bool hasGeometry() const { return has_geometry_; }

  /// A copy of the prototype whose locked joints are `locked` (names; the entry's armatures on the
  /// others), the locks held in its data: the model is not copied (the copy's sharedModel() is
  /// this robot's). Throws core::InvalidInput naming `field` + "[k]" for an unknown joint name.
  robot::ArticulatedBody modelWithLockedJoints(const std::vector<std::string>& locked,
                                               const std::string& field) const;

  /// The model's index of the joint `name` (one with a coordinate); throws core::InvalidInput
  /// naming `field` if the robot has none.
  int jointIndex(const std::string& name, const std::string& field) const;

  JointStateCache& jointStates() { return joint_states_; }
  const JointStateCache& jointStates() const { return joint_states_; }

 private:
  /// One flag per joint, true for the joints named in `locked` (field + "[k]" if unknown).
  std::vector<bool> lockedFlags(const std::vector<std::string>& locked,
                                const std::string& field) const;

  RobotParameters parameters_;
  robot::ArticulatedBody model_;
  std::string base_frame_;
  std::vector<std::string> link_ids_;
  std::vector<detection::BodyGeometry> link_geometry_;
  bool has_geometry_ = false;
  JointStateCache joint_states_;
};

}  // namespace collision_response
