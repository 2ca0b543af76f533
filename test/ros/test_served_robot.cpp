// A ~robots entry's model and the request's robot state, without a ROS master (served_robot.h,
// robot_conversion.h, joint_state_cache.h): start-up errors name the parameter; joint states merge
// the request's values with the latest per joint; every bad value is named.
#include <gtest/gtest.h>
#include <ros/package.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "collision_response/core/body_response.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/rigid_body.h"
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

// --- One model shared by every request (docs/robots.md, "Model and data") ---------------------

namespace {

// The shipped 7-DOF arm (9 joints with the fingers), its palm's mesh replaced by a box so that no
// package path is needed (the geometry plays no part here).
std::string arm7Urdf() {
  std::ifstream file(ARM7_URDF);
  std::stringstream text;
  text << file.rdbuf();
  std::string urdf = text.str();
  const std::string mesh =
      R"(<mesh filename="package://collision_response/meshes/hand.stl" scale="0.001 0.001 0.001"/>)";
  for (std::size_t at = urdf.find(mesh); at != std::string::npos; at = urdf.find(mesh))
    urdf.replace(at, mesh.size(), R"(<box size="0.08 0.14 0.06"/>)");
  return urdf;
}

// What a request answers for the robot, every number the node reports or uses.
struct Answer {
  Eigen::MatrixXd mass_matrix;
  Eigen::VectorXd gravity_torques, velocity_after, joint_velocities_after;
  double impulse = 0.0, energy_before = 0.0;
  const cr::robot::RobotModel* model = nullptr;  // the model the request's body used
  bool operator==(const Answer& o) const {
    return mass_matrix == o.mass_matrix && gravity_torques == o.gravity_torques &&
           velocity_after == o.velocity_after &&
           joint_velocities_after == o.joint_velocities_after && impulse == o.impulse &&
           energy_before == o.energy_before;
  }
};

// Requests of one robot: each joint's position and velocity given, lock sets among none (the
// entry's), an empty override and several overrides.
std::vector<cr::RobotState> requests(const std::vector<std::string>& joints, int count) {
  const std::vector<std::vector<std::string>> lock_sets = {
      {},
      {"joint6", "joint7"},
      {"joint2"},
      {"left_finger_joint", "right_finger_joint"},
      {"joint1", "joint3", "joint5"}};
  std::mt19937 random(7);
  std::uniform_real_distribution<double> angle(-1.0, 1.0);
  std::vector<cr::RobotState> out;
  for (int r = 0; r < count; ++r) {
    cr::RobotState msg;
    msg.name = "arm";
    msg.joint_state.name = joints;
    for (std::size_t j = 0; j < joints.size(); ++j) {
      const bool finger = joints[j].find("finger") != std::string::npos;
      msg.joint_state.position.push_back(finger ? 0.02 + 0.01 * angle(random) : angle(random));
      msg.joint_state.velocity.push_back(finger ? 0.0 : angle(random));
    }
    msg.gravity.z = -9.81;
    msg.override_locked_joints = r % 6 != 0;  // every sixth keeps the entry's locks
    if (msg.override_locked_joints) msg.locked_joints = lock_sets[r % lock_sets.size()];
    out.push_back(msg);
  }
  return out;
}

// Prepares the request's robot as the node does, strikes its hand with a 1 kg box and answers.
Answer answer(const cr::ServedRobot& served, const cr::RobotState& msg) {
  cr::robot::ArticulatedBody arm = cr::robotAtRequestState(
      served, msg, Eigen::Isometry3d::Identity(), ros::Time(100.0), 0.5, "robots[0]");
  Answer out;
  out.model = arm.sharedModel().get();
  out.mass_matrix = arm.massMatrix();
  out.gravity_torques = arm.gravityTorques();
  out.energy_before = arm.kineticEnergy();
  const int hand = arm.linkIndex("hand");
  const Eigen::Isometry3d pose = arm.linkPose(hand);
  const Eigen::Vector3d n = pose.linear().col(0), p = pose * Eigen::Vector3d(0.04, 0, 0.03);
  cr::core::RigidBody box;
  box.inverse_mass = 1.0;
  box.inverse_inertia = Eigen::Matrix3d::Identity() * 600.0;
  box.com = p + 0.05 * n;
  box.linear_velocity = -2.0 * n;
  cr::core::ContactPoint contact(0, 1, p, n, 0.5, 0.3, 0.3);
  contact.part_a = hand;
  const cr::core::BodyResponse response = cr::core::computeBodyResponse({&arm, &box}, {contact});
  out.impulse = response.impulses[0].normal_impulse;
  out.velocity_after = arm.velocity();
  out.joint_velocities_after = arm.jointVelocities();
  return out;
}

cr::RobotParameters armEntry() {
  cr::RobotParameters p = entry();
  p.locked_joints = {"right_finger_joint"};
  p.armature["joint1"] = 0.1;
  return p;
}

}  // namespace

// Requests answered on four threads at once, each in its own order and many times over, give
// bit for bit the answers of the same requests answered one by one, and every request's body is
// a view of the one model the served robot holds.
TEST(SharedRobotModel, ConcurrentRequestsAnswerAsSequentialOnesOnOneModel) {
  const cr::ServedRobot served(armEntry(), arm7Urdf(), "~robots[0]");
  const std::vector<cr::RobotState> all = requests(served.model().jointNames(), 24);
  std::vector<Answer> sequential;
  for (const cr::RobotState& msg : all) sequential.push_back(answer(served, msg));
  // The requests differ: locks change the unknowns, states the numbers.
  EXPECT_NE(sequential[0].mass_matrix.rows(), sequential[1].mass_matrix.rows());
  EXPECT_NE(sequential[1].velocity_after, sequential[7].velocity_after);

  constexpr int kThreads = 4, kRounds = 60;
  std::vector<std::vector<std::pair<std::size_t, Answer>>> answers(kThreads);
  std::vector<std::string> errors(kThreads);  // an exception a thread met (none expected)
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      try {
        for (int round = 0; round < kRounds; ++round) {
          for (std::size_t k = 0; k < all.size(); ++k) {
            const std::size_t r = (k * (t + 1) + round + t) % all.size();  // a different order
            answers[t].emplace_back(r, answer(served, all[r]));
          }
        }
      } catch (const std::exception& e) {
        errors[t] = e.what();
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  for (int t = 0; t < kThreads; ++t) EXPECT_EQ(errors[t], "") << "thread " << t;
  int compared = 0;
  for (int t = 0; t < kThreads; ++t) {
    for (const auto& [r, a] : answers[t]) {
      EXPECT_TRUE(a == sequential[r]) << "thread " << t << ", request " << r;
      EXPECT_EQ(a.model, served.sharedModel().get()) << "thread " << t << ", request " << r;
      ++compared;
    }
  }
  EXPECT_EQ(compared, kThreads * kRounds * static_cast<int>(all.size()));
  for (const Answer& a : sequential) EXPECT_EQ(a.model, served.sharedModel().get());
}

// A request's locks are held in its data: the body shares the served robot's model (no copy), and
// its M is the free robot's with the locked joints' rows and columns struck out (a locked joint's
// subtree moves with its parent: the remaining unknowns see the same inertia), the same as a
// robot whose model locks those joints; the locked joints keep their velocities in a strike.
TEST(SharedRobotModel, LockedJointsOfARequestDoNotCopyTheModel) {
  cr::RobotParameters parameters = entry();
  const cr::ServedRobot served(parameters, arm7Urdf(), "~robots[0]");
  const std::vector<std::string>& joints = served.model().jointNames();
  cr::RobotState msg = requests(joints, 2)[1];
  msg.override_locked_joints = false;
  const cr::robot::ArticulatedBody free = cr::robotAtRequestState(
      served, msg, Eigen::Isometry3d::Identity(), ros::Time(100.0), 0.5, "robots[0]");
  msg.override_locked_joints = true;
  msg.locked_joints = {"joint2", "joint6", "left_finger_joint"};
  const long uses = served.sharedModel().use_count();
  const cr::robot::ArticulatedBody locked = cr::robotAtRequestState(
      served, msg, Eigen::Isometry3d::Identity(), ros::Time(100.0), 0.5, "robots[0]");
  EXPECT_EQ(locked.sharedModel().get(), served.sharedModel().get());
  EXPECT_EQ(free.sharedModel().get(), served.sharedModel().get());
  EXPECT_EQ(served.sharedModel().use_count(), uses + 1);  // one more view, no other model
  ASSERT_EQ(free.velocityCount(), 9);
  ASSERT_EQ(locked.velocityCount(), 6);

  std::vector<int> kept;
  for (int j = 0; j < free.jointCount(); ++j) {
    if (std::find(msg.locked_joints.begin(), msg.locked_joints.end(), joints[j]) ==
        msg.locked_joints.end())
      kept.push_back(free.unknownOfJoint(j));
  }
  Eigen::MatrixXd struck(kept.size(), kept.size());
  for (std::size_t a = 0; a < kept.size(); ++a)
    for (std::size_t b = 0; b < kept.size(); ++b)
      struck(a, b) = free.massMatrix()(kept[a], kept[b]);
  EXPECT_LT((locked.massMatrix() - struck).cwiseAbs().maxCoeff(), 1e-12 * struck.norm());

  // The same robot locked in its model (a model of its own, built apart).
  cr::robot::ArticulatedBody reference = cr::robot::robotFromUrdfString(arm7Urdf());
  for (const std::string& name : msg.locked_joints)
    reference.setJointModel(reference.jointIndex(name), cr::robot::JointModel::kLocked);
  reference.setState(locked.jointPositions(), locked.jointVelocities());
  EXPECT_LT((locked.massMatrix() - reference.massMatrix()).cwiseAbs().maxCoeff(),
            1e-12 * struck.norm());

  const Answer struck_answer = answer(served, msg);
  for (const std::string& name : msg.locked_joints) {
    const int j = free.jointIndex(name);
    EXPECT_EQ(struck_answer.joint_velocities_after(j), locked.jointVelocities()(j)) << name;
  }
  EXPECT_NE(struck_answer.joint_velocities_after(free.jointIndex("joint1")),
            locked.jointVelocities()(free.jointIndex("joint1")));
}
