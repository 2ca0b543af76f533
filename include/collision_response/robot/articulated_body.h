#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <kdl/frames.hpp>
#include <kdl/rigidbodyinertia.hpp>
#include <kdl/tree.hpp>
#include <string>
#include <vector>

#include "collision_response/core/body_model.h"
#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/contact_point.h"

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

/// A robot as a body of the contact problem (core::BodyModel, docs/robots.md): a kinematic tree of
/// links (KDL::Tree; revolute, continuous, prismatic and fixed joints, limits unused) on a fixed or
/// floating base. Velocity unknowns v = (base twist (v_o [m/s], w [rad/s]), world, if floating;
/// the velocities of the free joints in joint order, a mimic joint folded into its root's:
/// setMimicJoints()). Per state (setState()): the links' world
/// frames (KDL's), the joint-space inertia M(q) by the composite-rigid-body algorithm (spatial
/// inertias in the world frame about the world origin, Eigen fixed-size), its Cholesky factor
/// M = L L^T, so that every M^-1 J(p)^T is two triangular solves. A robot without velocity
/// unknowns (a fixed base, every joint locked) skips M: its state is the frames and twists. A
/// contact names a link as its part (core::ContactPoint::part_a / part_b = linkIndex("name")); the
/// part-less BodyModel methods use defaultLink() (the last link).
class ArticulatedBody final : public core::BodyModel {
 public:
  /// The tree's root segment is the base; base_inertia is the base link's inertia in the base
  /// frame (a KDL::Tree's root has none: urdf_loader.h passes the URDF root link's), used when the
  /// base floats. Every joint free, q = qdot = 0, base at the identity. Throws
  /// std::invalid_argument for an empty tree or a floating base on a massless robot. A singular
  /// M (singularJoint()) is accepted here, so that the joint can be locked; setState() and the
  /// contact problem refuse it.
  ArticulatedBody(const KDL::Tree& tree, BaseType base = BaseType::kFixed,
                  const KDL::RigidBodyInertia& base_inertia = KDL::RigidBodyInertia::Zero());

  // --- Description -----------------------------------------------------------------------------
  BaseType baseType() const { return base_type_; }
  /// Joints with a coordinate (revolute, continuous, prismatic), in KDL's q_nr order: the order of
  /// jointPositions() and jointVelocities().
  int jointCount() const { return static_cast<int>(joint_names_.size()); }
  const std::vector<std::string>& jointNames() const { return joint_names_; }
  /// Why M is singular ("singular joint-space inertia: joint 'name' moves no mass ..."), empty if
  /// it is not; requireRegular() throws it as std::invalid_argument.
  const std::string& singularJoint() const { return singular_; }
  void requireRegular() const;
  /// Index of a joint by name; throws std::invalid_argument naming it if there is none.
  int jointIndex(const std::string& name) const;
  /// Links (the tree's segments below the base; the base itself is link 0), by name.
  int linkCount() const { return static_cast<int>(links_.size()); }
  const std::string& linkName(int link) const { return links_[link].name; }
  /// Throws std::invalid_argument naming it if there is no such link.
  int linkIndex(const std::string& name) const;
  int defaultLink() const { return default_link_; }
  void setDefaultLink(int link);

  /// Joint model (and armature, for kArmature) of a joint; rebuilds the state's factorisation
  /// (a singular M is recorded, not thrown: locking joints one by one may pass through one).
  /// Mimic joints: a group (a root and the joints that mimic it, directly or through a chain) is
  /// one unknown, locked when its root is, or any of its joints whose multiplier (to the root) is
  /// not 0 (a brake on one joint of a coupling holds them all); a follower's armature I_a adds
  /// multiplier^2 I_a to its root's diagonal.
  void setJointModel(int joint, JointModel model, double armature = 0.0);
  JointModel jointModel(int joint) const { return joint_models_[joint]; }
  /// Whether the joint keeps its velocity in an impact: its own model, or its mimic group's lock.
  bool isLocked(int joint) const { return unknown_of_joint_[joint] < 0; }

  /// The mimic joints (URDF <mimic>; urdf_loader.h passes them), replacing any set before: each
  /// joint's coordinate then follows its root's, q = multiplier * q_root + offset with the
  /// multipliers multiplied and the offsets composed along a chain (a mimic of a mimic). The
  /// followers' positions and velocities are derived from their roots' now and at every
  /// setState(). Throws std::invalid_argument naming the joint for a follower or a leader that is
  /// not a joint with a coordinate, a joint given two leaders, a non-finite multiplier or offset,
  /// and a cycle (a joint that mimics itself through its leaders). An empty list: no mimics.
  void setMimicJoints(const std::vector<MimicJoint>& mimics);
  bool hasMimicJoints() const { return has_mimics_; }
  /// The independent joint a joint's coordinate follows (itself if it mimics nothing), and the
  /// resolved multiplier and offset: q_joint = mimicMultiplier * q_root + mimicOffset (1 and 0 for
  /// an independent joint).
  int mimicRoot(int joint) const { return mimic_root_[joint]; }
  double mimicMultiplier(int joint) const { return mimic_multiplier_[joint]; }
  double mimicOffset(int joint) const { return mimic_offset_[joint]; }

  // --- State -------------------------------------------------------------------------------------
  /// Joint positions q [rad | m] and velocities [rad/s | m/s] (jointCount() each), base pose in
  /// the world and, for a floating base, its twist (velocity of the base origin, angular velocity,
  /// world). A mimic joint's entries are not used: its position and velocity are derived from its
  /// root's (mimicRoot()). Computes kinematics, M(q) and its factor. Throws std::invalid_argument
  /// on wrong sizes and when M is singular (a free joint moving only massless links, or one whose
  /// motion the floating base already gives them), naming the joint; the state is then kept (lock
  /// the joint).
  void setState(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot,
                const Eigen::Isometry3d& base_pose = Eigen::Isometry3d::Identity(),
                const Eigen::Vector3d& base_linear_velocity = Eigen::Vector3d::Zero(),
                const Eigen::Vector3d& base_angular_velocity = Eigen::Vector3d::Zero());
  const Eigen::VectorXd& jointPositions() const { return q_; }
  const Eigen::VectorXd& jointVelocities() const { return qdot_; }
  const Eigen::Vector3d& baseLinearVelocity() const { return base_linear_velocity_; }
  const Eigen::Vector3d& baseAngularVelocity() const { return base_angular_velocity_; }
  /// World pose of a link's frame.
  Eigen::Isometry3d linkPose(int link) const;

  /// M(q) in the velocity unknowns (velocityCount() square), with armature [kg, kg m, kg m^2].
  const Eigen::MatrixXd& massMatrix() const { return mass_matrix_; }
  /// The joint of unknown k (-1 for the base twist's six; a mimic group's root for its unknown).
  int jointOfUnknown(int k) const { return joint_of_unknown_[k]; }
  /// Unknown of a joint, -1 for a locked one; a mimic joint shares its root's (its velocity is
  /// mimicMultiplier() times that unknown).
  int unknownOfJoint(int joint) const { return unknown_of_joint_[joint]; }
  /// J(p) of the material point of `link` at world p, 3 x velocityCount() (a mimic joint's column
  /// folded into its root's: J_root += multiplier * J_joint).
  Eigen::Matrix<double, 3, Eigen::Dynamic> linkPointJacobian(int link,
                                                             const Eigen::Vector3d& point) const;
  /// Generalized impulse of a velocity change, M dv = sum of J^T P over the impulses that made it
  /// [N s for base and prismatic unknowns, N m s for rotations]; a mimic group's entry is that of
  /// its root's coordinate (the sum over the group of multiplier times each joint's J^T P).
  Eigen::VectorXd generalizedImpulse(const Eigen::VectorXd& velocity_change) const {
    return mass_matrix_ * velocity_change;
  }
  /// The generalized force a force F [N] applied at world p on `link` exerts on every joint, J(p)^T
  /// F over all joints (locked ones included: what their brake or controller holds), joint order [N
  /// m revolute, N prismatic]. The same for an impulse [N s] gives N m s | N s.
  Eigen::VectorXd jointTorquesOf(int link, const Eigen::Vector3d& point,
                                 const Eigen::Vector3d& force) const;
  /// The joint torques that the resting contact forces exert on this robot, body `self` of the
  /// contact list: sum of jointTorquesOf() over the contacts with a side on it whose answer is
  /// resting, with the force normal_force n + friction_force (+ on b, - on a). Empty if no resting
  /// contact touches the robot.
  Eigen::VectorXd restingContactTorques(int self, const std::vector<core::ContactPoint>& contacts,
                                        const std::vector<core::ContactImpulse>& answers) const;
  /// Kinetic energy (1/2) v_all^T M_all v_all of the whole robot, locked joints included [J].
  double kineticEnergy() const;
  /// Total linear [N s] and angular momentum about the world origin [N m s], world.
  Eigen::Matrix<double, 6, 1> momentum() const;

  // --- Loads (resting contacts, docs/robots.md, "Resting contacts") ---------------------------
  /// The joint torques tau [N m revolute, N prismatic] the actuators apply (jointCount() entries,
  /// joint order; a locked joint's entry is unused: its acceleration is 0) and the gravitational
  /// acceleration g [m/s^2], world (e.g. (0, 0, -9.81) for a z-up world). Default: zero torques,
  /// no gravity. Kept across setState(). Throws std::invalid_argument on a wrong size.
  void setLoads(const Eigen::VectorXd& joint_torques, const Eigen::Vector3d& gravity);
  /// Gravity g [m/s^2], world, and actuators that hold the robot against it at whatever state it
  /// takes: tau = gravityTorques(), computed only when a resting query needs it (impacts pay
  /// nothing). Kept across setState() until setLoads().
  void setGravityCompensation(const Eigen::Vector3d& gravity);
  /// The actuators' torques: those of setLoads(), or g(q) under gravity compensation.
  Eigen::VectorXd jointTorques() const;
  const Eigen::Vector3d& gravity() const { return gravity_; }
  /// The joint torques that hold the robot still against gravity at its configuration, g(q)
  /// (every joint, locked ones included) [N m | N]: gravity compensation.
  Eigen::VectorXd gravityTorques() const;
  /// h(q, v) in the velocity unknowns: the generalized forces the unknowns need for zero
  /// acceleration, C(q, v) v + g(q) (Coriolis, centrifugal and gravity; the base's as a force [N]
  /// and a moment about the base origin [N m], world), so that M vdot + h = tau.
  Eigen::VectorXd biasForces() const;
  /// vdot = M^-1 (tau - h): the acceleration of the velocity unknowns under the loads alone
  /// (locked joints: 0; the base's as the acceleration of its origin [m/s^2] and angular
  /// acceleration [rad/s^2]).
  Eigen::VectorXd freeAcceleration() const;

  // --- core::BodyModel
  // -----------------------------------------------------------------------------
  int velocityCount() const override { return unknowns_; }
  Eigen::VectorXd velocity() const override;
  Eigen::Vector3d materialPointVelocity(const Eigen::Vector3d& point) const override {
    return partPointVelocity(default_link_, point);
  }
  Eigen::Matrix<double, 3, Eigen::Dynamic> pointJacobian(
      const Eigen::Vector3d& point) const override {
    return partPointJacobian(default_link_, point);
  }
  Eigen::Matrix<double, Eigen::Dynamic, 3> inverseMassJacobianTranspose(
      const Eigen::Vector3d& point) const override {
    return partInverseMassJacobianTranspose(default_link_, point);
  }
  void addVelocityChange(const Eigen::Ref<const Eigen::VectorXd>& change) override;
  Eigen::Vector3d partPointVelocity(int part, const Eigen::Vector3d& point) const override;
  Eigen::Matrix<double, 3, Eigen::Dynamic> partPointJacobian(
      int part, const Eigen::Vector3d& point) const override;
  Eigen::Matrix<double, Eigen::Dynamic, 3> partInverseMassJacobianTranspose(
      int part, const Eigen::Vector3d& point) const override;
  /// The material point's acceleration under the loads alone: J(p) vdot + J-dot(p) v, from the
  /// links' accelerations for freeAcceleration(), computed on the first call after a change of
  /// state or loads (not thread-safe on one object, as setState() is not).
  Eigen::Vector3d partPointFreeAcceleration(int part, const Eigen::Vector3d& point) const override;

 private:
  /// A link's spatial acceleration, world, at the world origin: angular [rad/s^2] and the
  /// derivative of the velocity field at the origin [m/s^2] (the time derivative of a twist).
  struct Acceleration {
    Eigen::Vector3d angular = Eigen::Vector3d::Zero();
    Eigen::Vector3d linear = Eigen::Vector3d::Zero();
  };
  /// Recursive Newton-Euler: the generalized forces (per joint, and the base's 6 as for its
  /// unknowns) that give the joints the accelerations `joint_accelerations` (jointCount()) and the
  /// base the acceleration `base_acceleration` (origin [m/s^2], angular [rad/s^2]; a floating base
  /// only), with the joints' velocities if `with_velocity`, under gravity. Writes the links'
  /// accelerations (gravity not included) to `accelerations` if not null.
  void inverseDynamics(const Eigen::VectorXd& joint_accelerations,
                       const Eigen::Matrix<double, 6, 1>& base_acceleration, bool with_velocity,
                       Eigen::VectorXd& joint_forces, Eigen::Matrix<double, 6, 1>& base_forces,
                       std::vector<Acceleration>* accelerations) const;
  void updateFreeAccelerations() const;
  /// Mass properties of a rigid body in the world frame, about the world origin: mass m [kg],
  /// first moment h = m c [kg m] (c its centre of mass), rotational inertia I_o about the origin
  /// [kg m^2]. Such inertias of bodies add (composite bodies).
  struct SpatialInertia {
    double mass = 0.0;
    Eigen::Vector3d first_moment = Eigen::Vector3d::Zero();
    Eigen::Matrix3d rotational = Eigen::Matrix3d::Zero();
    SpatialInertia& operator+=(const SpatialInertia& other) {
      mass += other.mass;
      first_moment += other.first_moment;
      rotational += other.rotational;
      return *this;
    }
  };
  /// A link's own mass properties in its (tip) frame: mass [kg], centre of mass [m] and rotational
  /// inertia about the centre of mass [kg m^2], both in the link frame.
  struct LocalInertia {
    double mass = 0.0;
    Eigen::Vector3d com = Eigen::Vector3d::Zero();
    Eigen::Matrix3d about_com = Eigen::Matrix3d::Zero();
  };
  struct Link {
    std::string name;
    int parent = -1;           // link index, -1 for the base
    KDL::Segment segment;      // joint + tip frame (the inertia is in `local`)
    LocalInertia local;        // the link's own, link frame
    int joint = -1;            // index into joint_names_, -1 for a fixed joint / the base
    KDL::Frame frame;          // world frame of the link (segment tip)
    KDL::Twist axis;           // motion of a unit joint velocity, world, at the origin
    KDL::Twist twist;          // link twist, world, at the world origin
    SpatialInertia composite;  // the link and its subtree, world, about the origin (M(q) only)
  };
  static LocalInertia localInertia(const KDL::RigidBodyInertia& inertia);
  SpatialInertia worldInertia(const Link& link) const;
  void rebuild();  // unknowns from the joint models, then kinematics, M and its factor
  void updateKinematics();
  void updateTwists();
  void updateMassMatrix();
  void updateMimicMassMatrix();  // updateMassMatrix() for a robot with mimic joints
  void deriveMimicState();       // the followers' q and qdot from their roots'
  // Generalized forces per joint (and the base's 6) folded into the unknowns: T^T f.
  Eigen::VectorXd foldJointForces(const Eigen::VectorXd& joint_forces,
                                  const Eigen::Matrix<double, 6, 1>& base_forces) const;
  void factorise();
  // Motion of a unit value of unknown k (world twist at the origin).
  const KDL::Twist& unknownAxis(int k) const;
  int checkLink(int link) const;

  BaseType base_type_;
  std::vector<Link> links_;  // topological order: parents first; links_[0] is the base
  std::vector<std::string> joint_names_;
  std::vector<int> link_of_joint_;
  std::vector<JointModel> joint_models_;
  std::vector<double> armatures_;
  std::vector<int> unknown_of_joint_;
  std::vector<int> joint_of_unknown_;
  int unknowns_ = 0;
  // Mimic joints, resolved to their roots (q_j = multiplier_j q_root_j + offset_j; j itself, 1, 0
  // for an independent joint). Without mimics (has_mimics_ false) every path is the plain one.
  std::vector<int> mimic_root_;
  std::vector<double> mimic_multiplier_, mimic_offset_;
  bool has_mimics_ = false;
  int default_link_ = 0;

  Eigen::VectorXd q_, qdot_;
  KDL::Frame base_pose_ = KDL::Frame::Identity();
  Eigen::Vector3d base_linear_velocity_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d base_angular_velocity_ = Eigen::Vector3d::Zero();
  KDL::Twist base_axes_[6];
  Eigen::MatrixXd mass_matrix_;
  Eigen::MatrixXd cholesky_;  // M = L L^T: L in the lower triangle (factorise())
  std::string singular_;
  Eigen::VectorXd torques_;                            // tau, joint order (setLoads())
  bool gravity_compensation_ = false;                  // tau = g(q) instead
  Eigen::Vector3d gravity_ = Eigen::Vector3d::Zero();  // g, world
  // Links' accelerations under the loads alone (partPointFreeAcceleration()), valid if the flag.
  mutable std::vector<Acceleration> free_accelerations_;
  mutable bool free_accelerations_valid_ = false;
};

}  // namespace collision_response::robot
