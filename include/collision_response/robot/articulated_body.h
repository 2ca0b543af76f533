#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <kdl/frames.hpp>
#include <kdl/rigidbodyinertia.hpp>
#include <kdl/tree.hpp>
#include <memory>
#include <string>
#include <vector>

#include "collision_response/core/body_model.h"
#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/robot/algorithms.h"
#include "collision_response/robot/articulated_body_algorithm.h"
#include "collision_response/robot/robot_data.h"
#include "collision_response/robot/robot_model.h"

namespace collision_response::robot {

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
///
/// Model and data (docs/robots.md, "Model and data"): the body holds a shared, const RobotModel
/// (what the robot is) and its own RobotData (its state, locks and everything computed from
/// them), and runs the free functions of algorithms.h on them. Copying a body copies only the
/// data: the copies share the model, so requests and threads each take a copy of a served robot
/// at no model cost. setJointModel(), setMimicJoints() and setDefaultLink() build the body a new
/// model (copy on write: bodies sharing the old one keep it), for building; a request locks joints
/// with setLockedJoints(), in its data. Errors are core::InvalidInput naming the argument.
class ArticulatedBody final : public core::BodyModel {
 public:
  /// The tree's root segment is the base; base_inertia is the base link's inertia in the base
  /// frame (a KDL::Tree's root has none: urdf_loader.h passes the URDF root link's), used when the
  /// base floats. Every joint free, q = qdot = 0, base at the identity. Throws
  /// core::InvalidInput for an empty tree or a floating base on a massless robot. A singular
  /// M (singularJoint()) is accepted here, so that the joint can be locked; setState() and the
  /// contact problem refuse it.
  ArticulatedBody(const KDL::Tree& tree, BaseType base = BaseType::kFixed,
                  const KDL::RigidBodyInertia& base_inertia = KDL::RigidBodyInertia::Zero());
  /// A body of a shared model (not null), q = qdot = 0, base at the identity, no locks of its own.
  explicit ArticulatedBody(std::shared_ptr<const RobotModel> model);

  /// The model this body shares with its copies, and its own data.
  const RobotModel& model() const { return *model_; }
  const std::shared_ptr<const RobotModel>& sharedModel() const { return model_; }
  const RobotData& data() const { return data_; }

  // --- Description -----------------------------------------------------------------------------
  BaseType baseType() const { return model_->baseType(); }
  /// Joints with a coordinate (revolute, continuous, prismatic), in KDL's q_nr order: the order of
  /// jointPositions() and jointVelocities().
  int jointCount() const { return model_->jointCount(); }
  const std::vector<std::string>& jointNames() const { return model_->jointNames(); }
  /// Why M is singular ("singular joint-space inertia: joint 'name' moves no mass ..."), empty if
  /// it is not; requireRegular() throws it as core::InvalidInput naming "joint_models".
  const std::string& singularJoint() const { return data_.singular; }
  void requireRegular() const { robot::requireRegular(data_); }
  /// Index of a joint by name; throws core::InvalidInput ("joint") naming it if there is none.
  int jointIndex(const std::string& name) const { return model_->jointIndex(name); }
  /// Links (the tree's segments below the base; the base itself is link 0), by name.
  int linkCount() const { return model_->linkCount(); }
  const std::string& linkName(int link) const { return model_->linkName(link); }
  /// Throws core::InvalidInput ("link") naming it if there is no such link.
  int linkIndex(const std::string& name) const { return model_->linkIndex(name); }
  int defaultLink() const { return model_->defaultLink(); }
  /// A new model with this default link (copy on write).
  void setDefaultLink(int link);

  /// Joint model (and armature, for kArmature) of a joint, in a new model (copy on write: for
  /// building a robot, not per request); rebuilds the state's factorisation
  /// (a singular M is recorded, not thrown: locking joints one by one may pass through one).
  /// Mimic joints: a group (a root and the joints that mimic it, directly or through a chain) is
  /// one unknown, locked when its root is, or any of its joints whose multiplier (to the root) is
  /// not 0 (a brake on one joint of a coupling holds them all); a follower's armature I_a adds
  /// multiplier^2 I_a to its root's diagonal.
  void setJointModel(int joint, JointModel model, double armature = 0.0);
  JointModel jointModel(int joint) const { return model_->jointModel(joint); }
  /// The joint's velocity limit [rad/s | m/s] (URDF <limit velocity>), infinity when it has none.
  double velocityLimit(int joint) const { return model_->velocityLimit(joint); }
  /// Whether the joint keeps its velocity in an impact: its own model, this body's locks
  /// (setLockedJoints()), or its mimic group's lock.
  bool isLocked(int joint) const { return data_.unknown_of_joint[joint] < 0; }
  /// The joints this body locks on top of the model's kLocked ones (jointCount() flags; all false:
  /// the model's locks alone), held in its data: the model is not copied. Rebuilds the unknowns,
  /// M and its factor at the current state (the kinematics do not depend on the locks) (a singular
  /// M is recorded in singularJoint(), not thrown). Throws core::InvalidInput ("locked_joints") on
  /// a wrong size.
  void setLockedJoints(const std::vector<bool>& locked);
  const std::vector<bool>& lockedJoints() const { return data_.locked; }

  /// The mimic joints (URDF <mimic>; urdf_loader.h passes them), replacing any set before: each
  /// joint's coordinate then follows its root's, q = multiplier * q_root + offset with the
  /// multipliers multiplied and the offsets composed along a chain (a mimic of a mimic). The
  /// followers' positions and velocities are derived from their roots' now and at every
  /// setState(). In a new model (copy on write). Throws core::InvalidInput ("mimic_joints")
  /// naming the joint for a follower or a leader that is
  /// not a joint with a coordinate, a joint given two leaders, a non-finite multiplier or offset,
  /// and a cycle (a joint that mimics itself through its leaders). An empty list: no mimics.
  void setMimicJoints(const std::vector<MimicJoint>& mimics);
  bool hasMimicJoints() const { return model_->hasMimicJoints(); }
  /// The independent joint a joint's coordinate follows (itself if it mimics nothing), and the
  /// resolved multiplier and offset: q_joint = mimicMultiplier * q_root + mimicOffset (1 and 0 for
  /// an independent joint).
  int mimicRoot(int joint) const { return model_->mimicRoot(joint); }
  double mimicMultiplier(int joint) const { return model_->mimicMultiplier(joint); }
  double mimicOffset(int joint) const { return model_->mimicOffset(joint); }

  // --- State -------------------------------------------------------------------------------------
  /// Joint positions q [rad | m] and velocities [rad/s | m/s] (jointCount() each), base pose in
  /// the world and, for a floating base, its twist (velocity of the base origin, angular velocity,
  /// world). A mimic joint's entries are not used: its position and velocity are derived from its
  /// root's (mimicRoot()). Computes kinematics, M(q) and its factor. Throws core::InvalidInput
  /// ("q") on wrong sizes and when M is singular (a free joint moving only massless links, or one
  /// whose motion the floating base already gives them), naming the joint; the state is then kept
  /// (lock the joint).
  void setState(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot,
                const Eigen::Isometry3d& base_pose = Eigen::Isometry3d::Identity(),
                const Eigen::Vector3d& base_linear_velocity = Eigen::Vector3d::Zero(),
                const Eigen::Vector3d& base_angular_velocity = Eigen::Vector3d::Zero());
  /// The flight's state (RobotEpisodeBody): as setState() for a fixed base without mimic joints
  /// (articulatedBodyApplies()), kinematics only: M(q) and its factor are left stale, so only
  /// flightAcceleration() and the kinematic queries may follow until the next setState().
  void setFlightState(const Eigen::Ref<const Eigen::VectorXd>& q,
                      const Eigen::Ref<const Eigen::VectorXd>& qdot,
                      const Eigen::Isometry3d& base_pose);
  /// Completes a setFlightState() state into what setState() gives at it: M(q), its factor and the
  /// same check (the kinematics kept, not computed again). Throws as setState().
  void completeFlightState();
  /// freeAcceleration() at a setFlightState() state, by the articulated-body algorithm
  /// (articulated_body_algorithm.h).
  Eigen::VectorXd flightAcceleration() const;
  /// The same into `vdot`, with the caller's scratch (no allocation once sized).
  void flightAcceleration(ArticulatedBodyWorkspace& workspace, Eigen::VectorXd& vdot) const;
  const Eigen::VectorXd& jointPositions() const { return data_.q; }
  const Eigen::VectorXd& jointVelocities() const { return data_.qdot; }
  const Eigen::Vector3d& baseLinearVelocity() const { return data_.base_linear_velocity; }
  const Eigen::Vector3d& baseAngularVelocity() const { return data_.base_angular_velocity; }
  /// World pose of a link's frame.
  Eigen::Isometry3d linkPose(int link) const;

  /// M(q) in the velocity unknowns (velocityCount() square), with armature [kg, kg m, kg m^2].
  const Eigen::MatrixXd& massMatrix() const { return data_.mass_matrix; }
  /// The joint of unknown k (-1 for the base twist's six; a mimic group's root for its unknown).
  int jointOfUnknown(int k) const { return data_.joint_of_unknown[k]; }
  /// Unknown of a joint, -1 for a locked one; a mimic joint shares its root's (its velocity is
  /// mimicMultiplier() times that unknown).
  int unknownOfJoint(int joint) const { return data_.unknown_of_joint[joint]; }
  /// J(p) of the material point of `link` at world p, 3 x velocityCount() (a mimic joint's column
  /// folded into its root's: J_root += multiplier * J_joint).
  Eigen::Matrix<double, 3, Eigen::Dynamic> linkPointJacobian(int link,
                                                             const Eigen::Vector3d& point) const {
    return robot::pointJacobian(*model_, data_, link, point);
  }
  /// Generalized impulse of a velocity change, M dv = sum of J^T P over the impulses that made it
  /// [N s for base and prismatic unknowns, N m s for rotations]; a mimic group's entry is that of
  /// its root's coordinate (the sum over the group of multiplier times each joint's J^T P).
  Eigen::VectorXd generalizedImpulse(const Eigen::VectorXd& velocity_change) const {
    return data_.mass_matrix * velocity_change;
  }
  /// The generalized force a force F [N] applied at world p on `link` exerts on every joint, J(p)^T
  /// F over all joints (locked ones included: what their brake or controller holds), joint order [N
  /// m revolute, N prismatic]. The same for an impulse [N s] gives N m s | N s.
  Eigen::VectorXd jointTorquesOf(int link, const Eigen::Vector3d& point,
                                 const Eigen::Vector3d& force) const {
    return robot::jointTorquesOf(*model_, data_, link, point, force);
  }
  /// The joint torques that the resting contact forces exert on this robot, body `self` of the
  /// contact list: sum of jointTorquesOf() over the contacts with a side on it whose answer is
  /// resting, with the force normal_force n + friction_force (+ on b, - on a). Empty if no resting
  /// contact touches the robot.
  Eigen::VectorXd restingContactTorques(int self, const std::vector<core::ContactPoint>& contacts,
                                        const std::vector<core::ContactImpulse>& answers) const;
  /// Kinetic energy (1/2) v_all^T M_all v_all of the whole robot, locked joints included [J].
  double kineticEnergy() const { return robot::kineticEnergy(*model_, data_); }
  /// Total linear [N s] and angular momentum about the world origin [N m s], world.
  Eigen::Matrix<double, 6, 1> momentum() const { return robot::momentum(*model_, data_); }

  // --- Loads (resting contacts, docs/robots.md, "Resting contacts") ---------------------------
  /// The joint torques tau [N m revolute, N prismatic] the actuators apply (jointCount() entries,
  /// joint order; a locked joint's entry is unused: its acceleration is 0) and the gravitational
  /// acceleration g [m/s^2], world (e.g. (0, 0, -9.81) for a z-up world). Default: zero torques,
  /// no gravity. Kept across setState(). Throws core::InvalidInput ("joint_torques") on a wrong
  /// size.
  void setLoads(const Eigen::VectorXd& joint_torques, const Eigen::Vector3d& gravity);
  /// Gravity g [m/s^2], world, and actuators that hold the robot against it at whatever state it
  /// takes: tau = gravityTorques(), computed only when a resting query needs it (impacts pay
  /// nothing). Kept across setState() until setLoads().
  void setGravityCompensation(const Eigen::Vector3d& gravity);
  /// The actuators' torques: those of setLoads(), or g(q) under gravity compensation.
  Eigen::VectorXd jointTorques() const { return robot::jointTorques(*model_, data_); }
  const Eigen::Vector3d& gravity() const { return data_.gravity; }
  /// The joint torques that hold the robot still against gravity at its configuration, g(q)
  /// (every joint, locked ones included) [N m | N]: gravity compensation.
  Eigen::VectorXd gravityTorques() const { return robot::gravityTorques(*model_, data_); }
  /// h(q, v) in the velocity unknowns: the generalized forces the unknowns need for zero
  /// acceleration, C(q, v) v + g(q) (Coriolis, centrifugal and gravity; the base's as a force [N]
  /// and a moment about the base origin [N m], world), so that M vdot + h = tau.
  Eigen::VectorXd biasForces() const { return robot::biasForces(*model_, data_); }
  /// vdot = M^-1 (tau - h): the acceleration of the velocity unknowns under the loads alone
  /// (locked joints: 0; the base's as the acceleration of its origin [m/s^2] and angular
  /// acceleration [rad/s^2]).
  Eigen::VectorXd freeAcceleration() const { return robot::freeAcceleration(*model_, data_); }

  // --- core::BodyModel
  // -----------------------------------------------------------------------------
  int velocityCount() const override { return data_.unknowns; }
  Eigen::VectorXd velocity() const override;
  Eigen::Vector3d materialPointVelocity(const Eigen::Vector3d& point) const override {
    return partPointVelocity(model_->defaultLink(), point);
  }
  Eigen::Matrix<double, 3, Eigen::Dynamic> pointJacobian(
      const Eigen::Vector3d& point) const override {
    return partPointJacobian(model_->defaultLink(), point);
  }
  Eigen::Matrix<double, Eigen::Dynamic, 3> inverseMassJacobianTranspose(
      const Eigen::Vector3d& point) const override {
    return partInverseMassJacobianTranspose(model_->defaultLink(), point);
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
  /// The configuration coordinates: the joints that mimic no other, locked ones included, in
  /// joint order (configurationJoints(), jointPositionCoordinates()); their derivatives from
  /// robot/configuration_derivatives.h at this state.
  int configurationCount() const override { return configuration_count_; }
  Eigen::Matrix<double, 3, Eigen::Dynamic> partPointVelocityByConfiguration(
      int part, const Eigen::Vector3d& point) const override;
  Eigen::Matrix<double, 3, Eigen::Dynamic> partJacobianProductByConfiguration(
      int part, const Eigen::Vector3d& point, const Eigen::VectorXd& x) const override;
  Eigen::MatrixXd partJacobianTransposeProductByConfiguration(
      int part, const Eigen::Vector3d& point, const Eigen::Vector3d& force) const override;
  Eigen::MatrixXd massMatrixProductByConfiguration(const Eigen::VectorXd& x) const override;
  Eigen::MatrixXd inverseMassTimes(const Eigen::MatrixXd& x) const override;

 private:
  void rebuild();  // unknowns from the locks, then kinematics, M and its factor
  // Replaces the model by a copy changed by `edit` (copy on write), then rebuild().
  template <class Edit>
  void editModel(Edit&& edit);

  std::shared_ptr<const RobotModel> model_;
  RobotData data_;
  int configuration_count_ = 0;  // configurationJoints(*model_).size(), set with the model
};

}  // namespace collision_response::robot
