#pragma once

#include <collision_response/RobotResult.h>
#include <collision_response/RobotState.h>
#include <ros/time.h>

#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "collision_response/core/contact.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/robot/articulated_body.h"
#include "collision_response/ros/served_robot.h"

namespace collision_response {

/// The base pose a RobotState gives (request frame), or nothing when the whole pose is zero (the
/// default: the caller looks the base frame up in tf2). Throws core::InvalidInput naming
/// field + ".base_pose..." for a non-finite value, an orientation that is not unit length, or a
/// position given with the all-zero orientation.
std::optional<Eigen::Isometry3d> basePoseFromMsg(const RobotState& msg, const std::string& field);

/// The served robot at the state a request gives it (docs/robots.md, "Robots through ROS"): a copy
/// of its prototype (the data alone: the model stays shared) with the request's locked joints (or
/// the entry's), joint positions and velocities
/// from msg.joint_state, each one missing there from the robot's joint-state cache, `base_pose`
/// (request frame) and, for a floating base, msg.base_twist. Throws core::InvalidInput naming
/// `field` ("robots[i]") + ".joint_state.name[k]" for an unknown or repeated joint,
/// ".joint_state.position" / ".velocity" for an array neither empty nor as long as name,
/// ".joint_state.position[k]" / ".velocity[k]" for a value that is not finite (or beyond the core's
/// magnitude limits), ".joint_state" for a joint whose position is given nowhere or whose latest
/// message is older than `timeout` [s] at `now`, ".base_twist" for a non-finite twist,
/// ".locked_joints[k]" for an unknown joint and ".locked_joints" when the unlocked joints leave M
/// singular. A joint whose velocity neither the request nor the topic gives (publishers of
/// positions only, such as joint_state_publisher) is at rest, with a line in `warnings` (if not
/// null). A mimic joint's position and velocity are derived from its root's (it needs none); one
/// given in the request, or recent on the topic, that differs from the derived by more than 1e-6
/// [rad | m, rad/s | m/s] gets a line in `warnings` naming it, and the derived one is used. The
/// loads of resting contacts (ArticulatedBody::setLoads()): msg.gravity (request frame;
/// ".gravity" if not finite or beyond 1e9 m/s^2) and the torques msg.joint_torques names: gravity
/// compensation g(q), none, or joint_state.effort (".joint_state.effort" for an array neither empty
/// nor as long as name, a value not finite, or a free joint whose effort is given nowhere or is
/// older than `timeout`); ".joint_torques" for another value.
robot::ArticulatedBody robotAtRequestState(const ServedRobot& robot, const RobotState& msg,
                                           const Eigen::Isometry3d& base_pose, const ros::Time& now,
                                           double timeout, const std::string& field,
                                           std::vector<std::string>* warnings = nullptr);

/// A robot's answer: `after` is the model after the impact, `velocity_before` its velocity
/// unknowns (ArticulatedBody::velocity()) and `energy_before` its kinetic energy [J] before it.
/// joint_state: the model's joints in order, positions unchanged, velocities post-impact, effort
/// the generalized impulse M (v_after - v_before) per joint (0 for a locked one; a mimic joint of
/// multiplier m: its root's divided by m, the group's impulse in its own coordinate, 0 if m = 0).
RobotResult toMsg(const std::string& name, const robot::ArticulatedBody& after,
                  const Eigen::VectorXd& velocity_before, double energy_before,
                  const Eigen::Isometry3d& base_pose, const std_msgs::Header& header);

/// The request's contacts as contact points of the body models: the rigid bodies first (models
/// 0 .. rigid_count - 1), then one model per robot. `contact_bodies`: each contact's validated body
/// indices (SceneValidator::contactBodies()); an index past the rigid bodies is a link,
/// `robot_link_of_id[index - rigid_count]` = (robot, link), placed as body rigid_count + robot,
/// part link. Normals are normalised.
std::vector<core::ContactPoint> placeContacts(
    const std::vector<core::Contact>& contacts,
    const std::vector<std::pair<int, int>>& contact_bodies, int rigid_count,
    const std::vector<std::pair<int, int>>& robot_link_of_id);

}  // namespace collision_response
