#pragma once

#include <Eigen/Core>
#include <kdl/rigidbodyinertia.hpp>
#include <kdl/segment.hpp>
#include <kdl/tree.hpp>
#include <string>
#include <vector>

namespace collision_response::robot {

/// What a joint does during an impact (docs/robots.md, "Joint models").
enum class JointModel {
  kFree,      ///< its velocity jumps: one velocity unknown
  kLocked,    ///< moves with its parent during the impact: no unknown, its velocity is kept
  kArmature,  ///< free, with a rotor inertia (kg m^2, or kg for a prismatic joint) added on M's
              ///< diagonal
};

/// A joint whose coordinate follows another's (URDF <mimic>, docs/robots.md, "Mimic joints"):
/// q_joint = multiplier * q_leader + offset, qdot_joint = multiplier * qdot_leader. It adds no
/// unknown: its motion folds into its leader's (through chains of mimics, into the first joint of
/// the chain that mimics nothing, its root).
struct MimicJoint {
  std::string joint;        ///< the follower (a joint with a coordinate)
  std::string leader;       ///< the joint it follows (URDF's <mimic joint="...">)
  double multiplier = 1.0;  ///< dq_joint / dq_leader [1, or m/rad, rad/m between kinds]
  double offset = 0.0;      ///< q_joint at q_leader = 0 [rad | m]
};

/// How the robot's base moves.
enum class BaseType {
  kFixed,     ///< placed by a pose, immovable
  kFloating,  ///< 6 more unknowns: the base twist (velocity of the base origin, angular velocity)
};

/// A link's own mass properties in its (tip) frame: mass [kg], centre of mass [m] and rotational
/// inertia about the centre of mass [kg m^2], both in the link frame.
struct LocalInertia {
  double mass = 0.0;
  Eigen::Vector3d com = Eigen::Vector3d::Zero();
  Eigen::Matrix3d about_com = Eigen::Matrix3d::Zero();
};

/// One link of the tree and the joint that carries it (docs/robots.md, "Model and data").
struct LinkModel {
  std::string name;
  int parent = -1;       ///< link index, -1 for the base (link 0)
  KDL::Segment segment;  ///< the joint and the tip frame (the inertia is in `local`)
  /// The segment's frame past its joint: segment.pose(q) = jointPose(segment.getJoint(), q) *
  /// tip. Read once when the model is built: KDL's Joint::pose() caches its last answer in the
  /// joint (a mutable member), so the algorithms never call it on a shared model.
  KDL::Frame tip;
  LocalInertia local;  ///< the link's own, link frame
  int joint = -1;      ///< joint index (jointNames()), -1 for a fixed joint and the base
};

/// What a robot is, apart from any state (Pinocchio's model; docs/robots.md, "Model and data"):
/// the links in topological order (KDL::Tree; revolute, continuous, prismatic and fixed joints,
/// velocity limits kept for the answer's check, position limits unused), the base type and inertia,
/// each joint's model and armature, the mimic relations resolved to their roots, the default link
/// and the name indices. The configuration functions (setJointModel(), setMimicJoints(),
/// setDefaultLink()) are for building it; once shared (std::shared_ptr<const RobotModel>) it is
/// never changed, so any number of requests and threads read it at once, each with its own
/// RobotData. The joint models here are the robot's own; a request locks further joints in its data
/// (RobotData::locked).
///
/// Errors are core::InvalidInput naming the argument: "joint", "link", "armature", "tree",
/// "base", "mimic_joints".
class RobotModel {
 public:
  /// The tree's root segment is the base; base_inertia is the base link's inertia in the base
  /// frame (a KDL::Tree's root has none: urdf_loader.h passes the URDF root link's), used when the
  /// base floats. Every joint free, no mimics, the default link the last. Throws for an empty tree
  /// or a joint with a KDL scale or offset other than 1 and 0 ("tree"; kdl_parser makes none), or
  /// a floating base on a massless robot ("base").
  RobotModel(const KDL::Tree& tree, BaseType base = BaseType::kFixed,
             const KDL::RigidBodyInertia& base_inertia = KDL::RigidBodyInertia::Zero());

  // --- Building (before the model is shared) ----------------------------------------------------
  /// The joint's model and armature [kg m^2 | kg] (used for kArmature only). Throws naming
  /// "joint" for an index out of range, "armature" for a negative or NaN armature.
  void setJointModel(int joint, JointModel model, double armature = 0.0);
  /// The mimic joints (URDF <mimic>), replacing any set before, resolved to their roots: q =
  /// multiplier * q_root + offset, the multipliers multiplied and the offsets composed along a
  /// chain. Throws naming "mimic_joints" (the text names the joint: "mimic joint 'x': ...") for a
  /// follower or leader that is not a joint with a coordinate, two leaders, a non-finite
  /// multiplier or offset, and a cycle. An empty list: no mimics.
  void setMimicJoints(const std::vector<MimicJoint>& mimics);
  /// The link the part-less BodyModel functions use. Throws naming "link" if out of range.
  void setDefaultLink(int link);
  /// The joint's velocity limit [rad/s | m/s] (URDF <limit velocity>; docs/robots.md, "Safety
  /// outputs"): the impact does not use it, the answer compares the post-impact velocity with it.
  /// Infinity (the default) for none. Throws naming "joint" for an index out of range,
  /// "velocity_limit" for a limit that is not > 0 (NaN included).
  void setVelocityLimit(int joint, double limit);

  // --- Description
  // --------------------------------------------------------------------------------
  BaseType baseType() const { return base_type_; }
  bool floating() const { return base_type_ == BaseType::kFloating; }
  /// Joints with a coordinate (revolute, continuous, prismatic), in KDL's q_nr order.
  int jointCount() const { return static_cast<int>(joint_names_.size()); }
  const std::vector<std::string>& jointNames() const { return joint_names_; }
  /// Index of a joint by name; throws naming "joint" if there is none.
  int jointIndex(const std::string& name) const;
  /// Index of a joint by name, -1 if there is none.
  int findJoint(const std::string& name) const;
  /// Links (the tree's segments; the base itself is link 0), parents before children.
  int linkCount() const { return static_cast<int>(links_.size()); }
  const LinkModel& link(int index) const { return links_[index]; }
  const std::string& linkName(int link) const { return links_[link].name; }
  /// Throws naming "link" if there is no such link.
  int linkIndex(const std::string& name) const;
  /// `link` itself; throws naming "link" if it is out of range.
  int checkLink(int link) const {
    if (link < 0 || link >= linkCount()) refuseLink(link);
    return link;
  }
  int defaultLink() const { return default_link_; }
  /// The link a joint carries.
  int linkOfJoint(int joint) const { return link_of_joint_[joint]; }

  JointModel jointModel(int joint) const { return joint_models_[joint]; }
  /// The rotor inertia added on M's diagonal (0 unless the joint's model is kArmature).
  double armature(int joint) const { return armatures_[joint]; }
  /// The joint's velocity limit [rad/s | m/s]; infinity when it has none.
  double velocityLimit(int joint) const { return velocity_limits_[joint]; }

  bool hasMimicJoints() const { return has_mimics_; }
  /// The independent joint a joint's coordinate follows (itself if it mimics nothing), and the
  /// resolved multiplier and offset: q_joint = mimicMultiplier * q_root + mimicOffset.
  int mimicRoot(int joint) const { return mimic_root_[joint]; }
  double mimicMultiplier(int joint) const { return mimic_multiplier_[joint]; }
  double mimicOffset(int joint) const { return mimic_offset_[joint]; }

 private:
  [[noreturn]] void refuseLink(int link) const;

  BaseType base_type_;
  std::vector<LinkModel> links_;
  std::vector<std::string> joint_names_;
  std::vector<int> link_of_joint_;
  std::vector<JointModel> joint_models_;
  std::vector<double> armatures_;
  std::vector<double> velocity_limits_;
  std::vector<int> mimic_root_;
  std::vector<double> mimic_multiplier_, mimic_offset_;
  bool has_mimics_ = false;
  int default_link_ = 0;
};

/// The motion of a joint at q (KDL's Joint::pose() for a joint of scale 1 and offset 0, the only
/// kind RobotModel takes) without touching the joint's cache: safe on a shared model.
KDL::Frame jointPose(const KDL::Joint& joint, double q);

/// The mass properties of a KDL inertia (rotational inertia about the frame origin) as a
/// LocalInertia (about the centre of mass).
LocalInertia localInertia(const KDL::RigidBodyInertia& inertia);

}  // namespace collision_response::robot
