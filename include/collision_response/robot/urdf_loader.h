#pragma once

#include <memory>
#include <string>

#include "collision_response/robot/articulated_body.h"
#include "collision_response/robot/robot_model.h"

namespace collision_response::robot {

/// A robot from a URDF document (plain URDF, no xacro): urdf::Model and
/// kdl_parser::treeFromUrdfModel give the KDL tree; the root link is the base and its <inertial>
/// (which KDL's tree drops) becomes the base inertia for a floating base. Joint limits are not
/// used. <mimic> joints become the model's mimic joints (RobotModel::setMimicJoints()).
/// Throws core::InvalidInput naming the field "URDF" (its text "URDF: ..." as before) for a
/// text that is not UTF-8 or holds a NUL (requireUrdfText(): the byte and its line), for a
/// document that does not parse;
/// naming the joint for a <mimic> the body refuses ("URDF: mimic joint 'x': ...": a leader that is
/// not a joint with a coordinate, a cycle of mimics); and naming the link or joint for a number
/// the model cannot take: a link's <inertial> origin, mass or inertia, a joint's <origin> or
/// <axis> (not finite or beyond the core's MagnitudeLimits: 1e7 m, 1e15 kg, 1e30 kg m^2; a moving
/// joint's axis zero), or its <mimic> multiplier (not finite or beyond 1e6 in magnitude) or offset
/// (not finite or beyond 1e7 rad or m).
ArticulatedBody robotFromUrdfString(const std::string& xml, BaseType base = BaseType::kFixed);
/// The model alone, still open to building (RobotModel::setJointModel(), ...) before it is shared
/// as std::shared_ptr<const RobotModel>; the same errors.
std::shared_ptr<RobotModel> robotModelFromUrdfString(const std::string& xml,
                                                     BaseType base = BaseType::kFixed);
/// The same from a file; throws core::InvalidInput ("URDF") naming the file if it cannot be read.
ArticulatedBody robotFromUrdfFile(const std::string& path, BaseType base = BaseType::kFixed);

}  // namespace collision_response::robot
