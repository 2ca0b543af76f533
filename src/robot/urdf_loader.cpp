#include "collision_response/robot/urdf_loader.h"

#include <urdf/model.h>
#include <fstream>
#include <kdl_parser/kdl_parser.hpp>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace collision_response::robot {
namespace {

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

}  // namespace

ArticulatedBody robotFromUrdfString(const std::string& xml, BaseType base) {
  urdf::Model model;
  if (!model.initString(xml)) throw std::invalid_argument("URDF: the document does not parse");
  const KDL::RigidBodyInertia root_inertia = rootInertia(model);
  // kdl_parser drops a root link's inertia with a warning that KDL cannot use it; ours is passed
  // to the body (a floating base uses it), so the root is handed to kdl_parser without one.
  if (model.root_link_) model.root_link_->inertial.reset();
  KDL::Tree tree;
  if (!kdl_parser::treeFromUrdfModel(model, tree)) {
    throw std::invalid_argument("URDF: kdl_parser could not build the tree of '" + model.getName() +
                                "'");
  }
  ArticulatedBody body(tree, base, root_inertia);
  // <mimic>: KDL's tree has no couplings; the body takes them by joint name.
  std::vector<MimicJoint> mimics;
  for (const auto& [name, joint] : model.joints_) {
    if (!joint || !joint->mimic) continue;
    mimics.push_back(
        {name, joint->mimic->joint_name, joint->mimic->multiplier, joint->mimic->offset});
  }
  if (!mimics.empty()) {
    try {
      body.setMimicJoints(mimics);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string("URDF: ") + e.what());
    }
  }
  return body;
}

ArticulatedBody robotFromUrdfFile(const std::string& path, BaseType base) {
  std::ifstream file(path);
  if (!file) throw std::invalid_argument("URDF: cannot read '" + path + "'");
  std::stringstream text;
  text << file.rdbuf();
  return robotFromUrdfString(text.str(), base);
}

}  // namespace collision_response::robot
