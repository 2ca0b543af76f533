// The shipped 7-DOF arm (urdf/arm7.urdf, robot "arm" of the node's ~robots) striking a box with
// its hand at one contact, as a service request: shared by the robot rostests and the service
// benchmark (benchmark/service_load.cpp).
#pragma once

#include <collision_response/ComputeResponse.h>
#include <ros/time.h>
#include <sensor_msgs/JointState.h>

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "collision_response/robot/articulated_body.h"
#include "collision_response/robot/urdf_loader.h"

namespace collision_response::testing {

/// The arm's joints in model order: 7 revolute, then the 2 prismatic fingers.
inline const std::vector<std::string> kArmJoints = {"joint1",
                                                    "joint2",
                                                    "joint3",
                                                    "joint4",
                                                    "joint5",
                                                    "joint6",
                                                    "joint7",
                                                    "left_finger_joint",
                                                    "right_finger_joint"};

/// A swing of the arm that moves the hand (kArmJoints order) [rad | m] and [rad/s | m/s].
inline const std::vector<double> kArmSwingPositions = {0.1, 0.6, -0.2, -1.2, 0.3,
                                                       0.9, 0.2, 0.01, 0.01};
inline const std::vector<double> kArmSwingVelocities = {0.2, 0.5, -0.1, -0.6, 0.1, 0.3, 0.05, 0, 0};

/// Where the hand strikes [m, world] and the contact normal (unit, from the hand towards the box).
struct Strike {
  Eigen::Vector3d point;
  Eigen::Vector3d normal;
};

/// The point 4 cm along the hand's z from its origin, at the arm's current state, with the normal
/// along that point's velocity: the contact approaches when the box is at rest.
inline Strike strikeOf(const robot::ArticulatedBody& arm) {
  const int hand = arm.linkIndex("hand");
  Strike strike;
  strike.point = arm.linkPose(hand) * Eigen::Vector3d(0, 0, 0.04);
  strike.normal = arm.partPointVelocity(hand, strike.point).normalized();
  return strike;
}

/// A 2 kg box (10 cm cube), centred 5 cm beyond the strike point along the normal, moving towards
/// the hand at `speed` [m/s] (0: at rest).
inline BodyState strikeBox(const Strike& strike, double speed = 0.0) {
  BodyState body;
  body.id = "box";
  body.inertia.m = 2.0;
  body.inertia.ixx = body.inertia.iyy = body.inertia.izz = 2.0 * 0.01 / 6.0;  // m a^2 / 6
  const Eigen::Vector3d centre = strike.point + 0.05 * strike.normal;
  body.pose.position.x = centre.x();
  body.pose.position.y = centre.y();
  body.pose.position.z = centre.z();
  body.pose.orientation.w = 1.0;
  body.twist.linear.x = -speed * strike.normal.x();
  body.twist.linear.y = -speed * strike.normal.y();
  body.twist.linear.z = -speed * strike.normal.z();
  return body;
}

/// The request: the box above and one contact "arm/hand" -> "box" at the strike point, e = 0.4,
/// mu_s = 0.3, mu_d = 0.2, in frame "world". No `robots` entry: callers add one when they give
/// the arm's state.
inline ComputeResponse strikeRequest(const Strike& strike, double box_speed = 0.0) {
  ComputeResponse srv;
  srv.request.header.frame_id = "world";
  srv.request.bodies = {strikeBox(strike, box_speed)};
  Contact c;
  c.body_a = "arm/hand";
  c.body_b = "box";
  c.point.x = strike.point.x();
  c.point.y = strike.point.y();
  c.point.z = strike.point.z();
  c.normal.x = strike.normal.x();
  c.normal.y = strike.normal.y();
  c.normal.z = strike.normal.z();
  c.restitution = 0.4;
  c.static_friction = 0.3;
  c.dynamic_friction = 0.2;
  srv.request.contacts = {c};
  return srv;
}

/// The arm's joint state (q, qdot in kArmJoints order), stamped now.
inline sensor_msgs::JointState armJointState(const std::vector<double>& q,
                                             const std::vector<double>& qdot) {
  sensor_msgs::JointState msg;
  msg.header.stamp = ros::Time::now();
  msg.name = kArmJoints;
  msg.position = q;
  msg.velocity = qdot;
  return msg;
}

/// The arm of the URDF `urdf`, its base at the world origin, at state (q, qdot), striking the box
/// (moving towards the hand at `box_speed` [m/s]). The request names robot "arm": with the joint
/// state (q, qdot) when `own_state`, else with none (the node's latest joint state is used).
inline ComputeResponse armStrikeRequest(const std::string& urdf, const std::vector<double>& q,
                                        const std::vector<double>& qdot, bool own_state,
                                        double box_speed = 0.0) {
  robot::ArticulatedBody arm = robot::robotFromUrdfString(urdf);
  arm.setState(Eigen::Map<const Eigen::VectorXd>(q.data(), static_cast<int>(q.size())),
               Eigen::Map<const Eigen::VectorXd>(qdot.data(), static_cast<int>(qdot.size())));
  ComputeResponse srv = strikeRequest(strikeOf(arm), box_speed);
  srv.request.robots.resize(1);
  srv.request.robots[0].name = "arm";
  if (own_state) {
    srv.request.robots[0].joint_state = armJointState(q, qdot);
    srv.request.robots[0].joint_state.header.stamp = ros::Time();
  }
  return srv;
}

}  // namespace collision_response::testing
