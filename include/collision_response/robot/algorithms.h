#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "collision_response/robot/robot_data.h"
#include "collision_response/robot/robot_model.h"

namespace collision_response::robot {

// The robot algorithms as free functions over a const model and one request's data
// (docs/robots.md, "Model and data"): each reads the model, reads or writes only `data`, and keeps
// no state of its own, so threads with their own data may run them on one shared model. World
// frame, spatial vectors at the world origin. `data` must have been made for `model`.

/// The velocity unknowns from the locks (the model's kLocked joints and data.locked; a mimic group
/// is locked when its root is, or any of its joints with a non-zero multiplier): the base twist
/// first (floating), then one per free group, its root's, in joint order. Derives the followers'
/// q and qdot from their roots'.
void updateUnknowns(const RobotModel& model, RobotData& data);
/// The followers' q and qdot from their roots' (q = m q_root + o, qdot = m qdot_root).
void deriveMimicState(const RobotModel& model, RobotData& data);
/// Frames and joint axes of every link from q and the base pose, then updateTwists(); the world
/// inertias computeMassMatrix() kept are no longer valid.
void forwardKinematics(const RobotModel& model, RobotData& data);
/// Link twists from qdot and the base twist (V_i = V_parent + S_i qdot_i); invalidates the free
/// accelerations.
void updateTwists(const RobotModel& model, RobotData& data);
/// M(q) in the unknowns by the composite-rigid-body algorithm (armature on the diagonal, mimic
/// groups folded: T^T M_all T). Needs forwardKinematics(). Keeps each link's world inertia
/// (RobotData::link_inertias), which inverseDynamics() then reads instead of computing it again.
void computeMassMatrix(const RobotModel& model, RobotData& data);
/// M = L L^T into data.cholesky; a singular M is recorded in data.singular (naming the first
/// joint whose pivot vanishes), not thrown.
void factorizeMassMatrix(const RobotModel& model, RobotData& data);
/// Throws core::InvalidInput naming `field` with data.singular if M is singular.
void requireRegular(const RobotData& data, const std::string& field = "joint_models");
/// x <- M^-1 x by the factor (every column), data.unknowns rows.
void solveMassMatrix(const RobotData& data, Eigen::Matrix<double, Eigen::Dynamic, 3>& x);
void solveMassMatrix(const RobotData& data, Eigen::VectorXd& x);
void solveMassMatrix(const RobotData& data, Eigen::MatrixXd& x);

/// J(p) of the material point of `link` at world p, 3 x unknowns (a follower's column folded into
/// its root's: J_root += multiplier * J_joint).
Eigen::Matrix<double, 3, Eigen::Dynamic> pointJacobian(const RobotModel& model,
                                                       const RobotData& data, int link,
                                                       const Eigen::Vector3d& point);
/// J(p)^T F over every joint (locked ones included), joint order [N m | N].
Eigen::VectorXd jointTorquesOf(const RobotModel& model, const RobotData& data, int link,
                               const Eigen::Vector3d& point, const Eigen::Vector3d& force);
/// The velocity unknowns' values (base twist, then each free group's root's qdot).
Eigen::VectorXd unknownVelocity(const RobotModel& model, const RobotData& data);
/// Adds `change` (unknowns) to the velocities; the followers follow exactly; then updateTwists().
void addVelocityChange(const RobotModel& model, RobotData& data,
                       const Eigen::Ref<const Eigen::VectorXd>& change);

/// World mass properties of a link at its frame.
SpatialInertia worldInertia(const LocalInertia& local, const KDL::Frame& frame);
/// Kinetic energy (1/2) v_all^T M_all v_all of every link [J].
double kineticEnergy(const RobotModel& model, const RobotData& data);
/// Linear [N s] and angular momentum about the world origin [N m s], world.
Eigen::Matrix<double, 6, 1> momentum(const RobotModel& model, const RobotData& data);

/// Recursive Newton-Euler: the generalized forces (per joint, and the base's 6 as for its
/// unknowns) that give the joints the accelerations `joint_accelerations` (jointCount()) and the
/// base `base_acceleration` (origin [m/s^2], angular [rad/s^2]; floating only), with the joints'
/// velocities if `with_velocity`, under data.gravity. Writes the links' accelerations (gravity not
/// included) to `accelerations` if not null.
void inverseDynamics(const RobotModel& model, const RobotData& data,
                     const Eigen::VectorXd& joint_accelerations,
                     const Eigen::Matrix<double, 6, 1>& base_acceleration, bool with_velocity,
                     Eigen::VectorXd& joint_forces, Eigen::Matrix<double, 6, 1>& base_forces,
                     std::vector<SpatialAcceleration>* accelerations);
/// g(q) for every joint (gravity compensation) [N m | N].
Eigen::VectorXd gravityTorques(const RobotModel& model, const RobotData& data);
/// h(q, v) = C(q, v) v + g(q) in the unknowns.
Eigen::VectorXd biasForces(const RobotModel& model, const RobotData& data);
/// The actuators' torques: data.torques, or g(q) under gravity compensation.
Eigen::VectorXd jointTorques(const RobotModel& model, const RobotData& data);
/// vdot = M^-1 (tau - h) in the unknowns (throws if M is singular).
Eigen::VectorXd freeAcceleration(const RobotModel& model, const RobotData& data);
/// Fills data.free_accelerations (the links' under the loads alone) if they are not valid.
void updateFreeAccelerations(const RobotModel& model, const RobotData& data);

}  // namespace collision_response::robot
