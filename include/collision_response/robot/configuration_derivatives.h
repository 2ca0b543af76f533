#pragma once

#include <Eigen/Core>
#include <vector>

#include "collision_response/robot/robot_data.h"
#include "collision_response/robot/robot_model.h"

namespace collision_response::robot {

// Derivatives of a robot's kinematic and inertial maps with respect to its configuration
// coordinates (docs/robots.md, "Derivatives with respect to the joint positions"), at the state of
// `data` (forwardKinematics() and, for the mass matrix, computeMassMatrix() done): what the
// impact's joint-position derivatives need (core::computeBodyImpactDerivatives()). The coordinates
// are the joints that mimic no other, locked ones included, in joint order (configurationJoints();
// the order of jointPositionCoordinates()); moving one moves its followers by their multipliers.
// Each joint's motion carries its subtree rigidly along its world axis S (a twist at the world
// origin), so that a quantity X of a link below it changes as the twist cross product S x X
// (Featherstone's spatial algebra; the same rule the derivatives of the recursive Newton-Euler
// algorithm use). A world point p named with a link is the material point of that link at p: the
// point is held in the world, the link moves under it. Units: per rad for revolute joints, per m
// for prismatic.

/// The joints that are configuration coordinates (mimic no other), in joint order.
std::vector<int> configurationJoints(const RobotModel& model);

/// d/dq_k of J(p) x for each coordinate k (3 x configurationJoints().size(), [m/s per rad | m]):
/// the change of the velocity of the material point of `link` at world p when the joints move
/// with velocity x (velocity unknowns; locked joints still, the base as x says) [m/s].
Eigen::Matrix<double, 3, Eigen::Dynamic> jacobianProductByConfiguration(
    const RobotModel& model, const RobotData& data, int link, const Eigen::Vector3d& point,
    const Eigen::VectorXd& x);

/// The same for the point's velocity at the state's own motion (data.twists: every joint's
/// velocity, locked ones included, and the base's twist) [m/s per rad | m].
Eigen::Matrix<double, 3, Eigen::Dynamic> pointVelocityByConfiguration(const RobotModel& model,
                                                                      const RobotData& data,
                                                                      int link,
                                                                      const Eigen::Vector3d& point);

/// d/dq_k of J(p)^T F in the velocity unknowns (unknowns x coordinates): F [N] (or an impulse
/// [N s]) applied at world p on `link`.
Eigen::MatrixXd jacobianTransposeProductByConfiguration(const RobotModel& model,
                                                        const RobotData& data, int link,
                                                        const Eigen::Vector3d& point,
                                                        const Eigen::Vector3d& force);

/// d/dq_k of M(q) x in the velocity unknowns (unknowns x coordinates), x in the unknowns; needs
/// computeMassMatrix() at this state (its composite inertias).
Eigen::MatrixXd massMatrixProductByConfiguration(const RobotModel& model, const RobotData& data,
                                                 const Eigen::VectorXd& x);

}  // namespace collision_response::robot
