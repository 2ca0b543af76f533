// Integration test: robots through ROS (docs/robots.md, "Robots through ROS"). The URDF is on the
// parameter server, joint states come from this test on /joint_states, tf from
// robot_state_publisher and a static world -> base_link transform (robot_node.test). The node's
// answers are compared with the core library's, given the same state: the robot library's model
// from the same URDF, the same rigid body, core::computeBodyResponse().
#include <collision_response/ComputeBatch.h>
#include <collision_response/ComputeEpisode.h>
#include <collision_response/ComputeResponse.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>
#include <visualization_msgs/MarkerArray.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <string>

#include "arm_strike.h"
#include "collision_response/core/body_impact_derivatives.h"
#include "collision_response/core/body_response.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/robot/joint_position_coordinates.h"
#include "collision_response/robot/urdf_loader.h"
#include "collision_response/ros/message_conversion.h"
#include "node_test_messages.h"

namespace cr = collision_response;
using namespace collision_response::testing;
using collision_response::toEigen;
using collision_response::toVector3;

namespace {

constexpr double kExact = 1e-12;  // the node and the core do the same arithmetic

// robot_node.test's static transform world -> base_link: x y z 0.5 -0.2 0.1, yaw 0.3.
Eigen::Isometry3d worldToBase() {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(0.5, -0.2, 0.1);
  pose.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return pose;
}

// What the test publishes on /joint_states (kArmJoints, model order).
const std::vector<std::string>& kJoints = kArmJoints;
const std::vector<double>& kPublishedPositions = kArmSwingPositions;
const std::vector<double>& kPublishedVelocities = kArmSwingVelocities;

// The arm from the URDF the node has (parsed once per base type).
cr::robot::ArticulatedBody referenceArm(bool floating = false) {
  static const auto parse = [](cr::robot::BaseType base) {
    std::string urdf;
    EXPECT_TRUE(ros::param::get("/robot_description", urdf));
    return cr::robot::robotFromUrdfString(urdf, base);
  };
  static const cr::robot::ArticulatedBody fixed = parse(cr::robot::BaseType::kFixed);
  static const cr::robot::ArticulatedBody free = parse(cr::robot::BaseType::kFloating);
  return floating ? free : fixed;
}

Eigen::VectorXd vector(const std::vector<double>& values) {
  return Eigen::Map<const Eigen::VectorXd>(values.data(), static_cast<int>(values.size()));
}

// Robot "arm" at rest at positions q (kJoints order), its whole joint state in the request.
cr::RobotState armAtRest(const std::vector<double>& q) {
  cr::RobotState robot;
  robot.name = "arm";
  robot.joint_state.name = kJoints;
  robot.joint_state.position = q;
  robot.joint_state.velocity.assign(kJoints.size(), 0.0);
  return robot;
}

// The core's answer for the same arm state, box and contact.
struct Reference {
  cr::robot::ArticulatedBody arm;
  cr::core::RigidBody box;
  cr::core::BodyResponse response;
};
Reference reference(cr::robot::ArticulatedBody arm, const cr::ComputeResponse& srv) {
  cr::core::BodyState state;
  const cr::BodyState& msg = srv.request.bodies[0];
  state.id = msg.id;
  state.mass = msg.inertia.m;
  state.inertia = Eigen::Vector3d(msg.inertia.ixx, msg.inertia.iyy, msg.inertia.izz).asDiagonal();
  state.position = toEigen(msg.pose.position);
  state.linear_velocity = toEigen(msg.twist.linear);
  state.angular_velocity = toEigen(msg.twist.angular);
  Reference ref{std::move(arm), cr::core::makeRigidBody(state), {}};
  const cr::Contact& c = srv.request.contacts[0];
  cr::core::ContactPoint point(0, 1, toEigen(c.point), toEigen(c.normal).normalized(),
                               c.restitution, c.static_friction, c.dynamic_friction);
  point.part_a = ref.arm.linkIndex("hand");
  ref.response = cr::core::computeBodyResponse({&ref.arm, &ref.box}, {point});
  return ref;
}

void expectMatches(const cr::ComputeResponse::Response& response, const Reference& ref) {
  ASSERT_TRUE(response.success) << response.message;
  ASSERT_EQ(response.robots.size(), 1u);
  const cr::RobotResult& robot = response.robots[0];
  EXPECT_EQ(robot.name, "arm");
  ASSERT_EQ(robot.joint_state.name, ref.arm.jointNames());
  ASSERT_EQ(robot.joint_state.velocity.size(), kJoints.size());
  for (int j = 0; j < ref.arm.jointCount(); ++j) {
    EXPECT_NEAR(robot.joint_state.velocity[j], ref.arm.jointVelocities()(j), kExact) << j;
    EXPECT_NEAR(robot.joint_state.position[j], ref.arm.jointPositions()(j), kExact) << j;
  }
  ASSERT_EQ(response.bodies.size(), 1u);
  EXPECT_NEAR(response.bodies[0].twist.linear.x, ref.box.linear_velocity.x(), kExact);
  EXPECT_NEAR(response.bodies[0].twist.linear.y, ref.box.linear_velocity.y(), kExact);
  EXPECT_NEAR(response.bodies[0].twist.linear.z, ref.box.linear_velocity.z(), kExact);
  ASSERT_EQ(response.impulses.size(), 1u);
  EXPECT_NEAR(response.impulses[0].normal_impulse, ref.response.impulses[0].normal_impulse, kExact);
  ASSERT_EQ(response.effective_masses.size(), 1u);
  EXPECT_NEAR(response.effective_masses[0], ref.response.effective_masses[0], kExact);
  // The contact separates (no warning that it is left approaching) and the impact does not create
  // energy.
  EXPECT_GT(response.impulses[0].normal_velocity_after, 0.0);
  for (const std::string& warning : response.warnings)
    EXPECT_EQ(warning.find("still approaching"), std::string::npos) << warning;
  EXPECT_LE(response.kinetic_energy_after, response.kinetic_energy_before * (1 + 1e-12));
}

class RobotNodeTest : public ServiceTest {
 protected:
  void SetUp() override {
    ServiceTest::SetUp();
    // The node has the joint states once an answer uses them.
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(20.0);
    cr::ComputeResponse probe = strikeRequest({Eigen::Vector3d(1, 0, 0), Eigen::Vector3d::UnitX()});
    probe.request.robots.resize(1);
    probe.request.robots[0].name = "arm";
    while (ros::WallTime::now() < deadline && !call(probe).success) ros::WallDuration(0.05).sleep();
  }

  // The arm at the published state, placed by the static transform.
  cr::robot::ArticulatedBody publishedArm() {
    cr::robot::ArticulatedBody arm = referenceArm();
    arm.setState(vector(kPublishedPositions), vector(kPublishedVelocities), worldToBase());
    return arm;
  }

  // A bad request is answered with success false naming `field`; a good one still succeeds.
  void expectRejected(const cr::ComputeResponse& srv, const std::string& field) {
    const auto response = ServiceTest::expectRejected(srv, field);
    EXPECT_TRUE(response.robots.empty());
    cr::ComputeResponse good = strikeRequest(strikeOf(publishedArm()));
    EXPECT_TRUE(call(good).success) << "node stopped serving after a bad request";
  }
};

TEST_F(RobotNodeTest, LatestJointStateAndTfBaseMatchTheCore) {
  const cr::robot::ArticulatedBody arm = publishedArm();
  cr::ComputeResponse srv = strikeRequest(strikeOf(arm));
  srv.request.robots.resize(1);
  srv.request.robots[0].name = "arm";  // joint state: the latest; base pose: tf
  const auto response = call(srv);
  expectMatches(response, reference(arm, srv));
  // The generalized impulse is M (v_after - v_before) = J^T P, P the contact impulse on the arm.
  const Reference ref = reference(arm, srv);
  const Eigen::Vector3d impulse_on_arm =
      -ref.response.impulses[0].total(toEigen(srv.request.contacts[0].normal).normalized());
  const Eigen::VectorXd expected =
      arm.linkPointJacobian(arm.linkIndex("hand"), toEigen(srv.request.contacts[0].point))
          .transpose() *
      impulse_on_arm;
  for (int j = 0; j < arm.jointCount(); ++j)
    EXPECT_NEAR(response.robots[0].joint_state.effort[j], expected(j), 1e-9) << j;
  EXPECT_EQ(response.robots[0].joint_state.header.frame_id, "world");
  EXPECT_EQ(response.robots[0].joint_state_before.velocity, kPublishedVelocities);
  EXPECT_EQ(response.robots[0].joint_state_before.position, kPublishedPositions);
  EXPECT_FALSE(response.robots[0].floating);
  EXPECT_NEAR(response.robots[0].base_pose.position.x, 0.5, 1e-12);
}

TEST_F(RobotNodeTest, FrictionlessStrikeMatchesTheClosedForm) {
  // Frictionless, through the box's centre: every law gives P = (1 + e) m_eff (-u_n) with
  // 1 / m_eff = n^T J M^-1 J^T n + 1 / m_box, and u_n after = -e u_n. J and M from the reference
  // model, the rest by hand.
  const cr::robot::ArticulatedBody arm = publishedArm();
  const Strike strike = strikeOf(arm);
  cr::ComputeResponse srv = strikeRequest(strike);
  srv.request.contacts[0].static_friction = srv.request.contacts[0].dynamic_friction = 0.0;
  const double e = srv.request.contacts[0].restitution;
  const Eigen::MatrixXd jacobian = arm.linkPointJacobian(arm.linkIndex("hand"), strike.point);
  const Eigen::MatrixXd w = jacobian * arm.massMatrix().inverse() * jacobian.transpose();
  const double effective_mass = 1.0 / (strike.normal.dot(w * strike.normal) + 1.0 / 2.0);
  const double u_n = -strike.normal.dot(jacobian * arm.velocity());  // box at rest
  ASSERT_LT(u_n, 0.0);
  const auto response = call(srv);
  ASSERT_TRUE(response.success) << response.message;
  ASSERT_EQ(response.effective_masses.size(), 1u);
  EXPECT_NEAR(response.effective_masses[0], effective_mass, 1e-9 * effective_mass);
  EXPECT_NEAR(response.impulses[0].normal_impulse, -(1 + e) * effective_mass * u_n,
              1e-9 * effective_mass * std::abs(u_n));
  EXPECT_NEAR(response.impulses[0].normal_velocity_before, u_n, 1e-12);
  EXPECT_NEAR(response.impulses[0].normal_velocity_after, -e * u_n, 1e-9 * std::abs(u_n));
  EXPECT_NEAR(toEigen(response.bodies[0].twist.linear).dot(strike.normal),
              response.impulses[0].normal_impulse / 2.0, 1e-12);
}

// Safety outputs through the service (docs/robots.md, "Safety outputs"). The frictionless strike
// through the box's centre: the arm's reflected mass 1 / (n^T J M^-1 J^T n) (J and M of the
// reference model), the box's its 2 kg (no lever arm), the approach speed -u_n and the energy
// 0.5 m_red u_n^2 with m_red = 1 / (n^T J M^-1 J^T n + 1 / 2); each joint's limit as arm7.urdf
// gives it (2.5 rad/s, the fingers 0.2 m/s); the joint impulses equal the efforts (no joint locked,
// no mimics). Then a 20 kg box thrown at the hand: exactly the joints whose |velocity| after the
// impact exceeds its limit are named in the warnings, "robots[0].joint_state.velocity[j]".
TEST_F(RobotNodeTest, SafetyOutputsThroughTheService) {
  const cr::robot::ArticulatedBody arm = publishedArm();
  const Strike strike = strikeOf(arm);
  cr::ComputeResponse srv = strikeRequest(strike);
  srv.request.contacts[0].static_friction = srv.request.contacts[0].dynamic_friction = 0.0;
  const Eigen::MatrixXd jacobian = arm.linkPointJacobian(arm.linkIndex("hand"), strike.point);
  const Eigen::VectorXd jn = jacobian.transpose() * strike.normal;
  const double w_arm = jn.dot(arm.massMatrix().inverse() * jn);
  const double u_n = -strike.normal.dot(jacobian * arm.velocity());  // box at rest
  ASSERT_LT(u_n, 0.0);
  const auto response = call(srv);
  ASSERT_TRUE(response.success) << response.message;
  ASSERT_EQ(response.reflected_masses_a.size(), 1u);
  ASSERT_EQ(response.reflected_masses_b.size(), 1u);
  ASSERT_EQ(response.approach_speeds.size(), 1u);
  ASSERT_EQ(response.transferred_energies.size(), 1u);
  EXPECT_NEAR(response.reflected_masses_a[0], 1.0 / w_arm, 1e-9 / w_arm);
  EXPECT_NEAR(response.reflected_masses_b[0], 2.0, 1e-9);
  EXPECT_NEAR(response.approach_speeds[0], -u_n, 1e-12);
  const double energy = 0.5 * u_n * u_n / (w_arm + 0.5);
  EXPECT_NEAR(response.transferred_energies[0], energy, 1e-9 * energy);
  ASSERT_EQ(response.robots.size(), 1u);
  const cr::RobotResult& robot = response.robots[0];
  ASSERT_EQ(robot.joint_velocity_limits.size(), kJoints.size());
  ASSERT_EQ(robot.joint_impulses.size(), kJoints.size());
  for (std::size_t j = 0; j < kJoints.size(); ++j) {
    EXPECT_EQ(robot.joint_velocity_limits[j], j < 7 ? 2.5 : 0.2) << kJoints[j];
    EXPECT_NEAR(robot.joint_impulses[j], robot.joint_state.effort[j], 1e-9) << kJoints[j];
  }

  const auto limit_warnings = [](const cr::ComputeResponse::Response& answer) {
    std::set<std::string> named;
    for (const std::string& warning : answer.warnings)
      if (warning.find(".joint_state.velocity[") != std::string::npos)
        named.insert(warning.substr(0, warning.find(':')));
    return named;
  };
  const auto beyond_limits = [](const cr::ComputeResponse::Response& answer) {
    std::set<std::string> joints;
    const cr::RobotResult& result = answer.robots.at(0);
    for (std::size_t j = 0; j < result.joint_state.velocity.size(); ++j)
      if (std::abs(result.joint_state.velocity[j]) > (j < 7 ? 2.5 : 0.2))
        joints.insert("robots[0].joint_state.velocity[" + std::to_string(j) + "]");
    return joints;
  };
  EXPECT_EQ(limit_warnings(response), beyond_limits(response));
  cr::ComputeResponse hard = strikeRequest(strike, 8.0);
  hard.request.bodies[0].inertia.m = 20.0;
  hard.request.bodies[0].inertia.ixx = hard.request.bodies[0].inertia.iyy =
      hard.request.bodies[0].inertia.izz = 20.0 * 0.01 / 6.0;
  const auto thrown = call(hard);
  ASSERT_TRUE(thrown.success) << thrown.message;
  const std::set<std::string> beyond = beyond_limits(thrown);
  ASSERT_FALSE(beyond.empty());
  EXPECT_EQ(limit_warnings(thrown), beyond);
}

TEST_F(RobotNodeTest, ContactNamingALinkIsEnough) {
  const cr::robot::ArticulatedBody arm = publishedArm();
  const cr::ComputeResponse srv = strikeRequest(strikeOf(arm));  // no robots field
  expectMatches(call(srv), reference(arm, srv));
}

// The hand striking the arm's own link3 (a contact between two links of one robot, no other body):
// the node gives the core's answer for the same state and contact, and the contact separates.
TEST_F(RobotNodeTest, TwoLinksOfTheArmStrikeEachOther) {
  cr::robot::ArticulatedBody arm = publishedArm();
  const int hand = arm.linkIndex("hand"), link3 = arm.linkIndex("link3");
  const Eigen::Vector3d p =
      0.5 * (arm.linkPose(hand).translation() + arm.linkPose(link3).translation());
  const Eigen::Vector3d relative = arm.partPointVelocity(link3, p) - arm.partPointVelocity(hand, p);
  ASSERT_GT(relative.norm(), 1e-3);
  const Eigen::Vector3d n = -relative.normalized();  // from the hand to link3, approaching
  cr::ComputeResponse srv = strikeRequest(strikeOf(arm));
  srv.request.bodies.clear();
  cr::Contact& c = srv.request.contacts[0];
  c.body_a = "arm/hand";
  c.body_b = "arm/link3";
  c.point = cr::toPoint(p);
  c.normal.x = n.x();
  c.normal.y = n.y();
  c.normal.z = n.z();
  const auto response = call(srv);
  ASSERT_TRUE(response.success) << response.message;

  cr::core::ContactPoint point(0, 0, p, n, c.restitution, c.static_friction, c.dynamic_friction);
  point.part_a = hand;
  point.part_b = link3;
  const cr::core::BodyResponse ref = cr::core::computeBodyResponse({&arm}, {point});
  ASSERT_EQ(response.robots.size(), 1u);
  for (int j = 0; j < arm.jointCount(); ++j) {
    EXPECT_NEAR(response.robots[0].joint_state.velocity[j], arm.jointVelocities()(j), kExact) << j;
  }
  ASSERT_EQ(response.impulses.size(), 1u);
  EXPECT_GT(response.impulses[0].normal_impulse, 0.0);
  EXPECT_NEAR(response.impulses[0].normal_impulse, ref.impulses[0].normal_impulse, kExact);
  EXPECT_NEAR(response.effective_masses[0], ref.effective_masses[0], kExact);
  EXPECT_GE(response.impulses[0].normal_velocity_after, -1e-9);
  EXPECT_LE(response.kinetic_energy_after, response.kinetic_energy_before * (1 + 1e-12));
}

TEST_F(RobotNodeTest, RequestJointStateIgnoresTheTopic) {
  const std::vector<double> q = {-0.3, 0.4, 0.5, -0.9, -0.2, 1.1, -0.4, 0.0, 0.02};
  const std::vector<double> qdot = {-0.4, 0.7, 0.2, -0.8, 0.3, 0.6, -0.2, 0.0, 0.0};
  cr::robot::ArticulatedBody arm = referenceArm();
  arm.setState(vector(q), vector(qdot), worldToBase());
  cr::ComputeResponse srv = strikeRequest(strikeOf(arm));
  srv.request.robots.resize(1);
  srv.request.robots[0].name = "arm";
  srv.request.robots[0].joint_state.name = kJoints;
  srv.request.robots[0].joint_state.position = q;
  srv.request.robots[0].joint_state.velocity = qdot;
  expectMatches(call(srv), reference(arm, srv));
}

TEST_F(RobotNodeTest, PartialJointStateTakesTheRestFromTheTopic) {
  std::vector<double> q = kPublishedPositions, qdot = kPublishedVelocities;
  q[3] = -1.5;
  qdot[1] = 0.9;
  cr::robot::ArticulatedBody arm = referenceArm();
  arm.setState(vector(q), vector(qdot), worldToBase());
  cr::ComputeResponse srv = strikeRequest(strikeOf(arm));
  srv.request.robots.resize(1);
  srv.request.robots[0].name = "arm";
  srv.request.robots[0].joint_state.name = {"joint4", "joint2"};
  srv.request.robots[0].joint_state.position = {-1.5, kPublishedPositions[1]};
  srv.request.robots[0].joint_state.velocity = {kPublishedVelocities[3], 0.9};
  expectMatches(call(srv), reference(arm, srv));
}

TEST_F(RobotNodeTest, LockedJointsOverride) {
  cr::robot::ArticulatedBody arm = referenceArm();
  arm.setJointModel(arm.jointIndex("joint2"), cr::robot::JointModel::kLocked);
  arm.setState(vector(kPublishedPositions), vector(kPublishedVelocities), worldToBase());
  cr::ComputeResponse srv = strikeRequest(strikeOf(arm));
  srv.request.robots.resize(1);
  srv.request.robots[0].name = "arm";
  srv.request.robots[0].override_locked_joints = true;
  srv.request.robots[0].locked_joints = {"joint2"};
  const auto response = call(srv);
  expectMatches(response, reference(arm, srv));
  // A locked joint keeps its velocity and reports no generalized impulse.
  EXPECT_EQ(response.robots[0].joint_state.velocity[1], kPublishedVelocities[1]);
  EXPECT_EQ(response.robots[0].joint_state.effort[1], 0.0);
}

TEST_F(RobotNodeTest, FloatingBaseConservesMomentum) {
  // A floating arm (its own topic, no messages: the request gives everything) strikes the box;
  // nothing else acts, so the total linear momentum of arm and box is conserved.
  cr::robot::ArticulatedBody arm = referenceArm(true);
  const Eigen::Vector3d base_v(0.3, -0.1, 0.2), base_w(0.1, 0.2, -0.3);
  arm.setState(vector(kPublishedPositions), vector(kPublishedVelocities), worldToBase(), base_v,
               base_w);
  const Strike strike = strikeOf(arm);
  cr::ComputeResponse srv = strikeRequest(strike);
  for (cr::Contact& c : srv.request.contacts) c.body_a = "floating_arm/hand";
  srv.request.robots.resize(1);
  cr::RobotState& robot = srv.request.robots[0];
  robot.name = "floating_arm";
  robot.joint_state.name = kJoints;
  robot.joint_state.position = kPublishedPositions;
  robot.joint_state.velocity = kPublishedVelocities;
  robot.base_pose = pose(0.5, -0.2, 0.1, Eigen::Quaterniond(worldToBase().linear()));
  robot.base_twist.linear = toVector3(base_v);
  robot.base_twist.angular = toVector3(base_w);
  const auto response = call(srv);
  ASSERT_TRUE(response.success) << response.message;
  ASSERT_EQ(response.robots.size(), 1u);
  EXPECT_TRUE(response.robots[0].floating);
  // The arm after: its model at the answer's state.
  cr::robot::ArticulatedBody after = arm;
  after.setState(vector(response.robots[0].joint_state.position),
                 vector(response.robots[0].joint_state.velocity), worldToBase(),
                 toEigen(response.robots[0].base_twist.linear),
                 toEigen(response.robots[0].base_twist.angular));
  const Eigen::Vector3d before = arm.momentum().head<3>();
  const Eigen::Vector3d box_after = 2.0 * toEigen(response.bodies[0].twist.linear);
  const Eigen::Vector3d total_after = after.momentum().head<3>() + box_after;
  EXPECT_NEAR((total_after - before).norm(), 0.0, 1e-9 * (1.0 + before.norm()));
  EXPECT_GT(response.impulses[0].normal_impulse, 0.0);
  EXPECT_GT(response.impulses[0].normal_velocity_after, 0.0);
}

// Derivatives with a robot (docs/robots.md, "Derivatives of robot impacts"): the frictionless
// strike through the box's centre under Newton: the block of the arm's joint velocities after by
// those before is I - (1 + e) M^-1 j^T j / (j M^-1 j^T + 1 / m_box) with j = n^T J(p) (J and M of
// the reference model), analytic, rows and columns labelled "robots[0].joint_state.velocity[j]";
// with friction, analytic too (Newton's closed form at one contact), the same labels.
TEST_F(RobotNodeTest, DerivativesWithRobotsThroughTheService) {
  const cr::robot::ArticulatedBody arm = publishedArm();
  const Strike strike = strikeOf(arm);
  cr::ComputeResponse srv = strikeRequest(strike);
  srv.request.contacts[0].static_friction = srv.request.contacts[0].dynamic_friction = 0.0;
  srv.request.options.law = cr::SolverOptions::LAW_NEWTON;
  srv.request.options.derivatives = true;
  const auto response = call(srv);
  ASSERT_TRUE(response.success) << response.message;
  const cr::ImpactDerivatives& d = response.derivatives;
  EXPECT_EQ(d.method, "analytic");
  const int joints = arm.jointCount();  // every joint free: one unknown each, model order
  ASSERT_EQ(d.rows, static_cast<uint32_t>(6 + joints + 4));  // box twist, joints, one contact
  ASSERT_EQ(d.columns, static_cast<uint32_t>(6 + joints + 3));
  ASSERT_EQ(d.jacobian.size(), static_cast<std::size_t>(d.rows) * d.columns);
  EXPECT_EQ(d.row_labels[0], "bodies[0].twist.linear.x");
  EXPECT_EQ(d.column_labels[6 + 3], "robots[0].joint_state.velocity[3]");
  EXPECT_EQ(d.row_labels[6 + joints], "impulses[0].normal_impulse");
  EXPECT_EQ(d.column_labels[6 + joints], "contacts[0].restitution");
  const double e = srv.request.contacts[0].restitution;
  const Eigen::MatrixXd j =
      strike.normal.transpose() * arm.linkPointJacobian(arm.linkIndex("hand"), strike.point);
  const Eigen::MatrixXd Minv = arm.massMatrix().inverse();
  const double w = (j * Minv * j.transpose())(0, 0) + 1.0 / 2.0;
  const Eigen::MatrixXd want =
      Eigen::MatrixXd::Identity(joints, joints) - (1 + e) * Minv * j.transpose() * j / w;
  for (int r = 0; r < joints; ++r)
    for (int k = 0; k < joints; ++k)
      EXPECT_NEAR(d.jacobian[(6 + r) * d.columns + 6 + k], want(r, k), 1e-9) << r << ", " << k;

  srv.request.contacts[0].static_friction = 0.5;
  srv.request.contacts[0].dynamic_friction = 0.4;
  const auto frictional = call(srv);
  ASSERT_TRUE(frictional.success) << frictional.message;
  EXPECT_EQ(frictional.derivatives.method, "analytic");
  EXPECT_EQ(frictional.derivatives.column_labels, d.column_labels);
  ASSERT_EQ(frictional.derivatives.contacts.size(), 1u);
  EXPECT_EQ(frictional.derivatives.contacts[0].method, "analytic");

  // The joint positions' columns on request (options.joint_position_derivatives), appended after
  // the coefficients' (the others unchanged): against the library's own call here on the same
  // arm and box (robot/joint_position_coordinates.h; the physics is checked in
  // test_robot_derivatives against closed forms).
  srv.request.options.joint_position_derivatives = true;
  const auto with_q = call(srv);
  ASSERT_TRUE(with_q.success) << with_q.message;
  const cr::ImpactDerivatives& dq = with_q.derivatives;
  EXPECT_EQ(frictional.derivatives.joint_position_method, "");
  EXPECT_EQ(dq.joint_position_method, "analytic");  // Newton's closed form at one contact
  ASSERT_EQ(dq.rows, frictional.derivatives.rows);
  ASSERT_EQ(dq.columns, static_cast<uint32_t>(6 + joints + 3 + joints));
  for (int k = 0; k < joints; ++k) {
    EXPECT_EQ(dq.column_labels[6 + joints + 3 + k],
              "robots[0].joint_state.position[" + std::to_string(k) + "]");
  }
  for (uint32_t r = 0; r < dq.rows; ++r) {
    for (uint32_t k = 0; k < frictional.derivatives.columns; ++k) {
      EXPECT_EQ(dq.jacobian[r * dq.columns + k],
                frictional.derivatives.jacobian[r * frictional.derivatives.columns + k]);
    }
  }
  cr::robot::ArticulatedBody library_arm = publishedArm();
  cr::core::RigidBody box;
  box.inverse_mass = 0.5;
  box.inverse_inertia = Eigen::Matrix3d::Identity() * 6.0 / (2.0 * 0.01);
  box.com = strike.point + 0.05 * strike.normal;
  cr::core::ContactPoint contact(0, 1, strike.point, strike.normal, 0.4, 0.5, 0.4);
  contact.part_a = library_arm.linkIndex("hand");
  cr::core::SolverOptions newton;
  newton.law = cr::core::ImpactLaw::kNewton;
  const cr::core::BodyImpactDerivatives library = cr::core::computeBodyImpactDerivatives(
      {&library_arm, &box}, {contact}, newton, cr::robot::jointPositionCoordinates(library_arm));
  // Library rows: the arm's unknowns, the box's twist, the impulse; the service's: the box first.
  for (int k = 0; k < joints; ++k) {
    const uint32_t column = 6 + joints + 3 + k;
    const Eigen::Index library_column = joints + 6 + 3 + k;
    const double scale = std::max(1.0, library.jacobian.col(library_column).cwiseAbs().maxCoeff());
    for (int r = 0; r < joints; ++r) {
      EXPECT_NEAR(dq.jacobian[(6 + r) * dq.columns + column], library.jacobian(r, library_column),
                  1e-6 * scale)
          << "joint velocity " << r << " by position " << k;
    }
    for (int r = 0; r < 6; ++r) {
      EXPECT_NEAR(dq.jacobian[r * dq.columns + column],
                  library.jacobian(joints + r, library_column), 1e-6 * scale)
          << "box twist " << r << " by position " << k;
    }
  }

  // Without derivatives, the flag is ignored and said so.
  srv.request.options.derivatives = false;
  const auto ignored = call(srv);
  ASSERT_TRUE(ignored.success) << ignored.message;
  EXPECT_TRUE(ignored.derivatives.jacobian.empty());
  bool warned = false;
  for (const std::string& warning : ignored.warnings)
    warned = warned || warning.find("options.joint_position_derivatives") != std::string::npos;
  EXPECT_TRUE(warned);
}

// The fraction of e in [a, b] (t = (e - a) / (b - a) in [0, 1]) with |x0 + t (x1 - x0)| > limit.
double exceedingFraction(double x0, double x1, double limit) {
  const double d = x1 - x0;
  auto measure = [&](double level, bool above) {
    if (d == 0.0) return (above ? x0 > level : x0 < level) ? 1.0 : 0.0;
    const double t = (level - x0) / d;
    double lo = 0.0, hi = 1.0;
    if (above == (d > 0.0))
      lo = std::max(lo, t);
    else
      hi = std::min(hi, t);
    return std::max(0.0, hi - lo);
  };
  return measure(limit, true) + measure(-limit, false);
}

// Frictionless, Newton's law, one contact: the joint velocities after are affine in e. With e
// uniform on [a, b], the sampled distribution through the service against two deterministic
// calls at e = a and e = b: mean (their average), variance (d^2 / 12), limit probabilities (the
// exact fraction of [a, b] beyond each URDF limit); then the linear method against the same two
// calls.
TEST_F(RobotNodeTest, SampledUncertaintyWithRobotsThroughTheService) {
  const cr::robot::ArticulatedBody arm = publishedArm();
  const Strike strike = strikeOf(arm);
  cr::ComputeResponse srv = strikeRequest(strike, 8.0);  // heavy and fast: joints leave limits
  srv.request.bodies[0].inertia.m = 20.0;
  srv.request.bodies[0].inertia.ixx = srv.request.bodies[0].inertia.iyy =
      srv.request.bodies[0].inertia.izz = 20.0 * 0.01 / 6.0;
  srv.request.contacts[0].static_friction = srv.request.contacts[0].dynamic_friction = 0.0;
  srv.request.options.law = cr::SolverOptions::LAW_NEWTON;
  srv.request.robots = {armAtRest(kArmSwingPositions)};
  srv.request.robots[0].joint_state.velocity = kArmSwingVelocities;
  constexpr double a = 0.2, b = 0.8;
  auto at = [&](double e) {
    cr::ComputeResponse fixed = srv;
    fixed.request.contacts[0].restitution = e;
    const auto answer = call(fixed);
    EXPECT_TRUE(answer.success) << answer.message;
    return answer.robots.at(0).joint_state.velocity;
  };
  const std::vector<double> qa = at(a), qb = at(b);
  ASSERT_EQ(qa.size(), kJoints.size());

  srv.request.contacts[0].restitution = 0.5;
  srv.request.options.uncertainty = cr::SolverOptions::UNCERTAINTY_SAMPLED;
  srv.request.options.uncertainty_samples = 4096;
  cr::ContactUncertainty u;
  u.contact = 0;
  u.restitution.type = cr::Distribution::TYPE_INTERVAL;
  u.restitution.min = a;
  u.restitution.max = b;
  srv.request.uncertainties = {u};
  const auto response = call(srv);
  ASSERT_TRUE(response.success) << response.message;
  const cr::OutcomeDistribution& d = response.outcome_distribution;
  EXPECT_EQ(d.method, "sampled");
  const std::size_t joints = kJoints.size();
  const std::size_t n = 6 + joints + 4;  // the box's twist, the joints, one contact
  ASSERT_EQ(d.labels.size(), n);
  EXPECT_EQ(d.labels[0], "bodies[0].twist.linear.x");
  EXPECT_EQ(d.labels[6 + 3], "robots[0].joint_state.velocity[3]");
  EXPECT_EQ(d.labels[6 + joints], "impulses[0].normal_impulse");
  ASSERT_EQ(d.mean.size(), n);
  ASSERT_EQ(d.covariance.size(), n * n);
  ASSERT_EQ(d.joint_limit_labels.size(), joints);  // every joint of the arm has a limit
  ASSERT_EQ(d.joint_limit_probability.size(), joints);
  double range = 0.0;
  for (std::size_t j = 0; j < joints; ++j) range = std::max(range, std::abs(qb[j] - qa[j]));
  bool some_crossing = false;
  for (std::size_t j = 0; j < joints; ++j) {
    SCOPED_TRACE(kJoints[j]);
    const std::size_t r = 6 + j;
    EXPECT_EQ(d.joint_limit_labels[j], d.labels[r]);
    EXPECT_NEAR(d.mean[r], 0.5 * (qa[j] + qb[j]), 1e-3 * range);
    const double dj = qb[j] - qa[j];
    EXPECT_NEAR(d.covariance[r * n + r], dj * dj / 12.0, 2e-3 * range * range / 12.0);
    const double exact = exceedingFraction(qa[j], qb[j], j < 7 ? 2.5 : 0.2);
    EXPECT_NEAR(d.joint_limit_probability[j], exact, 2e-3);
    some_crossing |= exact > 0.05 && exact < 0.95;
  }
  EXPECT_TRUE(some_crossing) << "no joint crosses its limit inside [a, b]: the check is weak";

  // The linear method through the service: the map is affine in e, so the linear mean is the
  // prediction at e's mean, (qa + qb) / 2, and its variance exactly that of the uniform e, d^2 /
  // 12 (to round-off); the limit probabilities are the normal tails P(|x| > L) of N(mean, d^2 /
  // 12), computed here from erfc.
  srv.request.options.uncertainty = cr::SolverOptions::UNCERTAINTY_LINEAR;
  const auto linear = call(srv);
  ASSERT_TRUE(linear.success) << linear.message;
  const cr::OutcomeDistribution& l = linear.outcome_distribution;
  EXPECT_EQ(l.method, "linear");
  EXPECT_EQ(l.samples, 0u);
  EXPECT_EQ(l.labels, d.labels);
  ASSERT_EQ(l.mean.size(), n);
  ASSERT_EQ(l.covariance.size(), n * n);
  ASSERT_EQ(l.joint_limit_labels, d.joint_limit_labels);
  ASSERT_EQ(l.joint_limit_probability.size(), joints);
  bool some_tail = false;
  for (std::size_t j = 0; j < joints; ++j) {
    SCOPED_TRACE(kJoints[j]);
    const std::size_t r = 6 + j;
    const double mean = 0.5 * (qa[j] + qb[j]);
    const double dj = qb[j] - qa[j];
    EXPECT_NEAR(l.mean[r], mean, 1e-9 * (1.0 + range));
    EXPECT_NEAR(l.covariance[r * n + r], dj * dj / 12.0, 1e-9 * (1.0 + range * range));
    const double sigma = std::abs(dj) / std::sqrt(12.0);
    const double limit = j < 7 ? 2.5 : 0.2;
    const double tail = sigma == 0.0
                            ? (std::abs(mean) > limit ? 1.0 : 0.0)
                            : 0.5 * std::erfc((limit + mean) / (sigma * std::sqrt(2.0))) +
                                  0.5 * std::erfc((limit - mean) / (sigma * std::sqrt(2.0)));
    EXPECT_NEAR(l.joint_limit_probability[j], tail, 1e-6);
    some_tail |= tail > 0.05 && tail < 0.95;
  }
  EXPECT_TRUE(some_tail) << "no joint's tail is strictly inside (0, 1): the check is weak";
}

TEST_F(RobotNodeTest, BadRobotInputIsNamed) {
  const Strike strike = strikeOf(publishedArm());
  {
    cr::ComputeResponse srv = strikeRequest(strike);
    srv.request.robots.resize(1);
    srv.request.robots[0].name = "no_such_robot";
    expectRejected(srv, "robots[0].name");
  }
  {
    cr::ComputeResponse srv = strikeRequest(strike);
    srv.request.contacts[0].body_a = "arm/no_such_link";
    srv.request.robots.resize(1);
    srv.request.robots[0].name = "arm";
    expectRejected(srv, "contacts[0].body_a");
  }
  {
    cr::ComputeResponse srv = strikeRequest(strike);
    srv.request.robots.resize(1);
    srv.request.robots[0].name = "arm";
    srv.request.robots[0].joint_state.name = {"joint1", "no_such_joint"};
    srv.request.robots[0].joint_state.position = {0.0, 0.0};
    expectRejected(srv, "robots[0].joint_state.name[1]");
  }
  {
    cr::ComputeResponse srv = strikeRequest(strike);
    srv.request.robots.resize(1);
    srv.request.robots[0].name = "arm";
    srv.request.robots[0].joint_state.name = {"joint1", "joint2"};
    srv.request.robots[0].joint_state.velocity = {0.0};
    expectRejected(srv, "robots[0].joint_state.velocity");
  }
  {
    cr::ComputeResponse srv = strikeRequest(strike);
    srv.request.robots.resize(1);
    srv.request.robots[0].name = "arm";
    srv.request.robots[0].joint_state.name = {"joint3"};
    srv.request.robots[0].joint_state.velocity = {std::numeric_limits<double>::quiet_NaN()};
    expectRejected(srv, "robots[0].joint_state.velocity[0]");
  }
  {
    cr::ComputeResponse srv = strikeRequest(strike);
    srv.request.robots.resize(1);
    srv.request.robots[0].name = "arm";
    srv.request.robots[0].override_locked_joints = true;
    srv.request.robots[0].locked_joints = {"hand_joint"};  // fixed: no coordinate
    expectRejected(srv, "robots[0].locked_joints[0]");
  }
  {
    // quiet_arm's topic has no publisher: nothing to take missing joints from.
    cr::ComputeResponse srv = strikeRequest(strike);
    srv.request.contacts[0].body_a = "quiet_arm/hand";
    srv.request.robots.resize(1);
    srv.request.robots[0].name = "quiet_arm";
    srv.request.robots[0].joint_state.name = {"joint1"};
    srv.request.robots[0].joint_state.position = {0.0};
    srv.request.robots[0].joint_state.velocity = {0.0};
    const auto response = call(srv);
    EXPECT_FALSE(response.success);
    EXPECT_NE(response.message.find("robots[0].joint_state"), std::string::npos)
        << response.message;
    EXPECT_NE(response.message.find("none received on /quiet_joint_states"), std::string::npos)
        << response.message;
  }
  {
    cr::ComputeResponse srv = strikeRequest(strike);
    srv.request.robots.resize(1);
    srv.request.robots[0].name = "arm";
    srv.request.robots[0].base_pose.orientation.w = 2.0;  // not unit
    expectRejected(srv, "robots[0].base_pose.orientation");
  }
  {
    // A position with the message's default (all-zero) quaternion: half a pose, refused rather
    // than replaced by tf's base (an all-zero base_pose is "not given").
    cr::ComputeResponse srv = strikeRequest(strike);
    srv.request.robots.resize(1);
    srv.request.robots[0].name = "arm";
    srv.request.robots[0].base_pose.position.x = 0.5;
    expectRejected(srv, "robots[0].base_pose.orientation");
  }
}

// quiet_arm's topic never had a message: the request gives every position and no velocity. The
// documented behaviour: the joints are taken at rest with a warning that says nothing was ever
// received (no staleness check on a sample that never came). The answer is the core's for the arm
// at rest at those positions.
TEST_F(RobotNodeTest, VelocityNeverReceivedIsTakenAtRestWithAWarning) {
  const std::vector<double> q = {-0.3, 0.4, 0.5, -0.9, -0.2, 1.1, -0.4, 0.0, 0.02};
  cr::robot::ArticulatedBody arm = referenceArm();
  arm.setState(vector(q), Eigen::VectorXd::Zero(arm.jointCount()), worldToBase());
  // The arm at rest: the box comes at the hand along the hand's z axis.
  const int hand = arm.linkIndex("hand");
  const Strike strike{arm.linkPose(hand) * Eigen::Vector3d(0, 0, 0.04),
                      arm.linkPose(hand).linear() * Eigen::Vector3d::UnitZ()};
  cr::ComputeResponse srv = strikeRequest(strike, 1.0);
  srv.request.contacts[0].body_a = "quiet_arm/hand";
  srv.request.robots.resize(1);
  srv.request.robots[0].name = "quiet_arm";
  srv.request.robots[0].joint_state.name = kJoints;
  srv.request.robots[0].joint_state.position = q;
  srv.request.robots[0].base_pose =
      pose(0.5, -0.2, 0.1, Eigen::Quaterniond(worldToBase().linear()));
  const auto response = call(srv);
  ASSERT_TRUE(response.success) << response.message;
  ASSERT_EQ(response.warnings.size(), 1u);
  EXPECT_NE(response.warnings[0].find("robots[0].joint_state: no velocity in the request, and "
                                      "none ever received on /quiet_joint_states"),
            std::string::npos)
      << response.warnings[0];
  EXPECT_EQ(response.warnings[0].find(" s old"), std::string::npos) << response.warnings[0];
  const Reference ref = reference(arm, srv);
  ASSERT_EQ(response.robots.size(), 1u);
  for (int j = 0; j < ref.arm.jointCount(); ++j) {
    EXPECT_EQ(response.robots[0].joint_state_before.velocity[j], 0.0) << j;
    EXPECT_NEAR(response.robots[0].joint_state.velocity[j], ref.arm.jointVelocities()(j), kExact)
        << j;
  }
  EXPECT_NEAR(response.impulses[0].normal_impulse, ref.response.impulses[0].normal_impulse, kExact);
  EXPECT_GT(response.impulses[0].normal_velocity_after, 0.0);
}

// Every joint locked, the fixed-base arm moving into an immovable wall: no impulse can change the
// hand's velocity along the normal (effective mass infinite), so the answer leaves the contact
// approaching at the hand's own normal speed, -|v_hand| (the normal is along v_hand), and says so.
TEST_F(RobotNodeTest, LockedArmIntoAWallIsLeftApproachingAndWarned) {
  const cr::robot::ArticulatedBody arm = publishedArm();
  const Strike strike = strikeOf(arm);
  const double hand_speed =
      arm.partPointVelocity(arm.linkIndex("hand"), strike.point).norm();  // v = J qdot
  ASSERT_GT(hand_speed, 0.1);
  cr::ComputeResponse srv = strikeRequest(strike);
  srv.request.bodies[0].inertia = geometry_msgs::Inertia();  // the wall: immovable, at rest
  srv.request.robots.resize(1);
  srv.request.robots[0].name = "arm";
  srv.request.robots[0].override_locked_joints = true;
  srv.request.robots[0].locked_joints = kJoints;
  const auto response = call(srv);
  ASSERT_TRUE(response.success) << response.message;
  EXPECT_EQ(response.impulses[0].normal_impulse, 0.0);
  EXPECT_NEAR(response.impulses[0].normal_velocity_after, -hand_speed, 1e-12);
  EXPECT_TRUE(std::isinf(response.effective_masses[0]));
  ASSERT_EQ(response.warnings.size(), 1u);
  EXPECT_EQ(response.warnings[0].rfind("contacts[0]: still approaching at", 0), 0u)
      << response.warnings[0];
  EXPECT_NE(response.warnings[0].find("no impulse along the normal can move it"), std::string::npos)
      << response.warnings[0];
  // Unlocked, the same strike is resolved: nothing left approaching (the rebound may throw a
  // joint beyond its velocity limit: that warning alone may come, "Safety outputs").
  srv.request.robots[0].override_locked_joints = false;
  const auto unlocked = call(srv);
  ASSERT_TRUE(unlocked.success) << unlocked.message;
  EXPECT_GE(unlocked.impulses[0].normal_velocity_after, 0.0);
  for (const std::string& warning : unlocked.warnings)
    EXPECT_NE(warning.find("leaves its velocity limit"), std::string::npos) << warning;
}

// Resting contacts through the node: the arm at rest at the published positions, its hand on a
// table (n = +z, request frame "world"), gravity mostly along -z. Its joint torques
// (joint_state.effort under JOINT_TORQUES_EFFORT) are gravity compensation plus the torques of a
// push F0 = 20 N into the table, tau = g(q) - J(p)^T n F0 (from the reference model): the table
// pushes back with exactly F0 (statics), and no velocity changes. Gravity compensation alone (the
// default) rests the hand on the table without pressing. Bad values are named.
TEST_F(RobotNodeTest, HandPushingOnATableFeelsItsOwnPush) {
  cr::robot::ArticulatedBody arm = referenceArm();
  const Eigen::VectorXd q = vector(kPublishedPositions);
  arm.setState(q, Eigen::VectorXd::Zero(q.size()), worldToBase());
  const int hand = arm.linkIndex("hand");
  const Eigen::Vector3d p = arm.linkPose(hand) * Eigen::Vector3d(0, 0, 0.03);
  // Gravity oblique to the base's axes (the base is turned about z): a mix-up of the request frame
  // and the base frame would show.
  const Eigen::Vector3d gravity(1.2, -0.7, -9.7);
  arm.setLoads(Eigen::VectorXd::Zero(q.size()), gravity);
  const double f0 = 20.0;
  const Eigen::VectorXd gravity_torques = arm.gravityTorques();
  const Eigen::VectorXd tau =
      gravity_torques - arm.linkPointJacobian(hand, p).transpose() * Eigen::Vector3d::UnitZ() * f0;

  cr::ComputeResponse srv;
  srv.request.header.frame_id = "world";
  cr::BodyState table;
  table.id = "table";
  table.pose.orientation.w = 1.0;
  srv.request.bodies = {table};
  srv.request.contacts = {
      contact("table", "arm/hand", p.x(), p.y(), p.z(), 0, 0, 1, 0.0, 0.5, 0.5)};
  srv.request.robots = {armAtRest(kPublishedPositions)};
  cr::RobotState& robot = srv.request.robots[0];
  robot.joint_state.effort.assign(tau.data(), tau.data() + tau.size());
  robot.gravity = toVector3(gravity);
  robot.joint_torques = cr::RobotState::JOINT_TORQUES_EFFORT;
  auto response = call(srv);
  ASSERT_TRUE(response.success) << response.message;
  ASSERT_EQ(response.impulses.size(), 1u);
  EXPECT_TRUE(response.impulses[0].resting);
  EXPECT_NEAR(response.impulses[0].normal_force, f0, 1e-9);
  EXPECT_EQ(response.impulses[0].normal_impulse, 0.0);
  ASSERT_EQ(response.islands.size(), 1u);
  EXPECT_EQ(response.islands[0].method, "resting_closed_form");
  ASSERT_EQ(response.robots.size(), 1u);
  for (const double v : response.robots[0].joint_state.velocity) EXPECT_EQ(v, 0.0);
  // Statics: the actuators' torques and the contact's hold the arm against gravity,
  // tau + J^T F = g(q).
  ASSERT_EQ(response.robots[0].contact_joint_torques.size(), kJoints.size());
  for (std::size_t j = 0; j < kJoints.size(); ++j) {
    EXPECT_NEAR(tau(j) + response.robots[0].contact_joint_torques[j], gravity_torques(j), 1e-9)
        << kJoints[j];
  }

  robot.joint_torques = cr::RobotState::JOINT_TORQUES_GRAVITY_COMPENSATION;
  response = call(srv);
  ASSERT_TRUE(response.success) << response.message;
  EXPECT_TRUE(response.impulses[0].resting);
  EXPECT_LE(response.impulses[0].normal_force, 1e-9);

  {
    cr::ComputeResponse bad = srv;
    bad.request.robots[0].joint_torques = 7;
    expectRejected(bad, "robots[0].joint_torques");
  }
  {
    cr::ComputeResponse bad = srv;
    bad.request.robots[0].joint_torques = cr::RobotState::JOINT_TORQUES_EFFORT;
    bad.request.robots[0].joint_state.effort.pop_back();
    expectRejected(bad, "robots[0].joint_state.effort");
  }
  {
    // /joint_states carries no effort: a joint whose effort the request leaves out has none.
    cr::ComputeResponse bad = srv;
    bad.request.robots[0].joint_torques = cr::RobotState::JOINT_TORQUES_EFFORT;
    bad.request.robots[0].joint_state.effort.clear();
    const auto rejected = ServiceTest::expectRejected(bad, "robots[0].joint_state.effort");
    EXPECT_NE(rejected.message.find("has no effort"), std::string::npos) << rejected.message;
  }
  {
    cr::ComputeResponse bad = srv;
    bad.request.robots[0].gravity.x = std::numeric_limits<double>::quiet_NaN();
    expectRejected(bad, "robots[0].gravity.x");
  }
}

TEST_F(RobotNodeTest, StaleJointStateIsRejected) {
  // stale_arm's latest message is 5 s old (~joint_state_timeout 2 s).
  ros::Publisher stale = node_.advertise<sensor_msgs::JointState>("/stale_joint_states", 1, true);
  sensor_msgs::JointState msg;
  msg.header.stamp = ros::Time::now() - ros::Duration(5.0);
  msg.name = kJoints;
  msg.position = kPublishedPositions;
  msg.velocity = kPublishedVelocities;
  stale.publish(msg);
  cr::ComputeResponse srv = strikeRequest(strikeOf(publishedArm()));
  srv.request.contacts[0].body_a = "stale_arm/hand";
  srv.request.robots.resize(1);
  srv.request.robots[0].name = "stale_arm";
  // Wait until the node has the message: the error changes from "none received" to "old".
  cr::ComputeResponse::Response response;
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(10.0);
  do {
    response = call(srv);
    if (response.message.find("s old") != std::string::npos) break;
    ros::WallDuration(0.05).sleep();
  } while (ros::WallTime::now() < deadline);
  EXPECT_FALSE(response.success);
  EXPECT_NE(response.message.find("robots[0].joint_state"), std::string::npos) << response.message;
  EXPECT_NE(response.message.find("~joint_state_timeout"), std::string::npos) << response.message;
  EXPECT_TRUE(call(strikeRequest(strikeOf(publishedArm()))).success);
}

TEST_F(RobotNodeTest, AnswerIsPublishedWithTheRobots) {
  ResponsesListener listener(node_);
  ASSERT_TRUE(listener.waitForPublisher(10.0));
  const cr::ComputeResponse srv = strikeRequest(strikeOf(publishedArm()));
  ASSERT_TRUE(call(srv).success);
  const auto published = listener.waitForMessage(10.0);
  ASSERT_TRUE(published);
  ASSERT_EQ(published->robots.size(), 1u);
  EXPECT_EQ(published->robots[0].name, "arm");
  EXPECT_EQ(published->robots[0].joint_state.name.size(), kJoints.size());
}

TEST_F(RobotNodeTest, MarkersCarryTheLinksFrames) {
  std::mutex mutex;
  visualization_msgs::MarkerArray::ConstPtr latest;
  ros::Subscriber markers = node_.subscribe<visualization_msgs::MarkerArray>(
      "/collision_response/markers", 1, [&](const visualization_msgs::MarkerArray::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(mutex);
        latest = m;
      });
  const ros::WallTime connected = ros::WallTime::now() + ros::WallDuration(10.0);
  while (markers.getNumPublishers() == 0 && ros::WallTime::now() < connected)
    ros::WallDuration(0.01).sleep();
  ros::WallDuration(0.2).sleep();  // the node sees the subscriber
  const cr::robot::ArticulatedBody arm = publishedArm();
  const Strike strike = strikeOf(arm);
  ASSERT_TRUE(call(strikeRequest(strike)).success);
  // The contact in the hand's frame: hand_T_world p, with the hand's pose from the reference.
  const Eigen::Vector3d in_hand = arm.linkPose(arm.linkIndex("hand")).inverse() * strike.point;
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(10.0);
  bool found = false;
  while (!found && ros::WallTime::now() < deadline) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (latest) {
        for (const visualization_msgs::Marker& m : latest->markers) {
          if (m.ns != "robot_contact_points") continue;
          found = true;
          EXPECT_EQ(m.header.frame_id, "hand");
          EXPECT_NEAR((toEigen(m.pose.position) - in_hand).norm(), 0.0, 1e-9);
        }
        bool impulse_in_hand = false;
        for (const visualization_msgs::Marker& m : latest->markers)
          impulse_in_hand |= m.ns == "contact_impulses" && m.header.frame_id == "hand";
        if (found) {
          EXPECT_TRUE(impulse_in_hand);
        }
      }
    }
    ros::WallDuration(0.02).sleep();
  }
  EXPECT_TRUE(found) << "no robot contact marker";
}

TEST_F(RobotNodeTest, FingerPadsOnATableFromTheUrdfGeometry) {
  // The left finger's frame placed pointing straight down (its pad box, 2 x 1 x 5 cm, reaches 5 cm
  // along the finger's z) 0.1 mm into a table top at z = 0: the arm's base pose follows from the
  // reference kinematics. The table (20 kg) rises at 0.5 m/s into the resting fingers.
  const std::vector<double> q = {0.3, 0.2, -0.4, 0.3, 0.5, -0.3, 0.7, 0.015, 0.02};
  cr::robot::ArticulatedBody arm = referenceArm();
  arm.setState(vector(q), Eigen::VectorXd::Zero(arm.jointCount()));
  Eigen::Isometry3d finger_wanted = Eigen::Isometry3d::Identity();
  finger_wanted.translation() = Eigen::Vector3d(0.4, -0.1, 0.05 - 1e-4);
  finger_wanted.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Isometry3d base =
      finger_wanted * arm.linkPose(arm.linkIndex("left_finger")).inverse();

  cr::ComputeResponse srv;
  srv.request.header.frame_id = "world";
  cr::BodyState table;
  table.id = "table";
  table.inertia.m = 20.0;
  table.inertia.ixx = table.inertia.iyy = 20.0 * (1.0 + 0.01) / 12.0;
  table.inertia.izz = 20.0 * 2.0 / 12.0;
  table.pose = pose(0.4, -0.1, -0.05);
  table.twist.linear.z = 0.5;
  shape_msgs::SolidPrimitive top;
  top.type = shape_msgs::SolidPrimitive::BOX;
  top.dimensions = {1.0, 1.0, 0.1};
  table.primitives = {top};
  table.primitive_poses = {pose(0, 0, 0)};
  srv.request.bodies = {table};
  srv.request.detection.mode = cr::DetectionOptions::MODE_ALWAYS;
  srv.request.detection.restitution = 0.3;
  srv.request.robots = {armAtRest(q)};
  cr::RobotState& robot = srv.request.robots[0];
  const Eigen::Quaterniond base_rotation(base.linear());
  robot.base_pose =
      pose(base.translation().x(), base.translation().y(), base.translation().z(), base_rotation);
  const auto response = call(srv);
  ASSERT_TRUE(response.success) << response.message;
  std::map<std::string, int> per_link;
  for (std::size_t k = 0; k < response.detected_contacts.size(); ++k) {
    const cr::Contact& c = response.detected_contacts[k];
    const std::string link = c.body_a == "table" ? c.body_b : c.body_a;
    ++per_link[link];
    EXPECT_NEAR(std::abs(c.normal.z), 1.0, 1e-9) << link;
    EXPECT_NEAR(c.point.z, -5e-5, 1e-9) << link;  // midway through the 0.1 mm overlap
    EXPECT_NEAR(response.detected_depths[k], 1e-4, 1e-9) << link;
    EXPECT_GE(response.impulses[k].normal_impulse, 0.0);
  }
  EXPECT_EQ(per_link["arm/left_finger"], 4);  // the pad's four corners
  EXPECT_EQ(per_link["arm/right_finger"], 4);
  EXPECT_EQ(per_link.size(), 2u) << "only the finger pads touch the table";
  // The fingers push the table back: it slows down, and the arm moves.
  EXPECT_LT(response.bodies[0].twist.linear.z, 0.5);
  ASSERT_EQ(response.robots.size(), 1u);
  double speed = 0.0;
  for (double v : response.robots[0].joint_state.velocity) speed += std::abs(v);
  EXPECT_GT(speed, 0.0);
}

// Detected contacts keep the (robot, link) detection paired them on; contacts given in the request
// name links by "<robot>/<link>". The two paths must agree: the finger pads' detected contacts,
// given back as the request's own contacts (detection off), get the same impulses, the same joint
// velocities and the same table velocity.
TEST_F(RobotNodeTest, DetectedLinkContactsAnswerAsTheSameContactsGivenByName) {
  const std::vector<double> q = {0.3, 0.2, -0.4, 0.3, 0.5, -0.3, 0.7, 0.015, 0.02};
  cr::robot::ArticulatedBody arm = referenceArm();
  arm.setState(vector(q), Eigen::VectorXd::Zero(arm.jointCount()));
  Eigen::Isometry3d finger_wanted = Eigen::Isometry3d::Identity();
  finger_wanted.translation() = Eigen::Vector3d(0.4, -0.1, 0.05 - 1e-4);
  finger_wanted.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Isometry3d base =
      finger_wanted * arm.linkPose(arm.linkIndex("left_finger")).inverse();
  cr::ComputeResponse detected;
  detected.request.header.frame_id = "world";
  cr::BodyState table;
  table.id = "table";
  table.inertia.m = 20.0;
  table.inertia.ixx = table.inertia.iyy = 20.0 * (1.0 + 0.01) / 12.0;
  table.inertia.izz = 20.0 * 2.0 / 12.0;
  table.pose = pose(0.4, -0.1, -0.05);
  table.twist.linear.z = 0.5;
  shape_msgs::SolidPrimitive top;
  top.type = shape_msgs::SolidPrimitive::BOX;
  top.dimensions = {1.0, 1.0, 0.1};
  table.primitives = {top};
  table.primitive_poses = {pose(0, 0, 0)};
  detected.request.bodies = {table};
  detected.request.detection.mode = cr::DetectionOptions::MODE_ALWAYS;
  detected.request.detection.restitution = 0.3;
  detected.request.detection.static_friction = 0.4;
  detected.request.detection.dynamic_friction = 0.3;
  detected.request.robots = {armAtRest(q)};
  const Eigen::Quaterniond base_rotation(base.linear());
  detected.request.robots[0].base_pose =
      pose(base.translation().x(), base.translation().y(), base.translation().z(), base_rotation);
  const auto by_detection = call(detected);
  ASSERT_TRUE(by_detection.success) << by_detection.message;
  ASSERT_EQ(by_detection.detected_contacts.size(), 8u);

  cr::ComputeResponse given = detected;
  given.request.detection.mode = cr::DetectionOptions::MODE_NEVER;
  given.request.contacts = by_detection.detected_contacts;
  const auto by_name = call(given);
  ASSERT_TRUE(by_name.success) << by_name.message;
  ASSERT_EQ(by_name.impulses.size(), by_detection.impulses.size());
  double total = 0.0;  // [N s] the pads' push on the table
  for (std::size_t k = 0; k < by_name.impulses.size(); ++k) {
    EXPECT_NEAR(by_name.impulses[k].normal_impulse, by_detection.impulses[k].normal_impulse, 1e-12)
        << k;
    total += by_name.impulses[k].normal_impulse;
  }
  EXPECT_GT(total, 0.0);
  EXPECT_NEAR(by_name.bodies[0].twist.linear.z, by_detection.bodies[0].twist.linear.z, 1e-12);
  ASSERT_EQ(by_name.robots.size(), 1u);
  ASSERT_EQ(by_detection.robots.size(), 1u);
  const auto& v_name = by_name.robots[0].joint_state.velocity;
  const auto& v_detected = by_detection.robots[0].joint_state.velocity;
  ASSERT_EQ(v_name.size(), v_detected.size());
  for (std::size_t j = 0; j < v_name.size(); ++j) EXPECT_NEAR(v_name[j], v_detected[j], 1e-12) << j;
}

TEST_F(RobotNodeTest, BatchScenesCarryRobots) {
  const cr::robot::ArticulatedBody arm = publishedArm();
  const cr::ComputeResponse single = strikeRequest(strikeOf(arm));
  cr::ComputeBatch batch;
  batch.request.header.frame_id = "world";
  cr::Scene scene;
  scene.bodies = single.request.bodies;
  scene.contacts = single.request.contacts;
  scene.robots.resize(1);
  scene.robots[0].name = "arm";
  batch.request.scenes = {scene, scene};
  batch.request.scenes[1].robots[0].name = "no_such_robot";
  ros::ServiceClient client =
      node_.serviceClient<cr::ComputeBatch>("/collision_response/compute_batch");
  ASSERT_TRUE(client.call(batch));
  ASSERT_EQ(batch.response.results.size(), 2u);
  ASSERT_TRUE(batch.response.results[0].success) << batch.response.results[0].message;
  const Reference ref = reference(arm, single);
  ASSERT_EQ(batch.response.results[0].robots.size(), 1u);
  for (int j = 0; j < arm.jointCount(); ++j) {
    EXPECT_NEAR(batch.response.results[0].robots[0].joint_state.velocity[j],
                ref.arm.jointVelocities()(j), kExact);
  }
  EXPECT_FALSE(batch.response.results[1].success);
  EXPECT_NE(batch.response.results[1].message.find("scenes[1].robots[0].name"), std::string::npos)
      << batch.response.results[1].message;
}

// Robots in episodes through ~compute_episode (docs/robots.md, "Robots in episodes"): the arm at
// the published state (its joint state in the request), no gravity and no actuation (torque model
// none), swinging its hand into a 0.5 kg ball (radius 5 cm) at rest 1 cm ahead of the hand point
// strikeOf() takes. Checked: the robot accepted, the ball struck by a link of "arm", each impact
// carrying the arm's joint state, the end joint state returned in the model's joint order, and no
// kinetic energy gained (the flight conserves it without gravity and torque; e = 0.4 dissipates).
TEST_F(RobotNodeTest, EpisodeFollowsTheArmIntoABall) {
  const cr::robot::ArticulatedBody arm = publishedArm();
  const Strike strike = strikeOf(arm);
  ros::ServiceClient episodes =
      node_.serviceClient<cr::ComputeEpisode>("/collision_response/compute_episode");
  ASSERT_TRUE(episodes.waitForExistence(ros::Duration(20.0)));
  cr::ComputeEpisode srv;
  srv.request.header.frame_id = "world";
  cr::BodyState ball;
  ball.id = "ball";
  ball.inertia.m = 0.5;
  ball.inertia.ixx = ball.inertia.iyy = ball.inertia.izz = 0.4 * 0.5 * 0.05 * 0.05;
  const Eigen::Vector3d centre = strike.point + 0.06 * strike.normal;
  ball.pose.position.x = centre.x();
  ball.pose.position.y = centre.y();
  ball.pose.position.z = centre.z();
  ball.pose.orientation.w = 1.0;
  ball.primitives.resize(1);
  ball.primitives[0].type = shape_msgs::SolidPrimitive::SPHERE;
  ball.primitives[0].dimensions = {0.05};
  ball.primitive_poses.resize(1);
  ball.primitive_poses[0].orientation.w = 1.0;
  srv.request.bodies = {ball};
  cr::RobotState robot = armAtRest(kPublishedPositions);
  robot.joint_state.velocity = kPublishedVelocities;
  robot.joint_torques = cr::RobotState::JOINT_TORQUES_NONE;
  srv.request.robots = {robot};
  srv.request.detection.restitution = 0.4;
  srv.request.detection.static_friction = 0.3;
  srv.request.detection.dynamic_friction = 0.2;
  srv.request.options.law = cr::SolverOptions::LAW_STRONGE;
  srv.request.horizon = 0.2;
  srv.request.max_impacts = 20;
  ASSERT_TRUE(episodes.call(srv));
  const cr::ComputeEpisode::Response& response = srv.response;
  ASSERT_TRUE(response.success) << response.message;
  ASSERT_FALSE(response.impacts.empty());
  const cr::EpisodeImpact& first = response.impacts[0];
  bool arm_on_ball = false;
  for (const cr::Contact& c : first.contacts) {
    arm_on_ball = arm_on_ball || (c.body_a.rfind("arm/", 0) == 0 && c.body_b == "ball") ||
                  (c.body_b.rfind("arm/", 0) == 0 && c.body_a == "ball");
  }
  EXPECT_TRUE(arm_on_ball);
  // The hand point starts 1 cm from the ball and moves at |v|: the first touch comes no later
  // than when that point would reach it.
  EXPECT_LE(first.time, 0.0101 / arm.partPointVelocity(arm.linkIndex("hand"), strike.point).norm());
  ASSERT_EQ(first.robots.size(), 1u);
  EXPECT_EQ(first.robots[0].name, arm.jointNames());
  EXPECT_EQ(first.robots[0].velocity.size(), kJoints.size());
  ASSERT_EQ(response.robots.size(), 1u);
  const cr::EpisodeRobot& end = response.robots[0];
  EXPECT_EQ(end.name, "arm");
  EXPECT_EQ(end.joint_state.name, arm.jointNames());
  ASSERT_EQ(end.joint_state.position.size(), kJoints.size());
  ASSERT_EQ(end.joint_state.velocity.size(), kJoints.size());
  ASSERT_EQ(response.bodies.size(), 1u);
  const double ball_energy =
      0.5 * 0.5 * toEigen(response.bodies[0].twist.linear).squaredNorm() +
      0.5 * ball.inertia.ixx * toEigen(response.bodies[0].twist.angular).squaredNorm();
  const double before = arm.kineticEnergy();
  // The end state's energy, recomputed here from the returned joint state.
  cr::robot::ArticulatedBody after = referenceArm();
  after.setState(vector(end.joint_state.position), vector(end.joint_state.velocity), worldToBase());
  EXPECT_NEAR(end.kinetic_energy, after.kineticEnergy(), 1e-9 * before);
  EXPECT_LE(after.kineticEnergy() + ball_energy, before * (1.0 + 1e-9));
  EXPECT_LT(after.kineticEnergy() + ball_energy, before);
  EXPECT_GT(ball_energy, 0.0);
}

// Bad robot input in an episode is named, and the node keeps serving.
TEST_F(RobotNodeTest, BadRobotInputInAnEpisodeIsNamed) {
  ros::ServiceClient episodes =
      node_.serviceClient<cr::ComputeEpisode>("/collision_response/compute_episode");
  ASSERT_TRUE(episodes.waitForExistence(ros::Duration(20.0)));
  const auto request = [](const std::string& name) {
    cr::ComputeEpisode srv;
    srv.request.header.frame_id = "world";
    cr::BodyState floor;
    floor.id = "floor";
    floor.pose.orientation.w = 1.0;
    floor.planes.resize(1);
    floor.planes[0].coef = {0.0, 0.0, 1.0, 10.0};
    floor.plane_poses.resize(1);
    floor.plane_poses[0].orientation.w = 1.0;
    srv.request.bodies = {floor};
    srv.request.robots.resize(1);
    srv.request.robots[0] = armAtRest(kPublishedPositions);
    srv.request.robots[0].name = name;
    srv.request.horizon = 0.01;
    srv.request.max_impacts = 5;
    return srv;
  };
  const auto expectNamed = [&](cr::ComputeEpisode srv, const std::string& field) {
    ASSERT_TRUE(episodes.call(srv));
    EXPECT_FALSE(srv.response.success);
    EXPECT_EQ(srv.response.message.rfind(field, 0), 0u) << srv.response.message;
    EXPECT_TRUE(srv.response.robots.empty());
  };
  expectNamed(request("no_such_arm"), "robots[0].name");
  cr::ComputeEpisode gravity = request("arm");
  gravity.request.gravity.z = -9.81;
  gravity.request.robots[0].gravity.z = -9.8;
  expectNamed(gravity, "robots[0].gravity");
  cr::ComputeEpisode floating = request("floating_arm");
  floating.request.robots[0].base_pose.orientation.w = 1.0;
  expectNamed(floating, "robots[0].base");
  cr::ComputeEpisode good = request("arm");
  ASSERT_TRUE(episodes.call(good));
  EXPECT_TRUE(good.response.success) << good.response.message;
  ASSERT_EQ(good.response.robots.size(), 1u);
  EXPECT_EQ(good.response.robots[0].joint_state.position, kPublishedPositions);
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_robot_node");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  // /joint_states at 50 Hz, stamped now: never stale (~joint_state_timeout 2 s). For the whole
  // run (a publisher torn down while its timer fires would race).
  ros::NodeHandle node;
  ros::Publisher joint_states = node.advertise<sensor_msgs::JointState>("/joint_states", 10);
  ros::WallTimer timer =
      node.createWallTimer(ros::WallDuration(0.02), [&joint_states](const ros::WallTimerEvent&) {
        joint_states.publish(armJointState(kPublishedPositions, kPublishedVelocities));
      });
  const int result = RUN_ALL_TESTS();
  timer.stop();
  spinner.stop();
  return result;
}
