#include "collision_response/robot/robot_model.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "collision_response/core/errors.h"

namespace collision_response::robot {

LocalInertia localInertia(const KDL::RigidBodyInertia& inertia) {
  // KDL keeps the rotational inertia about the frame's origin; ours is about the centre of mass.
  LocalInertia out;
  out.mass = inertia.getMass();
  const KDL::Vector c = inertia.getCOG();
  out.com = Eigen::Vector3d(c.x(), c.y(), c.z());
  const Eigen::Matrix3d about_origin =
      Eigen::Map<const Eigen::Matrix3d>(inertia.getRotationalInertia().data);
  out.about_com = about_origin - out.mass * (out.com.squaredNorm() * Eigen::Matrix3d::Identity() -
                                             out.com * out.com.transpose());
  return out;
}

KDL::Frame jointPose(const KDL::Joint& joint, double q) {
  switch (joint.getType()) {
    case KDL::Joint::RotAxis:
      return KDL::Frame(KDL::Rotation::Rot2(joint.JointAxis(), q), joint.JointOrigin());
    case KDL::Joint::RotX:
      return KDL::Frame(KDL::Rotation::RotX(q));
    case KDL::Joint::RotY:
      return KDL::Frame(KDL::Rotation::RotY(q));
    case KDL::Joint::RotZ:
      return KDL::Frame(KDL::Rotation::RotZ(q));
    case KDL::Joint::TransAxis:
      return KDL::Frame(joint.JointOrigin() + joint.JointAxis() * q);
    case KDL::Joint::TransX:
      return KDL::Frame(KDL::Vector(q, 0.0, 0.0));
    case KDL::Joint::TransY:
      return KDL::Frame(KDL::Vector(0.0, q, 0.0));
    case KDL::Joint::TransZ:
      return KDL::Frame(KDL::Vector(0.0, 0.0, q));
    default:
      return KDL::Frame::Identity();
  }
}

namespace {

// The frame past the joint (KDL's f_tip), and a check that jointPose() gives KDL's segment pose:
// a joint with a scale or offset would not.
KDL::Frame tipOf(const std::string& name, const KDL::Segment& segment) {
  const KDL::Joint& joint = segment.getJoint();
  const KDL::Frame tip = jointPose(joint, 0.0).Inverse() * segment.pose(0.0);
  for (const double q : {0.7, -1.3}) {
    if (!KDL::Equal(segment.pose(q), jointPose(joint, q) * tip, 1e-9)) {
      throw core::InvalidInput("tree", "joint of '" + name +
                                           "': a KDL joint with a scale or offset (other than 1 "
                                           "and 0) is not supported");
    }
  }
  return tip;
}

}  // namespace

RobotModel::RobotModel(const KDL::Tree& tree, BaseType base,
                       const KDL::RigidBodyInertia& base_inertia)
    : base_type_(base) {
  const auto root = tree.getRootSegment();
  if (root == tree.getSegments().end()) throw core::InvalidInput("tree", "an empty kinematic tree");
  LinkModel base_link;
  base_link.name = root->first;
  base_link.segment = KDL::Segment(root->first, KDL::Joint(KDL::Joint::Fixed),
                                   KDL::Frame::Identity(), base_inertia);
  base_link.local = localInertia(base_inertia);
  links_.push_back(std::move(base_link));
  // Depth-first, parents before children (children in the tree's order).
  std::vector<std::pair<KDL::SegmentMap::const_iterator, int>> stack;
  for (auto it = root->second.children.rbegin(); it != root->second.children.rend(); ++it) {
    stack.emplace_back(*it, 0);
  }
  std::vector<std::pair<unsigned, int>> joints;  // (q_nr, link)
  while (!stack.empty()) {
    const auto [element, parent] = stack.back();
    stack.pop_back();
    LinkModel link;
    link.name = element->first;
    link.parent = parent;
    link.segment = element->second.segment;
    link.tip = tipOf(link.name, link.segment);
    link.local = localInertia(link.segment.getInertia());
    const int index = static_cast<int>(links_.size());
    if (link.segment.getJoint().getType() != KDL::Joint::Fixed) {
      joints.emplace_back(element->second.q_nr, index);
    }
    links_.push_back(std::move(link));
    const auto& children = element->second.children;
    for (auto it = children.rbegin(); it != children.rend(); ++it) stack.emplace_back(*it, index);
  }
  std::sort(joints.begin(), joints.end());
  for (const auto& [q_nr, link] : joints) {
    links_[link].joint = static_cast<int>(joint_names_.size());
    joint_names_.push_back(links_[link].segment.getJoint().getName());
    link_of_joint_.push_back(link);
  }
  joint_models_.assign(joint_names_.size(), JointModel::kFree);
  armatures_.assign(joint_names_.size(), 0.0);
  velocity_limits_.assign(joint_names_.size(), std::numeric_limits<double>::infinity());
  mimic_root_.resize(joint_names_.size());
  for (int j = 0; j < jointCount(); ++j) mimic_root_[j] = j;
  mimic_multiplier_.assign(joint_names_.size(), 1.0);
  mimic_offset_.assign(joint_names_.size(), 0.0);
  default_link_ = linkCount() - 1;
  if (base_type_ == BaseType::kFloating) {
    double mass = base_inertia.getMass();
    for (const LinkModel& link : links_) mass += link.segment.getInertia().getMass();
    if (!(mass > 0.0)) throw core::InvalidInput("base", "a floating base robot without mass");
  }
}

int RobotModel::findJoint(const std::string& name) const {
  const auto it = std::find(joint_names_.begin(), joint_names_.end(), name);
  return it == joint_names_.end() ? -1 : static_cast<int>(it - joint_names_.begin());
}

int RobotModel::jointIndex(const std::string& name) const {
  const int joint = findJoint(name);
  if (joint < 0) throw core::InvalidInput("joint", "no joint '" + name + "'");
  return joint;
}

int RobotModel::linkIndex(const std::string& name) const {
  for (int i = 0; i < linkCount(); ++i) {
    if (links_[i].name == name) return i;
  }
  throw core::InvalidInput("link", "no link '" + name + "'");
}

void RobotModel::refuseLink(int link) const {
  throw core::InvalidInput("link", "no link " + std::to_string(link) + " (the robot has " +
                                       std::to_string(linkCount()) + ")");
}

void RobotModel::setDefaultLink(int link) {
  default_link_ = checkLink(link);
}

void RobotModel::setJointModel(int joint, JointModel model, double armature) {
  if (joint < 0 || joint >= jointCount()) {
    throw core::InvalidInput("joint", "no joint " + std::to_string(joint));
  }
  if (!(armature >= 0.0)) throw core::InvalidInput("armature", "a negative armature");
  joint_models_[joint] = model;
  armatures_[joint] = model == JointModel::kArmature ? armature : 0.0;
}

void RobotModel::setVelocityLimit(int joint, double limit) {
  if (joint < 0 || joint >= jointCount()) {
    throw core::InvalidInput("joint", "no joint " + std::to_string(joint));
  }
  if (!(limit > 0.0)) {
    throw core::InvalidInput(
        "velocity_limit", "joint '" + joint_names_[joint] + "': a velocity limit that is not > 0");
  }
  velocity_limits_[joint] = limit;
}

void RobotModel::setMimicJoints(const std::vector<MimicJoint>& mimics) {
  // Each joint's direct leader (-1: none), then every chain followed to its root.
  const int n = jointCount();
  const auto refuse = [](const std::string& reason) {
    throw core::InvalidInput("mimic_joints", reason);
  };
  std::vector<int> leader(n, -1);
  std::vector<double> multiplier(n, 1.0), offset(n, 0.0);
  for (const MimicJoint& mimic : mimics) {
    const std::string what = "mimic joint '" + mimic.joint + "'";
    const int joint = findJoint(mimic.joint);
    if (joint < 0) refuse(what + ": the robot has no such joint with a coordinate");
    const int lead = findJoint(mimic.leader);
    if (lead < 0) {
      refuse(what + ": its leader '" + mimic.leader +
             "' is not a joint of the robot with a coordinate");
    }
    if (leader[joint] >= 0) refuse(what + ": given two leaders");
    if (!std::isfinite(mimic.multiplier) || !std::isfinite(mimic.offset)) {
      refuse(what + ": its multiplier or offset is not finite");
    }
    leader[joint] = lead;
    multiplier[joint] = mimic.multiplier;
    offset[joint] = mimic.offset;
  }
  std::vector<int> root(n);
  std::vector<double> root_multiplier(n), root_offset(n);
  for (int j = 0; j < n; ++j) {
    // q_j = m_j q_l + o_j, q_l = m_l q_r + o_l, ...: multipliers multiply, offsets compose.
    int at = j, steps = 0;
    double m = 1.0, o = 0.0;
    while (leader[at] >= 0) {
      if (++steps > n) {  // after n steps along the leaders, `at` lies on a cycle
        std::string cycle = "'" + joint_names_[at] + "'";
        for (int k = leader[at];; k = leader[k]) {
          cycle += " -> '" + joint_names_[k] + "'";
          if (k == at) break;
        }
        refuse("mimic joint '" + joint_names_[j] + "': its leaders form a cycle (" + cycle + ")");
      }
      o = o + m * offset[at];
      m *= multiplier[at];
      at = leader[at];
    }
    root[j] = at;
    root_multiplier[j] = m;
    root_offset[j] = o;
  }
  mimic_root_ = std::move(root);
  mimic_multiplier_ = std::move(root_multiplier);
  mimic_offset_ = std::move(root_offset);
  has_mimics_ = false;
  for (int j = 0; j < n; ++j) has_mimics_ |= mimic_root_[j] != j;
}

}  // namespace collision_response::robot
