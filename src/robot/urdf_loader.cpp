#include "collision_response/robot/urdf_loader.h"

#include <urdf/model.h>

#include <cmath>
#include <fstream>
#include <kdl_parser/kdl_parser.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "collision_response/core/errors.h"
#include "collision_response/core/validation.h"
#include "collision_response/robot/urdf_text.h"

namespace collision_response::robot {
namespace {

// The field every error of the loader names: the URDF document.
const char* const kField = "URDF";

// The root link's inertia in the link frame (kdl_parser's conversion, which it does not apply to
// the root).
KDL::RigidBodyInertia rootInertia(const urdf::Model& model) {
  const urdf::LinkConstSharedPtr root = model.getRoot();
  if (!root || !root->inertial) return KDL::RigidBodyInertia::Zero();
  const urdf::Inertial& in = *root->inertial;
  double x, y, z, w;
  in.origin.rotation.getQuaternion(x, y, z, w);
  const KDL::Frame origin(
      KDL::Rotation::Quaternion(x, y, z, w),
      KDL::Vector(in.origin.position.x, in.origin.position.y, in.origin.position.z));
  return origin * KDL::RigidBodyInertia(
                      in.mass, KDL::Vector::Zero(),
                      KDL::RotationalInertia(in.ixx, in.iyy, in.izz, in.ixy, in.ixz, in.iyz));
}

// Refuses a number of the model that the kinematics and M(q) cannot take (not finite, or beyond the
// core's magnitude limits: they overflow there), naming the element.
void requireUsable(bool ok, const std::string& element, const std::string& what) {
  if (!ok) throw core::InvalidInput(kField, element + ": " + what);
}

void requireUsablePose(const urdf::Pose& pose, const std::string& element) {
  using Limits = core::MagnitudeLimits;
  const urdf::Vector3& p = pose.position;
  requireUsable(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z) &&
                    std::abs(p.x) <= Limits::kLength && std::abs(p.y) <= Limits::kLength &&
                    std::abs(p.z) <= Limits::kLength,
                element,
                "<origin> xyz must be finite and within " + std::to_string(Limits::kLength) + " m");
  const urdf::Rotation& r = pose.rotation;
  requireUsable(
      std::isfinite(r.x) && std::isfinite(r.y) && std::isfinite(r.z) && std::isfinite(r.w), element,
      "<origin> rpy must be finite");
}

void requireUsableModel(const urdf::Model& model) {
  using Limits = core::MagnitudeLimits;
  for (const auto& [name, link] : model.links_) {
    if (!link || !link->inertial) continue;
    const urdf::Inertial& in = *link->inertial;
    const std::string element = "link '" + name + "' <inertial>";
    requireUsablePose(in.origin, element);
    requireUsable(
        std::isfinite(in.mass) && in.mass >= 0.0 && in.mass <= Limits::kMass[1], element,
        "<mass> must be finite, >= 0 and at most " + std::to_string(Limits::kMass[1]) + " kg");
    for (const double value : {in.ixx, in.ixy, in.ixz, in.iyy, in.iyz, in.izz}) {
      requireUsable(std::isfinite(value) && std::abs(value) <= Limits::kInertia[1], element,
                    "<inertia> entries must be finite and within " +
                        std::to_string(Limits::kInertia[1]) + " kg m^2");
    }
  }
  for (const auto& [name, joint] : model.joints_) {
    if (!joint) continue;
    const std::string element = "joint '" + name + "'";
    requireUsablePose(joint->parent_to_joint_origin_transform, element);
    const urdf::Vector3& a = joint->axis;
    requireUsable(std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z), element,
                  "<axis> must be finite");
    const bool moves = joint->type == urdf::Joint::REVOLUTE ||
                       joint->type == urdf::Joint::CONTINUOUS ||
                       joint->type == urdf::Joint::PRISMATIC;
    // KDL divides the axis by its length: a zero axis would give NaN, reported later as a
    // singular inertia.
    requireUsable(!moves || a.x != 0.0 || a.y != 0.0 || a.z != 0.0, element,
                  "<axis> must not be zero");
    if (joint->mimic) {
      // A multiplier beyond 1e6 makes the mimic group's inertia overflow long before it means
      // anything mechanical; the offset is a joint position (rad or m).
      requireUsable(std::isfinite(joint->mimic->multiplier) &&
                        std::abs(joint->mimic->multiplier) <= 1e6 &&
                        std::isfinite(joint->mimic->offset) &&
                        std::abs(joint->mimic->offset) <= Limits::kLength,
                    element,
                    "<mimic> multiplier must be finite and within 1e6 in magnitude, offset "
                    "finite and within " +
                        std::to_string(Limits::kLength) + " rad or m");
    }
    // The velocity limit the answer checks (0 is "not given": exporters write it as a placeholder).
    requireUsable(!joint->limits ||
                      (std::isfinite(joint->limits->velocity) && joint->limits->velocity >= 0.0),
                  element, "<limit> velocity must be finite and >= 0");
  }
}

}  // namespace

std::shared_ptr<RobotModel> robotModelFromUrdfString(const std::string& xml, BaseType base) {
  requireUrdfText(xml);  // before TinyXML, which reads past a cut UTF-8 sequence
  urdf::Model model;
  if (!model.initString(xml)) throw core::InvalidInput(kField, "the document does not parse");
  requireUsableModel(model);
  const KDL::RigidBodyInertia root_inertia = rootInertia(model);
  // kdl_parser drops a root link's inertia with a warning that KDL cannot use it; ours is passed
  // to the body (a floating base uses it), so the root is handed to kdl_parser without one.
  if (model.root_link_) model.root_link_->inertial.reset();
  KDL::Tree tree;
  if (!kdl_parser::treeFromUrdfModel(model, tree)) {
    throw core::InvalidInput(kField,
                             "kdl_parser could not build the tree of '" + model.getName() + "'");
  }
  auto robot = std::make_shared<RobotModel>(tree, base, root_inertia);
  // <mimic>: KDL's tree has no couplings; the model takes them by joint name.
  std::vector<MimicJoint> mimics;
  for (const auto& [name, joint] : model.joints_) {
    if (!joint || !joint->mimic) continue;
    mimics.push_back(
        {name, joint->mimic->joint_name, joint->mimic->multiplier, joint->mimic->offset});
  }
  // <limit velocity>: kept for the answer's check (docs/robots.md, "Safety outputs"); 0 or no
  // <limit> (a continuous joint) leaves the joint without one (infinity).
  for (const auto& [name, joint] : model.joints_) {
    if (!joint || !joint->limits || !(joint->limits->velocity > 0.0)) continue;
    const int index = robot->findJoint(name);
    if (index >= 0) robot->setVelocityLimit(index, joint->limits->velocity);
  }
  if (!mimics.empty()) {
    try {
      robot->setMimicJoints(mimics);
    } catch (const core::InvalidInput& e) {
      throw e.withFirstSegment(kField);  // "URDF: mimic joint 'x': ..."
    }
  }
  return robot;
}

ArticulatedBody robotFromUrdfString(const std::string& xml, BaseType base) {
  return ArticulatedBody(robotModelFromUrdfString(xml, base));
}

ArticulatedBody robotFromUrdfFile(const std::string& path, BaseType base) {
  std::ifstream file(path);
  if (!file) throw core::InvalidInput(kField, "cannot read '" + path + "'");
  std::stringstream text;
  text << file.rdbuf();
  return robotFromUrdfString(text.str(), base);
}

}  // namespace collision_response::robot
