#include "collision_response/robot/articulated_body.h"

#include <utility>

#include "collision_response/core/errors.h"
#include "collision_response/robot/articulated_body_algorithm.h"
#include "collision_response/robot/configuration_derivatives.h"

namespace collision_response::robot {
namespace {

KDL::Frame toKdl(const Eigen::Isometry3d& pose) {
  // linear(), not rotation(): an Isometry's linear part is a rotation already, and Eigen 3.3's
  // rotation() re-orthonormalises it by an SVD (a pose set twice would drift).
  const Eigen::Matrix3d r = pose.linear();
  return KDL::Frame(
      KDL::Rotation(r(0, 0), r(0, 1), r(0, 2), r(1, 0), r(1, 1), r(1, 2), r(2, 0), r(2, 1),
                    r(2, 2)),
      KDL::Vector(pose.translation().x(), pose.translation().y(), pose.translation().z()));
}

Eigen::Vector3d velocityAt(const KDL::Twist& twist, const Eigen::Vector3d& p) {
  return Eigen::Vector3d(twist.vel.x(), twist.vel.y(), twist.vel.z()) +
         Eigen::Vector3d(twist.rot.x(), twist.rot.y(), twist.rot.z()).cross(p);
}

}  // namespace

ArticulatedBody::ArticulatedBody(const KDL::Tree& tree, BaseType base,
                                 const KDL::RigidBodyInertia& base_inertia)
    : ArticulatedBody(std::make_shared<const RobotModel>(tree, base, base_inertia)) {}

ArticulatedBody::ArticulatedBody(std::shared_ptr<const RobotModel> model)
    : model_(std::move(model)), data_(*model_) {
  rebuild();
}

template <class Edit>
void ArticulatedBody::editModel(Edit&& edit) {
  auto changed = std::make_shared<RobotModel>(*model_);
  edit(*changed);
  model_ = std::move(changed);
  rebuild();
}

void ArticulatedBody::setDefaultLink(int link) {
  editModel([link](RobotModel& model) { model.setDefaultLink(link); });
}

void ArticulatedBody::setJointModel(int joint, JointModel model, double armature) {
  editModel([&](RobotModel& m) { m.setJointModel(joint, model, armature); });
}

void ArticulatedBody::setMimicJoints(const std::vector<MimicJoint>& mimics) {
  editModel([&](RobotModel& m) { m.setMimicJoints(mimics); });
}

void ArticulatedBody::setLockedJoints(const std::vector<bool>& locked) {
  if (static_cast<int>(locked.size()) != jointCount()) {
    throw core::InvalidInput("locked_joints",
                             "needs " + std::to_string(jointCount()) + " entries (one per joint)");
  }
  data_.locked = locked;
  // The frames and twists do not depend on the locks: only the unknowns, M and its factor.
  updateUnknowns(*model_, data_);
  computeMassMatrix(*model_, data_);
  factorizeMassMatrix(*model_, data_);
  data_.free_accelerations_valid = false;
}

void ArticulatedBody::rebuild() {
  configuration_count_ = static_cast<int>(configurationJoints(*model_).size());
  updateUnknowns(*model_, data_);
  forwardKinematics(*model_, data_);
  computeMassMatrix(*model_, data_);
  factorizeMassMatrix(*model_, data_);
}

void ArticulatedBody::setState(const Eigen::VectorXd& q, const Eigen::VectorXd& qdot,
                               const Eigen::Isometry3d& base_pose,
                               const Eigen::Vector3d& base_linear_velocity,
                               const Eigen::Vector3d& base_angular_velocity) {
  if (q.size() != jointCount() || qdot.size() != jointCount()) {
    throw core::InvalidInput("q", "joint positions and velocities need " +
                                      std::to_string(jointCount()) + " entries each");
  }
  data_.q = q;
  data_.qdot = qdot;
  if (model_->hasMimicJoints()) deriveMimicState(*model_, data_);
  data_.base_pose = toKdl(base_pose);
  if (model_->floating()) {
    data_.base_linear_velocity = base_linear_velocity;
    data_.base_angular_velocity = base_angular_velocity;
  }
  forwardKinematics(*model_, data_);
  computeMassMatrix(*model_, data_);
  factorizeMassMatrix(*model_, data_);
  robot::requireRegular(data_, "q");
}

void ArticulatedBody::setFlightState(const Eigen::Ref<const Eigen::VectorXd>& q,
                                     const Eigen::Ref<const Eigen::VectorXd>& qdot,
                                     const Eigen::Isometry3d& base_pose) {
  if (q.size() != jointCount() || qdot.size() != jointCount()) {
    throw core::InvalidInput("q", "joint positions and velocities need " +
                                      std::to_string(jointCount()) + " entries each");
  }
  data_.q = q;
  data_.qdot = qdot;
  data_.base_pose = toKdl(base_pose);
  forwardKinematics(*model_, data_);
}

void ArticulatedBody::completeFlightState() {
  computeMassMatrix(*model_, data_);
  factorizeMassMatrix(*model_, data_);
  robot::requireRegular(data_, "q");
}

Eigen::VectorXd ArticulatedBody::flightAcceleration() const {
  return articulatedBodyAcceleration(*model_, data_);
}

void ArticulatedBody::flightAcceleration(ArticulatedBodyWorkspace& workspace,
                                         Eigen::VectorXd& vdot) const {
  articulatedBodyAcceleration(*model_, data_, workspace, vdot);
}

Eigen::Isometry3d ArticulatedBody::linkPose(int link) const {
  const KDL::Frame& f = data_.frames[model_->checkLink(link)];
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out.linear()(r, c) = f.M(r, c);
    out.translation()(r) = f.p(r);
  }
  return out;
}

Eigen::VectorXd ArticulatedBody::velocity() const {
  return unknownVelocity(*model_, data_);
}

void ArticulatedBody::addVelocityChange(const Eigen::Ref<const Eigen::VectorXd>& change) {
  robot::addVelocityChange(*model_, data_, change);
}

Eigen::Vector3d ArticulatedBody::partPointVelocity(int part, const Eigen::Vector3d& point) const {
  return velocityAt(data_.twists[model_->checkLink(part < 0 ? model_->defaultLink() : part)],
                    point);
}

Eigen::Matrix<double, 3, Eigen::Dynamic> ArticulatedBody::partPointJacobian(
    int part, const Eigen::Vector3d& point) const {
  return linkPointJacobian(part < 0 ? model_->defaultLink() : part, point);
}

Eigen::Matrix<double, Eigen::Dynamic, 3> ArticulatedBody::partInverseMassJacobianTranspose(
    int part, const Eigen::Vector3d& point) const {
  if (data_.unknowns == 0) return Eigen::Matrix<double, Eigen::Dynamic, 3>(0, 3);
  requireRegular();
  Eigen::Matrix<double, Eigen::Dynamic, 3> x = partPointJacobian(part, point).transpose();
  solveMassMatrix(data_, x);
  return x;
}

Eigen::VectorXd ArticulatedBody::restingContactTorques(
    int self, const std::vector<core::ContactPoint>& contacts,
    const std::vector<core::ContactImpulse>& answers) const {
  Eigen::VectorXd torques;
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    const core::ContactPoint& contact = contacts[c];
    if (!answers[c].resting || (contact.body_a != self && contact.body_b != self)) continue;
    if (torques.size() == 0) torques.setZero(jointCount());
    const Eigen::Vector3d force =
        answers[c].normal_force * contact.normal + answers[c].friction_force;
    if (contact.body_a == self) torques -= jointTorquesOf(contact.part_a, contact.point, force);
    if (contact.body_b == self) torques += jointTorquesOf(contact.part_b, contact.point, force);
  }
  return torques;
}

void ArticulatedBody::setLoads(const Eigen::VectorXd& joint_torques,
                               const Eigen::Vector3d& gravity) {
  if (joint_torques.size() != jointCount()) {
    throw core::InvalidInput("joint_torques",
                             "joint torques need " + std::to_string(jointCount()) + " entries");
  }
  data_.torques = joint_torques;
  data_.gravity = gravity;
  data_.gravity_compensation = false;
  data_.free_accelerations_valid = false;
}

void ArticulatedBody::setGravityCompensation(const Eigen::Vector3d& gravity) {
  data_.torques.setZero(jointCount());
  data_.gravity = gravity;
  data_.gravity_compensation = true;
  data_.free_accelerations_valid = false;
}

Eigen::Vector3d ArticulatedBody::partPointFreeAcceleration(int part,
                                                           const Eigen::Vector3d& point) const {
  const int link = model_->checkLink(part < 0 ? model_->defaultLink() : part);
  updateFreeAccelerations(*model_, data_);
  // a_p = dv_o/dt + alpha x p + w x v_p for the material point at p.
  const SpatialAcceleration& a = data_.free_accelerations[link];
  const KDL::Twist& twist = data_.twists[link];
  const Eigen::Vector3d w(twist.rot.x(), twist.rot.y(), twist.rot.z());
  return a.linear + a.angular.cross(point) + w.cross(velocityAt(twist, point));
}

Eigen::Matrix<double, 3, Eigen::Dynamic> ArticulatedBody::partPointVelocityByConfiguration(
    int part, const Eigen::Vector3d& point) const {
  return pointVelocityByConfiguration(*model_, data_, part < 0 ? model_->defaultLink() : part,
                                      point);
}

Eigen::Matrix<double, 3, Eigen::Dynamic> ArticulatedBody::partJacobianProductByConfiguration(
    int part, const Eigen::Vector3d& point, const Eigen::VectorXd& x) const {
  return jacobianProductByConfiguration(*model_, data_, part < 0 ? model_->defaultLink() : part,
                                        point, x);
}

Eigen::MatrixXd ArticulatedBody::partJacobianTransposeProductByConfiguration(
    int part, const Eigen::Vector3d& point, const Eigen::Vector3d& force) const {
  return jacobianTransposeProductByConfiguration(
      *model_, data_, part < 0 ? model_->defaultLink() : part, point, force);
}

Eigen::MatrixXd ArticulatedBody::massMatrixProductByConfiguration(const Eigen::VectorXd& x) const {
  return robot::massMatrixProductByConfiguration(*model_, data_, x);
}

Eigen::MatrixXd ArticulatedBody::inverseMassTimes(const Eigen::MatrixXd& x) const {
  requireRegular();
  Eigen::MatrixXd out = x;
  solveMassMatrix(data_, out);
  return out;
}

}  // namespace collision_response::robot
