// Integration test: mimic joints through ROS (docs/robots.md, "Mimic joints"). The node serves the
// parallel gripper of test/robot/gripper.urdf (mimic_node.test), whose finger2_joint mimics
// finger1_joint (multiplier 1, offset 0). A ball strikes one finger: both fingers' post-impact
// velocities are reported and equal; the generalized impulse of the fingers' one unknown is the
// contact impulse's power on both fingers' axes, taken from the uncoupled gripper's Jacobian (no
// mimic code); a mimic joint whose state nobody gives needs none (no "no velocity" warning); a
// given mimic state that disagrees with its leader's is named in a warning, in the request and on
// the joint-state topic.
#include <collision_response/ComputeResponse.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>

#include <Eigen/Geometry>
#include <regex>
#include <string>
#include <vector>

#include "collision_response/core/body_response.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/robot/urdf_loader.h"
#include "collision_response/ros/message_conversion.h"
#include "node_test_messages.h"

namespace cr = collision_response;
using namespace collision_response::testing;
using collision_response::toEigen;

namespace {

constexpr double kExact = 1e-12;  // the node and the core do the same arithmetic

std::string gripperUrdf() {
  std::string urdf;
  EXPECT_TRUE(ros::param::get("/gripper_description", urdf));
  return urdf;
}

// The base of the gripper in the request frame.
Eigen::Isometry3d basePose() {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(0.2, -0.1, 0.3);
  pose.linear() = Eigen::AngleAxisd(0.5, Eigen::Vector3d(0.2, 1.0, 0.1).normalized()).matrix();
  return pose;
}

// The state every request uses: wrist 0.3 rad at 0.4 rad/s, finger1 0.015 m closing at 0.05 m/s.
const double kWrist = 0.3, kWristRate = 0.4, kFinger = 0.015, kFingerRate = -0.05;

// A ball (0.3 kg, r 0.02 m) approaching the outer face of `finger` ("finger1" / "finger2") at 2 m/s
// along an oblique normal, friction 0.6 / 0.4, e = 0.5; the gripper's joint state: wrist and
// finger1 only.
struct Strike {
  cr::ComputeResponse srv;
  Eigen::Vector3d point, normal;
};
Strike strikeOn(const std::string& finger) {
  cr::robot::ArticulatedBody gripper = cr::robot::robotFromUrdfString(gripperUrdf());
  gripper.setState(Eigen::Vector3d(kWrist, kFinger, 0.0),
                   Eigen::Vector3d(kWristRate, kFingerRate, 0.0), basePose());
  const double side = finger == "finger1" ? 1.0 : -1.0;
  const Eigen::Isometry3d pad = gripper.linkPose(gripper.linkIndex(finger));
  Strike out;
  out.point = pad * Eigen::Vector3d(0.006, side * 0.01, 0.035);
  out.normal = pad.linear() * Eigen::Vector3d(0.3, side, -0.2).normalized();
  const Eigen::Vector3d centre = out.point + 0.02 * out.normal;
  out.srv.request.header.frame_id = "world";
  out.srv.request.bodies.push_back(
      sphere("ball", 0.3, 0.02, pose(centre.x(), centre.y(), centre.z())));
  out.srv.request.bodies[0].twist.linear = cr::toVector3(-2.0 * out.normal);
  out.srv.request.contacts.push_back(contact("gripper/" + finger, "ball", out.point.x(),
                                             out.point.y(), out.point.z(), out.normal.x(),
                                             out.normal.y(), out.normal.z(), 0.5, 0.6, 0.4));
  cr::RobotState& robot = out.srv.request.robots.emplace_back();
  robot.name = "gripper";
  robot.joint_state.name = {"wrist", "finger1_joint"};
  robot.joint_state.position = {kWrist, kFinger};
  robot.joint_state.velocity = {kWristRate, kFingerRate};
  const Eigen::Isometry3d base = basePose();
  const Eigen::Quaterniond q(base.linear());
  robot.base_pose = pose(base.translation().x(), base.translation().y(), base.translation().z(), q);
  return out;
}

int jointIndex(const cr::RobotResult& robot, const std::string& name) {
  for (std::size_t j = 0; j < robot.joint_state.name.size(); ++j) {
    if (robot.joint_state.name[j] == name) return static_cast<int>(j);
  }
  ADD_FAILURE() << "no joint " << name << " in the answer";
  return 0;
}

std::vector<std::string> warningsNaming(const cr::ComputeResponse::Response& response,
                                        const std::string& text) {
  std::vector<std::string> out;
  for (const std::string& w : response.warnings) {
    if (w.find(text) != std::string::npos) out.push_back(w);
  }
  return out;
}

// The warnings other than the joints' velocity limits (the strikes throw the 0.1 kg fingers beyond
// their 0.2 m/s: docs/robots.md, "Safety outputs").
std::vector<std::string> otherThanLimits(const cr::ComputeResponse::Response& response) {
  std::vector<std::string> out;
  for (const std::string& w : response.warnings) {
    if (w.find("leaves its velocity limit") == std::string::npos) out.push_back(w);
  }
  return out;
}

class MimicNodeTest : public ServiceTest {};

// A strike on either finger: the node's answer is the core's for the same coupled model; both
// fingers are reported, at one velocity after as before; the fingers' generalized impulse is
// J_f1^T P + J_f2^T P with the columns of the uncoupled gripper (no mimic code) and P the contact
// impulse on the gripper, and finger2's entry (its own coordinate, multiplier 1) equals it; no
// warning but the fingers' velocity limits: finger2's state is derived, not missing.
TEST_F(MimicNodeTest, StruckFingerMovesBothFingers) {
  for (const std::string finger : {"finger1", "finger2"}) {
    const Strike strike = strikeOn(finger);
    const auto response = call(strike.srv);
    ASSERT_TRUE(response.success) << response.message;
    EXPECT_TRUE(otherThanLimits(response).empty()) << otherThanLimits(response).front();
    ASSERT_EQ(response.robots.size(), 1u);
    const cr::RobotResult& robot = response.robots[0];
    const int wrist = jointIndex(robot, "wrist"), f1 = jointIndex(robot, "finger1_joint"),
              f2 = jointIndex(robot, "finger2_joint");
    EXPECT_EQ(robot.joint_state.velocity[f2], robot.joint_state.velocity[f1]) << finger;
    EXPECT_EQ(robot.joint_state.position[f2], kFinger);
    EXPECT_EQ(robot.joint_state_before.velocity[f2], kFingerRate);
    EXPECT_EQ(robot.joint_state_before.velocity[f1], kFingerRate);
    EXPECT_NE(robot.joint_state.velocity[f1], kFingerRate) << "the strike moved the fingers";
    // Beyond the fingers' 0.2 m/s (gripper.urdf), both are named: the follower's velocity too.
    ASSERT_GT(std::abs(robot.joint_state.velocity[f1]), 0.2);
    for (const int f : {f1, f2}) {
      EXPECT_EQ(
          warningsNaming(response, "robots[0].joint_state.velocity[" + std::to_string(f) + "]: ")
              .size(),
          1u)
          << f;
    }
    ASSERT_EQ(response.impulses.size(), 1u);
    ASSERT_GT(response.impulses[0].normal_impulse, 0.0);

    // The core, same coupled model and ball.
    cr::robot::ArticulatedBody model = cr::robot::robotFromUrdfString(gripperUrdf());
    model.setState(Eigen::Vector3d(kWrist, kFinger, 0.0),
                   Eigen::Vector3d(kWristRate, kFingerRate, 0.0), basePose());
    cr::core::BodyState ball_state;
    ball_state.id = "ball";
    ball_state.mass = 0.3;
    ball_state.inertia = Eigen::Matrix3d::Identity() * 0.4 * 0.3 * 0.02 * 0.02;
    ball_state.position = strike.point + 0.02 * strike.normal;
    ball_state.linear_velocity = -2.0 * strike.normal;
    cr::core::RigidBody ball = cr::core::makeRigidBody(ball_state);
    cr::core::ContactPoint point(0, 1, strike.point, strike.normal, 0.5, 0.6, 0.4);
    point.part_a = model.linkIndex(finger);
    const cr::core::BodyResponse ref = cr::core::computeBodyResponse({&model, &ball}, {point});
    for (int j = 0; j < model.jointCount(); ++j) {
      EXPECT_NEAR(robot.joint_state.velocity[j], model.jointVelocities()(j), kExact) << finger;
    }
    EXPECT_NEAR(response.impulses[0].normal_impulse, ref.impulses[0].normal_impulse, kExact);

    // The generalized impulse from the uncoupled gripper's Jacobian.
    cr::robot::ArticulatedBody uncoupled = cr::robot::robotFromUrdfString(
        std::regex_replace(gripperUrdf(), std::regex("<mimic[^>]*/>"), ""));
    ASSERT_FALSE(uncoupled.hasMimicJoints());
    uncoupled.setState(Eigen::Vector3d(kWrist, kFinger, kFinger),
                       Eigen::Vector3d(kWristRate, kFingerRate, kFingerRate), basePose());
    const Eigen::Vector3d on_gripper = -ref.impulses[0].total(strike.normal);
    const Eigen::MatrixXd J =
        uncoupled.linkPointJacobian(uncoupled.linkIndex(finger), strike.point);
    const Eigen::VectorXd joint_impulses = J.transpose() * on_gripper;  // wrist, f1, f2
    const double fingers = joint_impulses(1) + joint_impulses(2);
    EXPECT_NE(fingers, 0.0);
    EXPECT_NEAR(robot.joint_state.effort[f1], fingers, 1e-9) << finger;
    EXPECT_NEAR(robot.joint_state.effort[f2], fingers, 1e-9) << finger;
    EXPECT_NEAR(robot.joint_state.effort[wrist], joint_impulses(0), 1e-9) << finger;
  }
}

// finger2_joint's state in the request: within 1e-6 of the derived one, no warning; beyond, a
// warning naming the joint and what differs; the derived state is used either way.
TEST_F(MimicNodeTest, DisagreeingMimicStateInTheRequestIsNamed) {
  const Strike strike = strikeOn("finger1");
  const auto plain = call(strike.srv);
  ASSERT_TRUE(plain.success) << plain.message;

  cr::ComputeResponse agreeing = strike.srv;
  cr::RobotState& state = agreeing.request.robots[0];
  state.joint_state.name.push_back("finger2_joint");
  state.joint_state.position.push_back(kFinger + 5e-7);
  state.joint_state.velocity.push_back(kFingerRate - 5e-7);
  const auto quiet = call(agreeing);
  ASSERT_TRUE(quiet.success) << quiet.message;
  EXPECT_TRUE(otherThanLimits(quiet).empty()) << otherThanLimits(quiet).front();

  cr::ComputeResponse disagreeing = strike.srv;
  cr::RobotState& bad = disagreeing.request.robots[0];
  bad.joint_state.name.push_back("finger2_joint");
  bad.joint_state.position.push_back(kFinger + 0.004);
  bad.joint_state.velocity.push_back(kFingerRate + 0.05);
  const auto warned = call(disagreeing);
  ASSERT_TRUE(warned.success) << warned.message;
  const auto named = warningsNaming(warned, "joint 'finger2_joint' mimics 'finger1_joint'");
  ASSERT_EQ(named.size(), 2u) << (warned.warnings.empty() ? "" : warned.warnings.front());
  EXPECT_NE(named[0].find("robots[0].joint_state"), std::string::npos) << named[0];
  EXPECT_NE(named[0].find("position in the request"), std::string::npos) << named[0];
  EXPECT_NE(named[1].find("velocity in the request"), std::string::npos) << named[1];
  // Solved with the derived state: the same answer as without finger2's entries.
  ASSERT_EQ(warned.robots.size(), 1u);
  EXPECT_EQ(warned.robots[0].joint_state.velocity, plain.robots[0].joint_state.velocity);
  EXPECT_EQ(warned.robots[0].joint_state.position, plain.robots[0].joint_state.position);
  EXPECT_EQ(warned.impulses[0].normal_impulse, plain.impulses[0].normal_impulse);
}

// The state from the topic: positions only (a joint_state_publisher), finger2's 3 mm off its
// leader's. The wrist and finger1 are taken at rest with the usual warning, which does not list
// finger2_joint (its velocity is derived); finger2's position is named as disagreeing.
TEST_F(MimicNodeTest, DisagreeingMimicStateOnTheTopicIsNamed) {
  ros::Publisher states =
      node_.advertise<sensor_msgs::JointState>("/gripper_joint_states", 1, /*latch=*/true);
  sensor_msgs::JointState msg;
  msg.header.stamp = ros::Time::now();
  msg.name = {"wrist", "finger1_joint", "finger2_joint"};
  msg.position = {kWrist, kFinger, kFinger + 0.003};
  states.publish(msg);
  cr::ComputeResponse srv = strikeOn("finger2").srv;
  srv.request.robots[0].joint_state = sensor_msgs::JointState();  // all from the topic
  cr::ComputeResponse::Response response;
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(20.0);
  do {
    response = call(srv);
    if (response.success) break;
    ros::WallDuration(0.05).sleep();
  } while (ros::WallTime::now() < deadline);
  ASSERT_TRUE(response.success) << response.message;
  const auto resting = warningsNaming(response, "no velocity");
  ASSERT_EQ(resting.size(), 1u);
  EXPECT_NE(resting[0].find("'wrist', 'finger1_joint'"), std::string::npos) << resting[0];
  EXPECT_EQ(resting[0].find("finger2_joint"), std::string::npos) << resting[0];
  const auto named = warningsNaming(response, "joint 'finger2_joint' mimics 'finger1_joint'");
  ASSERT_EQ(named.size(), 1u);
  EXPECT_NE(named[0].find("position on /gripper_joint_states"), std::string::npos) << named[0];
  const cr::RobotResult& robot = response.robots[0];
  EXPECT_EQ(robot.joint_state.position[jointIndex(robot, "finger2_joint")], kFinger);
  EXPECT_EQ(robot.joint_state.velocity[jointIndex(robot, "finger2_joint")],
            robot.joint_state.velocity[jointIndex(robot, "finger1_joint")]);
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_mimic_node");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  spinner.stop();
  return result;
}
