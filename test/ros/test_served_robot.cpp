// A ~robots entry's model and the request's robot state, without a ROS master (served_robot.h,
// robot_conversion.h, joint_state_cache.h): start-up errors name the parameter; joint states merge
// the request's values with the latest per joint; every bad value is named.
#include <gtest/gtest.h>
#include <ros/package.h>

#include <Eigen/Geometry>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

#include "collision_response/core/errors.h"
#include "collision_response/robot/urdf_loader.h"
#include "collision_response/ros/robot_conversion.h"
#include "collision_response/ros/served_robot.h"

namespace cr = collision_response;

namespace {

std::string twoLinkUrdf() {
  std::ifstream file(std::string(TEST_ROBOT_DIR) + "/two_link.urdf");
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

// A 2-joint arm whose second joint moves a massless link: M is singular unless it is locked.
const char* kMasslessTip = R"(<?xml version="1.0"?>
<robot name="tip">
  <link name="base"/>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <link name="upper"><inertial><origin xyz="0.5 0 0"/><mass value="1"/>
    <inertia ixx="0.01" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="wrist" type="revolute"><parent link="upper"/><child link="tip"/>
    <origin xyz="1 0 0"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <link name="tip"/>
</robot>)";

template <class F>
void expectField(F&& f, const std::string& field, const std::string& text = "") {
  try {
    f();
    ADD_FAILURE() << field << ": accepted";
  } catch (const cr::core::InvalidInput& e) {
    EXPECT_EQ(e.field(), field) << e.what();
    EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what();
  }
}

cr::RobotParameters entry(const std::string& name = "arm") {
  cr::RobotParameters p;
  p.name = name;
  return p;
}

}  // namespace

TEST(ServedRobot, StartUpErrorsNameTheParameter) {
  expectField([] { cr::ServedRobot(entry(), "<robot", "~robots[0]"); },
              "~robots[0].description_param", "/robot_description");
  expectField([] { cr::ServedRobot(entry(), kMasslessTip, "~robots[1]"); }, "~robots[1]",
              "joint 'wrist'");
  cr::RobotParameters locked = entry();
  locked.locked_joints = {"nope"};
  expectField([&] { cr::ServedRobot(locked, twoLinkUrdf(), "~robots[0]"); },
              "~robots[0].locked_joints[0]", "'nope'");
  cr::RobotParameters armature = entry();
  armature.armature["nope"] = 0.1;
  expectField([&] { cr::ServedRobot(armature, twoLinkUrdf(), "~robots[0]"); },
              "~robots[0].armature.nope");
  // Locking the joint that moves no mass makes the model usable.
  cr::RobotParameters tip = entry("tip");
  tip.locked_joints = {"wrist"};
  const cr::ServedRobot served(tip, kMasslessTip, "~robots[0]");
  EXPECT_EQ(served.model().velocityCount(), 1);
  EXPECT_EQ(served.baseFrame(), "base");
  EXPECT_EQ(served.linkIds().front(), "tip/base");
}

TEST(ServedRobot, ArmatureAndLockedJointsFromTheEntry) {
  cr::RobotParameters p = entry();
  const cr::ServedRobot plain(p, twoLinkUrdf(), "~robots[0]");
  p.armature[plain.model().jointNames()[0]] = 0.25;
  const cr::ServedRobot with_armature(p, twoLinkUrdf(), "~robots[0]");
  EXPECT_NEAR(with_armature.model().massMatrix()(0, 0) - plain.model().massMatrix()(0, 0), 0.25,
              1e-12);
  EXPECT_EQ(with_armature.model().massMatrix()(1, 1), plain.model().massMatrix()(1, 1));
  p.locked_joints = {plain.model().jointNames()[1]};
  const cr::ServedRobot locked(p, twoLinkUrdf(), "~robots[0]");
  EXPECT_EQ(locked.model().velocityCount(), 1);
}

class RobotStateTest : public ::testing::Test {
 protected:
  RobotStateTest() : served_(entry(), twoLinkUrdf(), "~robots[0]") {}

  cr::robot::ArticulatedBody at(const cr::RobotState& msg, double age = 0.0) {
    return cr::robotAtRequestState(served_, msg, Eigen::Isometry3d::Identity(),
                                   now_ + ros::Duration(age), 0.5, "robots[0]");
  }
  void publish(const std::vector<double>& q, const std::vector<double>& qdot) {
    sensor_msgs::JointState msg;
    msg.header.stamp = now_;
    msg.name = served_.model().jointNames();
    msg.name.push_back("another_robots_joint");
    msg.position = q;
    msg.position.push_back(9.0);
    msg.velocity = qdot;
    msg.velocity.push_back(9.0);
    served_.jointStates().update(msg, now_);
  }

  cr::ServedRobot served_;
  const ros::Time now_{100.0};
};

TEST_F(RobotStateTest, TheRequestOverridesTheLatestPerJoint) {
  cr::RobotState msg;
  msg.name = "arm";
  const auto& joints = served_.model().jointNames();
  expectField([&] { at(msg); }, "robots[0].joint_state", "none received on /joint_states");
  publish({0.1, 0.2}, {0.3, 0.4});
  cr::robot::ArticulatedBody latest = at(msg);
  EXPECT_EQ(latest.jointPositions(), Eigen::Vector2d(0.1, 0.2));
  EXPECT_EQ(latest.jointVelocities(), Eigen::Vector2d(0.3, 0.4));
  msg.joint_state.name = {joints[1]};
  msg.joint_state.velocity = {-1.0};  // position of joint 1 from the latest
  const cr::robot::ArticulatedBody merged = at(msg);
  EXPECT_EQ(merged.jointPositions(), Eigen::Vector2d(0.1, 0.2));
  EXPECT_EQ(merged.jointVelocities(), Eigen::Vector2d(0.3, -1.0));
  // Stale: the latest is older than the timeout at `now`.
  expectField([&] { at(msg, 0.6); }, "robots[0].joint_state", "~joint_state_timeout");
  // Complete in the request: the latest is not needed, however old.
  msg.joint_state.name = joints;
  msg.joint_state.position = {1.0, 2.0};
  msg.joint_state.velocity = {3.0, 4.0};
  const cr::robot::ArticulatedBody given = at(msg, 100.0);
  EXPECT_EQ(given.jointPositions(), Eigen::Vector2d(1.0, 2.0));
  EXPECT_EQ(given.jointVelocities(), Eigen::Vector2d(3.0, 4.0));
}

// JOINT_TORQUES_EFFORT: tau from the request's effort, else the topic's. An effort is as old as the
// message that gave it: a newer positions-only message does not refresh it.
TEST_F(RobotStateTest, EffortsFromTheRequestOrTheTopicWithTheirOwnAge) {
  const auto& joints = served_.model().jointNames();
  cr::RobotState msg;
  msg.name = "arm";
  msg.joint_state.name = joints;
  msg.joint_state.position = {0.1, 0.2};
  msg.joint_state.velocity = {0.0, 0.0};
  msg.joint_torques = cr::RobotState::JOINT_TORQUES_EFFORT;
  msg.gravity.y = -9.81;
  msg.joint_state.effort = {1.5, -0.5};
  EXPECT_EQ(at(msg).jointTorques(), Eigen::Vector2d(1.5, -0.5));
  msg.joint_state.effort.clear();
  expectField([&] { at(msg); }, "robots[0].joint_state.effort", "has no effort");
  sensor_msgs::JointState efforts;
  efforts.header.stamp = now_;
  efforts.name = joints;
  efforts.effort = {2.0, 3.0};
  served_.jointStates().update(efforts, now_);
  EXPECT_EQ(at(msg).jointTorques(), Eigen::Vector2d(2.0, 3.0));
  sensor_msgs::JointState positions;  // 1 s later, positions only
  positions.header.stamp = now_ + ros::Duration(1.0);
  positions.name = joints;
  positions.position = {0.1, 0.2};
  served_.jointStates().update(positions, positions.header.stamp);
  expectField([&] { at(msg, 1.0); }, "robots[0].joint_state.effort", "~joint_state_timeout");
  // Gravity compensation (the default) and none need no effort.
  msg.joint_torques = cr::RobotState::JOINT_TORQUES_NONE;
  EXPECT_EQ(at(msg, 1.0).jointTorques(), Eigen::Vector2d::Zero());
  msg.joint_torques = cr::RobotState::JOINT_TORQUES_GRAVITY_COMPENSATION;
  const cr::robot::ArticulatedBody held = at(msg, 1.0);
  EXPECT_EQ(held.jointTorques(), held.gravityTorques());
  EXPECT_GT(held.jointTorques().norm(), 1.0);
  msg.joint_torques = 3;
  expectField([&] { at(msg); }, "robots[0].joint_torques");
}

TEST_F(RobotStateTest, BadValuesAreNamed) {
  const auto& joints = served_.model().jointNames();
  cr::RobotState msg;
  msg.name = "arm";
  msg.joint_state.name = joints;
  msg.joint_state.position = {0.0, 0.0};
  msg.joint_state.velocity = {0.0, 0.0};
  cr::RobotState bad = msg;
  bad.joint_state.position = {0.0};
  expectField([&] { at(bad); }, "robots[0].joint_state.position");
  bad = msg;
  bad.joint_state.velocity[1] = std::numeric_limits<double>::infinity();
  expectField([&] { at(bad); }, "robots[0].joint_state.velocity[1]");
  bad = msg;
  bad.joint_state.name[1] = joints[0];
  expectField([&] { at(bad); }, "robots[0].joint_state.name[1]", "repeats");
  bad = msg;
  bad.override_locked_joints = true;
  bad.locked_joints = {"x"};
  expectField([&] { at(bad); }, "robots[0].locked_joints[0]");
  bad = msg;
  bad.base_pose.orientation.w = std::numeric_limits<double>::quiet_NaN();
  expectField([&] { cr::basePoseFromMsg(bad, "robots[0]"); }, "robots[0].base_pose.orientation");
  EXPECT_FALSE(cr::basePoseFromMsg(msg, "robots[0]").has_value());  // all-zero: from tf
}
