#pragma once

#include <Eigen/Core>
#include <vector>

#include "collision_response/robot/robot_data.h"
#include "collision_response/robot/robot_model.h"

namespace collision_response::robot {

/// True if articulatedBodyAcceleration() applies to the model: a fixed base and no mimic joints
/// (a mimic group couples joints across the tree, which the recursion does not).
bool articulatedBodyApplies(const RobotModel& model);

/// The free acceleration vdot [rad/s^2 | m/s^2] of the velocity unknowns (freeAcceleration()'s
/// answer, M^-1 (tau - h)) by Featherstone's articulated-body algorithm, O(links), without M(q):
/// world frame, spatial vectors at the world origin, under the loads of `data` (tau = data.torques
/// and gravity; under gravity compensation the velocity terms alone, no gravity and no tau);
/// armature on each free joint's pivot; a locked joint moves its link at its constant velocity.
/// Needs forwardKinematics() (frames, axes, twists) only. Requires articulatedBodyApplies();
/// throws core::InvalidInput ("q") naming the joint if a free joint's articulated inertia along
/// its axis is not positive (M singular).
Eigen::VectorXd articulatedBodyAcceleration(const RobotModel& model, const RobotData& data);

/// The articulated-body algorithm's per-link scratch (articulated inertias, bias forces, the
/// joints' axes, drifts and pivots, the links' accelerations), kept by the caller from call to call
/// so that a flight's many right-hand sides allocate nothing. Per request (a RobotEpisodeBody
/// holds one), never shared between threads; sized by the call.
struct ArticulatedBodyWorkspace {
  std::vector<Eigen::Matrix<double, 6, 6>> inertia;
  std::vector<Eigen::Matrix<double, 6, 1>> bias, axis, drift, U, acceleration;
  std::vector<double> D, u;
  std::vector<char> grounded;  ///< the base and the links welded to it (fixed joints)
};

/// As above, the answer into `vdot` (resized to data.unknowns), the scratch in `workspace`: the
/// same numbers, without allocation once the workspace and vdot have their sizes.
void articulatedBodyAcceleration(const RobotModel& model, const RobotData& data,
                                 ArticulatedBodyWorkspace& workspace, Eigen::VectorXd& vdot);

}  // namespace collision_response::robot
