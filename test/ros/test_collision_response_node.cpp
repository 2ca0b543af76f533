// Integration test: the launch file's node, called through its service like a user would.
#include <collision_response/CollisionResponse.h>
#include <collision_response/ComputeBatch.h>
#include <collision_response/ComputeResponse.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <random>

#include <Eigen/Geometry>

#include "node_test_messages.h"

namespace cr = collision_response;
using namespace collision_response::testing;

namespace {

constexpr double kTolerance = 1e-9;

cr::BodyState ground() {
  cr::BodyState body;
  body.id = "ground";
  body.pose.orientation.w = 1.0;  // m = 0: immovable
  return body;
}

// Head-on spheres on the x axis: m1 = 1 kg at 2 m/s, m2 = 2 kg at -1 m/s, e = 0.5. Momentum
// m1 v1 + m2 v2 = 0 and v2' - v1' = e (v1 - v2) = 1.5 give v1' = -1, v2' = 0.5.
cr::ComputeResponse headOnSpheres() {
  cr::ComputeResponse srv;
  srv.request.header.frame_id = "world";
  srv.request.header.stamp = ros::Time(1234, 5678);  // no tf look-up: every body is in "world"
  srv.request.bodies = {sphere("left", 1.0, 0.1, pose(-0.1, 0, 0)),
                        sphere("right", 2.0, 0.1, pose(0.1, 0, 0))};
  srv.request.bodies[0].twist.linear.x = 2.0;
  srv.request.bodies[1].twist.linear.x = -1.0;
  srv.request.contacts = {contact("left", "right", 0, 0, 0, 1, 0, 0, 0.5)};
  return srv;
}

class NodeTest : public ServiceTest {
 protected:
  // A bad request is rejected with a message naming `field`, and the node still answers a good one.
  void expectRejected(const cr::ComputeResponse& srv, const std::string& field) {
    ServiceTest::expectRejected(srv, field);
    EXPECT_TRUE(call(headOnSpheres()).success) << "node stopped serving after a bad request";
  }
};

TEST_F(NodeTest, HeadOnSpheresMatchClosedForm) {
  const auto response = call(headOnSpheres());
  ASSERT_TRUE(response.success) << response.message;
  ASSERT_EQ(response.bodies.size(), 2u);
  EXPECT_EQ(response.bodies[0].id, "left");
  EXPECT_NEAR(response.bodies[0].twist.linear.x, -1.0, kTolerance);
  EXPECT_NEAR(response.bodies[1].twist.linear.x, 0.5, kTolerance);
  EXPECT_NEAR(response.bodies[1].twist.linear.y, 0.0, kTolerance);
  ASSERT_EQ(response.impulses.size(), 1u);
  // Impulse on the right sphere: m2 (v2' - v2) = 2 * 1.5 = 3 N s.
  EXPECT_NEAR(response.impulses[0].normal_impulse, 3.0, kTolerance);
  EXPECT_NEAR(response.impulses[0].normal_velocity_before, -3.0, kTolerance);
  EXPECT_NEAR(response.impulses[0].normal_velocity_after, 1.5, kTolerance);
  // Energy: before 0.5*1*4 + 0.5*2*1 = 3 J; after 0.5*1*1 + 0.5*2*0.25 = 0.75 J.
  EXPECT_NEAR(response.kinetic_energy_before, 3.0, kTolerance);
  EXPECT_NEAR(response.kinetic_energy_after, 0.75, kTolerance);
  ASSERT_EQ(response.islands.size(), 1u);
  EXPECT_EQ(response.islands[0].method, "impulse_space");  // the default law is Stronge's
}

// Head-on frictionless spheres on the z axis under Newton's law with derivatives requested: the
// Jacobian against Newton's formula differentiated by hand. With M = m1 + m2 and closing speed
// w = v1 - v2 (along z), P = (1 + e) m1 m2 / M w, v1' = v1 - P / m1, v2' = v2 + P / m2; every other
// velocity component is untouched (no friction, the contact through both centres). The contact
// slips along x (u_t = v_high + w_high x r_high - v_low = -0.4 m/s), so raising mu_d from 0 adds a
// sliding friction impulse mu_d P along +x on `high` (Coulomb, opposing the slip; the contact
// keeps sliding for small mu_d): d F_x / d mu_d = P, acting -P on `low` at r = (0, 0, 0.1) and +P
// on `high` at r = (0, 0, -0.1), torque r x F = (0, -0.1 P, 0) on each; mu_s has no effect on a
// sliding contact.
TEST_F(NodeTest, DerivativesOfHeadOnSpheresMatchNewtonsFormula) {
  const double m1 = 1.0, m2 = 2.0, v1 = 2.0, v2 = -1.0, e = 0.5;
  cr::ComputeResponse srv;
  srv.request.header.frame_id = "world";
  srv.request.bodies = {sphere("low", m1, 0.1, pose(0, 0, -0.1)),
                        sphere("high", m2, 0.1, pose(0, 0, 0.1))};
  srv.request.bodies[0].twist.linear.z = v1;
  srv.request.bodies[1].twist.linear.z = v2;
  srv.request.bodies[0].twist.linear.x = 0.3;  // tangential motion, left alone without friction
  srv.request.bodies[1].twist.angular.y = 1.0;
  srv.request.contacts = {contact("low", "high", 0, 0, 0, 0, 0, 1, e)};
  srv.request.options.law = cr::SolverOptions::LAW_NEWTON;
  srv.request.options.derivatives = true;
  const auto response = call(srv);
  ASSERT_TRUE(response.success) << response.message;
  const cr::ImpactDerivatives& d = response.derivatives;
  EXPECT_EQ(d.method, "analytic");
  ASSERT_EQ(d.rows, 12u + 4u);
  ASSERT_EQ(d.columns, 12u + 3u);
  ASSERT_EQ(d.row_labels.size(), d.rows);
  ASSERT_EQ(d.column_labels.size(), d.columns);
  ASSERT_EQ(d.jacobian.size(), d.rows * d.columns);
  ASSERT_EQ(d.contacts.size(), 1u);
  EXPECT_NE(d.contacts[0].mode, "no_impulse");
  EXPECT_EQ(d.contacts[0].method, "analytic");

  const double total = m1 + m2, w = v1 - v2;
  std::map<std::pair<std::string, std::string>, double> expected;
  const char* const components[] = {"linear.x",  "linear.y",  "linear.z",
                                    "angular.x", "angular.y", "angular.z"};
  for (const char* body : {"bodies[0].twist.", "bodies[1].twist."})
    for (const char* component : components)
      expected[{std::string(body) + component, std::string(body) + component}] = 1.0;
  const std::string z1 = "bodies[0].twist.linear.z", z2 = "bodies[1].twist.linear.z";
  const std::string p = "impulses[0].normal_impulse", restitution = "contacts[0].restitution";
  expected[{z1, z1}] = 1.0 - (1.0 + e) * m2 / total;
  expected[{z1, z2}] = (1.0 + e) * m2 / total;
  expected[{z2, z1}] = (1.0 + e) * m1 / total;
  expected[{z2, z2}] = 1.0 - (1.0 + e) * m1 / total;
  expected[{z1, restitution}] = -m2 / total * w;
  expected[{z2, restitution}] = m1 / total * w;
  expected[{p, z1}] = (1.0 + e) * m1 * m2 / total;
  expected[{p, z2}] = -(1.0 + e) * m1 * m2 / total;
  expected[{p, restitution}] = m1 * m2 / total * w;
  const double impulse = (1.0 + e) * m1 * m2 / total * w, radius = 0.1;
  const double i1 = 0.4 * m1 * radius * radius, i2 = 0.4 * m2 * radius * radius;
  const std::string mu_d = "contacts[0].dynamic_friction";
  expected[{"impulses[0].friction_impulse.x", mu_d}] = impulse;
  expected[{"bodies[0].twist.linear.x", mu_d}] = -impulse / m1;
  expected[{"bodies[1].twist.linear.x", mu_d}] = impulse / m2;
  expected[{"bodies[0].twist.angular.y", mu_d}] = -radius * impulse / i1;
  expected[{"bodies[1].twist.angular.y", mu_d}] = -radius * impulse / i2;
  // The prediction itself: P = 1.5 * 2/3 * 3 = 3 N s.
  ASSERT_EQ(response.impulses.size(), 1u);
  EXPECT_NEAR(response.impulses[0].normal_impulse, (1.0 + e) * m1 * m2 / total * w, kTolerance);

  std::size_t matched = 0;
  for (std::size_t r = 0; r < d.rows; ++r) {
    for (std::size_t k = 0; k < d.columns; ++k) {
      const auto found = expected.find({d.row_labels[r], d.column_labels[k]});
      const double want = found == expected.end() ? 0.0 : found->second;
      matched += found != expected.end();
      EXPECT_NEAR(d.jacobian[r * d.columns + k], want, 1e-9)
          << "d " << d.row_labels[r] << " / d " << d.column_labels[k];
    }
  }
  EXPECT_EQ(matched, expected.size()) << "labels missing from the answer";
}

TEST_F(NodeTest, DerivativesAreEmptyUnlessRequested) {
  const auto response = call(headOnSpheres());
  ASSERT_TRUE(response.success) << response.message;
  EXPECT_EQ(response.derivatives.rows, 0u);
  EXPECT_EQ(response.derivatives.columns, 0u);
  EXPECT_TRUE(response.derivatives.method.empty());
  EXPECT_TRUE(response.derivatives.jacobian.empty());
  EXPECT_TRUE(response.derivatives.row_labels.empty());
  EXPECT_TRUE(response.derivatives.contacts.empty());
}

TEST_F(NodeTest, PublishesEverySuccessfulResponse) {
  const ResponsesListener listener(node_);
  ASSERT_TRUE(listener.waitForPublisher(10.0));

  const auto response = call(headOnSpheres());
  ASSERT_TRUE(response.success);
  const cr::CollisionResponse::ConstPtr received = listener.waitForMessage(10.0);
  ASSERT_TRUE(received) << "no message on /collision_response/responses";
  EXPECT_EQ(received->header.frame_id, "world");
  EXPECT_EQ(received->header.stamp, ros::Time(1234, 5678));  // (roscpp rewrites seq)
  ASSERT_EQ(received->bodies.size(), 2u);
  EXPECT_NEAR(received->bodies[1].twist.linear.x, 0.5, kTolerance);
  ASSERT_EQ(received->impulses.size(), 1u);
  EXPECT_NEAR(received->impulses[0].normal_impulse, 3.0, kTolerance);
  EXPECT_EQ(received->contacts.size(), 1u);
}

// Solid sphere (m = 1, R = 0.1, I = 2/5 m R^2) hits the ground at v = (1, 0, -2) with e = 0.5 and
// mu = 1. Normal: v_z' = e * 2 = 1. Sticking (rolling) end: the tangential impulse J_x gives
// v_x' = 1 + J_x and w_y' = -R J_x / I; rolling v_x' - R w_y' = 0 needs J_x = -2/7, so
// v_x' = 5/7 and w_y' = 50/7; |J_x| = 2/7 <= mu * 3 N s, so the contact sticks.
TEST_F(NodeTest, SphereOnGroundSticksAndRolls) {
  cr::ComputeResponse srv;
  srv.request.header.frame_id = "world";
  srv.request.bodies = {ground(), sphere("ball", 1.0, 0.1, pose(0, 0, 0.1))};
  srv.request.bodies[1].twist.linear.x = 1.0;
  srv.request.bodies[1].twist.linear.z = -2.0;
  srv.request.contacts = {contact("ground", "ball", 0, 0, 0, 0, 0, 1, 0.5, 1.0, 1.0)};
  const auto response = call(srv);
  ASSERT_TRUE(response.success) << response.message;
  const auto& twist = response.bodies[1].twist;
  EXPECT_NEAR(twist.linear.x, 5.0 / 7.0, kTolerance);
  EXPECT_NEAR(twist.linear.z, 1.0, kTolerance);
  EXPECT_NEAR(twist.angular.y, 50.0 / 7.0, kTolerance);
  EXPECT_TRUE(response.impulses[0].sticking);
  EXPECT_NEAR(response.impulses[0].friction_impulse.x, -2.0 / 7.0, kTolerance);
  EXPECT_NEAR(response.impulses[0].normal_impulse, 3.0, kTolerance);
  // The ground does not move.
  EXPECT_EQ(response.bodies[0].twist.linear.z, 0.0);
}

// A ball given in base_link, which tf places in odom at (1, 2, 0) rotated 90 degrees about z.
// Its velocity (1, 0, 0) in base_link is (0, 1, 0) in odom; it hits an immovable wall (normal +y in
// odom) elastically and leaves at (0, -1, 0) in odom.
TEST_F(NodeTest, TransformsBodiesIntoTheRequestFrame) {
  tf2_ros::StaticTransformBroadcaster broadcaster;
  geometry_msgs::TransformStamped transform;
  transform.header.stamp = ros::Time::now();
  transform.header.frame_id = "odom";
  transform.child_frame_id = "base_link";
  transform.transform.translation.x = 1.0;
  transform.transform.translation.y = 2.0;
  transform.transform.rotation.z = std::sqrt(0.5);
  transform.transform.rotation.w = std::sqrt(0.5);
  broadcaster.sendTransform(transform);

  cr::ComputeResponse srv;
  srv.request.header.frame_id = "odom";
  srv.request.bodies = {sphere("ball", 1.0, 0.1, pose(0, 0, 0)), ground()};
  srv.request.bodies[0].frame_id = "base_link";
  srv.request.bodies[0].twist.linear.x = 1.0;
  srv.request.bodies[1].id = "wall";
  srv.request.contacts = {contact("ball", "wall", 1.0, 2.1, 0.0, 0, 1, 0, 1.0)};
  cr::ComputeResponse::Response response;
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(10.0);
  do {  // the node's listener needs a moment to receive /tf_static
    response = call(srv);
  } while (!response.success && ros::WallTime::now() < deadline &&
           (ros::WallDuration(0.05).sleep(), true));
  ASSERT_TRUE(response.success) << response.message;
  const auto& ball = response.bodies[0];
  EXPECT_EQ(ball.frame_id, "odom");
  EXPECT_NEAR(ball.pose.position.x, 1.0, kTolerance);
  EXPECT_NEAR(ball.pose.position.y, 2.0, kTolerance);
  EXPECT_NEAR(ball.twist.linear.x, 0.0, kTolerance);
  EXPECT_NEAR(ball.twist.linear.y, -1.0, kTolerance);
  // Frictionless: nothing holds the contact, through tf as in the request frame (round-off in the
  // rotated velocity once made this flip).
  EXPECT_FALSE(response.impulses[0].sticking);
  cr::ComputeResponse direct = srv;
  direct.request.bodies[0].frame_id = "odom";
  direct.request.bodies[0].pose = pose(1.0, 2.0, 0.0);
  direct.request.bodies[0].twist.linear.x = 0.0;
  direct.request.bodies[0].twist.linear.y = 1.0;
  const auto direct_response = call(direct);
  ASSERT_TRUE(direct_response.success) << direct_response.message;
  EXPECT_NEAR(direct_response.bodies[0].twist.linear.y, -1.0, kTolerance);
  EXPECT_FALSE(direct_response.impulses[0].sticking);
}

// Mistakes that are valid requests: answered as the contract says, with a warning naming the field.
bool hasWarning(const std::vector<std::string>& warnings, const std::string& start) {
  for (const std::string& warning : warnings)
    if (warning.rfind(start, 0) == 0) return true;
  return false;
}

TEST_F(NodeTest, CleanRequestHasNoWarnings) {
  EXPECT_TRUE(call(headOnSpheres()).warnings.empty());
  // An immovable floor at rest is immovable by intent.
  cr::ComputeResponse srv;
  srv.request.header.frame_id = "world";
  srv.request.bodies = {ground(), sphere("ball", 1.0, 0.1, pose(0, 0, 0.1))};
  srv.request.bodies[1].twist.linear.z = -2.0;
  srv.request.contacts = {contact("ground", "ball", 0, 0, 0, 0, 0, 1, 0.5)};
  const auto response = call(srv);
  ASSERT_TRUE(response.success) << response.message;
  EXPECT_TRUE(response.warnings.empty()) << response.warnings[0];
}

// The right sphere sent without inertia (every field 0) is immovable, as the contract says: the
// left one bounces off a wall moving at -1 m/s. u_n = -1 - 2 = -3, after +1.5: v_left' = -2.5.
TEST_F(NodeTest, MovingBodyWithoutMassWarns) {
  cr::ComputeResponse srv = headOnSpheres();
  srv.request.bodies[1].inertia = geometry_msgs::Inertia();
  const auto response = call(srv);
  ASSERT_TRUE(response.success) << response.message;
  EXPECT_NEAR(response.bodies[0].twist.linear.x, -2.5, kTolerance);
  EXPECT_NEAR(response.bodies[1].twist.linear.x, -1.0, kTolerance);
  ASSERT_EQ(response.warnings.size(), 1u);
  EXPECT_TRUE(hasWarning(response.warnings, "bodies[1].inertia: mass 0, treated as immovable"))
      << response.warnings[0];
  // An inertia tensor without a mass is the same mistake, at rest too.
  srv.request.bodies[1].inertia.ixx = srv.request.bodies[1].inertia.iyy =
      srv.request.bodies[1].inertia.izz = 0.008;
  srv.request.bodies[1].twist.linear.x = 0.0;
  const auto at_rest = call(srv);
  ASSERT_TRUE(at_rest.success) << at_rest.message;
  EXPECT_TRUE(hasWarning(at_rest.warnings, "bodies[1].inertia: mass 0, treated as immovable"));
}

// The normal pointing from b to a: the approaching spheres see a separating contact, get no
// impulse and keep their velocities.
TEST_F(NodeTest, FlippedNormalWarns) {
  cr::ComputeResponse srv = headOnSpheres();
  srv.request.contacts[0].normal.x = -1.0;
  const auto response = call(srv);
  ASSERT_TRUE(response.success) << response.message;
  EXPECT_NEAR(response.bodies[0].twist.linear.x, 2.0, kTolerance);
  EXPECT_NEAR(response.bodies[1].twist.linear.x, -1.0, kTolerance);
  EXPECT_EQ(response.impulses[0].normal_impulse, 0.0);
  ASSERT_EQ(response.warnings.size(), 1u);
  EXPECT_TRUE(hasWarning(response.warnings, "contacts[0]: separating at +3 m/s, no impulse"))
      << response.warnings[0];
}

// A bar (1 kg, length 1 m, I_yy = m L^2 / 3 about its centre for half-length L = 0.5 m) lands
// flat on both ends at 1 m/s, e = 0, no friction. Each end alone has W = 1/m + L^2/I = 4/m. The
// one-pass law goes end by end: the left end's impulse m/4 stops it and drives the right end down
// to -1.5 m/s; the right end's impulse 1.5 m/4 stops it and drives the left end down by
// 1.5 (1/m - L^2/I) m/4 = -0.75 m/s. The answer leaves contacts[0] approaching: warned. Newton's
// law (solved together) stops both ends: no warning.
TEST_F(NodeTest, ContactLeftApproachingWarns) {
  cr::ComputeResponse srv;
  srv.request.header.frame_id = "world";
  cr::BodyState bar = sphere("bar", 1.0, 0.1, pose(0, 0, 0));
  bar.inertia.ixx = 0.001;
  bar.inertia.iyy = bar.inertia.izz = 1.0 * 0.25 / 3.0;
  bar.twist.linear.z = -1.0;
  srv.request.bodies = {ground(), bar};
  srv.request.contacts = {contact("ground", "bar", -0.5, 0, 0, 0, 0, 1, 0.0),
                          contact("ground", "bar", 0.5, 0, 0, 0, 0, 1, 0.0)};
  srv.request.options.law = cr::SolverOptions::LAW_SEED_ONE_PASS;
  const auto one_pass = call(srv);
  ASSERT_TRUE(one_pass.success) << one_pass.message;
  EXPECT_NEAR(one_pass.impulses[0].normal_impulse, 0.25, kTolerance);
  EXPECT_NEAR(one_pass.impulses[1].normal_impulse, 0.375, kTolerance);
  EXPECT_NEAR(one_pass.impulses[0].normal_velocity_after, -0.75, kTolerance);
  EXPECT_NEAR(one_pass.impulses[1].normal_velocity_after, 0.0, kTolerance);
  ASSERT_EQ(one_pass.warnings.size(), 1u);
  EXPECT_TRUE(hasWarning(one_pass.warnings, "contacts[0]: still approaching at -0.75 m/s"))
      << one_pass.warnings[0];
  EXPECT_NE(one_pass.warnings[0].find("seed_one_pass"), std::string::npos) << one_pass.warnings[0];

  srv.request.options.law = cr::SolverOptions::LAW_NEWTON;
  const auto newton = call(srv);
  ASSERT_TRUE(newton.success) << newton.message;
  EXPECT_NEAR(newton.impulses[0].normal_velocity_after, 0.0, kTolerance);
  EXPECT_NEAR(newton.impulses[1].normal_velocity_after, 0.0, kTolerance);
  EXPECT_TRUE(newton.warnings.empty()) << newton.warnings[0];
}

// An empty request frame takes ~default_frame ("world"): the answer, the published message and
// the markers carry it.
TEST_F(NodeTest, EmptyFrameTakesTheDefaultFrameAndWarns) {
  const ResponsesListener listener(node_);
  ASSERT_TRUE(listener.waitForPublisher(10.0));
  cr::ComputeResponse srv = headOnSpheres();
  srv.request.header.frame_id = "";
  const auto response = call(srv);
  ASSERT_TRUE(response.success) << response.message;
  EXPECT_NEAR(response.bodies[1].twist.linear.x, 0.5, kTolerance);
  EXPECT_EQ(response.bodies[0].frame_id, "world");
  ASSERT_EQ(response.warnings.size(), 1u);
  EXPECT_EQ(response.warnings[0], "header.frame_id: empty, taken as ~default_frame 'world'");
  const cr::CollisionResponse::ConstPtr received = listener.waitForMessage(10.0);
  ASSERT_TRUE(received);
  EXPECT_EQ(received->header.frame_id, "world");
}

TEST_F(NodeTest, BatchScenesCarryTheirWarnings) {
  ros::ServiceClient batch_client =
      node_.serviceClient<cr::ComputeBatch>("/collision_response/compute_batch");
  cr::ComputeBatch batch;
  batch.request.header.frame_id = "world";
  const cr::ComputeResponse clean = headOnSpheres();
  cr::ComputeResponse flipped_srv = headOnSpheres();
  flipped_srv.request.contacts[0].normal.x = -1.0;
  const cr::ComputeResponse& flipped = flipped_srv;
  for (const auto* srv : {&clean.request, &flipped.request}) {
    cr::Scene scene;
    scene.bodies = srv->bodies;
    scene.contacts = srv->contacts;
    batch.request.scenes.push_back(scene);
  }
  ASSERT_TRUE(batch_client.call(batch));
  ASSERT_EQ(batch.response.results.size(), 2u);
  EXPECT_TRUE(batch.response.results[0].warnings.empty());
  EXPECT_TRUE(hasWarning(batch.response.results[1].warnings, "contacts[0]: separating at +3 m/s"));
}

// A batch scene asking for derivatives gets them in its result, the others none. Head-on spheres
// (m1 = 1, m2 = 2 kg, closing at w = 3 m/s along x, Newton's law): d P / d e = m1 m2 / (m1 + m2) w
// = 2 N s, the entry of row "impulses[0].normal_impulse" and column "contacts[0].restitution".
TEST_F(NodeTest, BatchScenesCarryTheirDerivatives) {
  ros::ServiceClient batch_client =
      node_.serviceClient<cr::ComputeBatch>("/collision_response/compute_batch");
  cr::ComputeBatch batch;
  batch.request.header.frame_id = "world";
  for (const bool derivatives : {true, false}) {
    const cr::ComputeResponse srv = headOnSpheres();
    cr::Scene scene;
    scene.bodies = srv.request.bodies;
    scene.contacts = srv.request.contacts;
    scene.options.law = cr::SolverOptions::LAW_NEWTON;
    scene.options.derivatives = derivatives;
    batch.request.scenes.push_back(scene);
  }
  ASSERT_TRUE(batch_client.call(batch));
  ASSERT_EQ(batch.response.results.size(), 2u);
  ASSERT_TRUE(batch.response.results[0].success) << batch.response.results[0].message;
  const cr::ImpactDerivatives& d = batch.response.results[0].derivatives;
  ASSERT_EQ(d.rows, 16u);
  ASSERT_EQ(d.columns, 15u);
  ASSERT_EQ(d.jacobian.size(), d.rows * d.columns);
  ASSERT_EQ(d.row_labels[12], "impulses[0].normal_impulse");
  ASSERT_EQ(d.column_labels[12], "contacts[0].restitution");
  EXPECT_NEAR(d.jacobian[12 * d.columns + 12], 1.0 * 2.0 / 3.0 * 3.0, 1e-9);
  EXPECT_TRUE(batch.response.results[1].success);
  EXPECT_EQ(batch.response.results[1].derivatives.rows, 0u);
  EXPECT_TRUE(batch.response.results[1].derivatives.jacobian.empty());
}

// Unit cube (1 kg, I = 1/6 I3) falling flat at 1 m/s onto the ground, 4 corner contacts, e = 0.5,
// frictionless: by symmetry v' = (0, 0, 0.5) and no spin, whatever the law or solver.
TEST_F(NodeTest, CubeLandingFlatBouncesWithoutSpin) {
  cr::ComputeResponse srv;
  srv.request.header.frame_id = "world";
  cr::BodyState cube = sphere("cube", 1.0, 0.0, pose(0, 0, 0.5));
  cube.inertia.ixx = cube.inertia.iyy = cube.inertia.izz = 1.0 / 6.0;
  cube.twist.linear.z = -1.0;
  srv.request.bodies = {ground(), cube};
  for (const double x : {-0.5, 0.5}) {
    for (const double y : {-0.5, 0.5})
      srv.request.contacts.push_back(contact("ground", "cube", x, y, 0, 0, 0, 1, 0.5));
  }
  for (const uint8_t law : {cr::SolverOptions::LAW_DEFAULT, cr::SolverOptions::LAW_NEWTON,
                            cr::SolverOptions::LAW_POISSON}) {
    for (const uint8_t solver : {cr::SolverOptions::SOLVER_DEFAULT, cr::SolverOptions::SOLVER_EXACT,
                                 cr::SolverOptions::SOLVER_ITERATIVE}) {
      SCOPED_TRACE("law " + std::to_string(law) + " solver " + std::to_string(solver));
      srv.request.options.law = law;
      srv.request.options.solver = solver;
      const auto response = call(srv);
      ASSERT_TRUE(response.success) << response.message;
      const auto& twist = response.bodies[1].twist;
      EXPECT_NEAR(twist.linear.x, 0.0, kTolerance);
      EXPECT_NEAR(twist.linear.y, 0.0, kTolerance);
      EXPECT_NEAR(twist.linear.z, 0.5, kTolerance);
      EXPECT_NEAR(std::hypot(twist.angular.x, twist.angular.y, twist.angular.z), 0.0, kTolerance);
      ASSERT_EQ(response.islands.size(), 1u);
      EXPECT_TRUE(response.islands[0].converged);
    }
  }
}

// The rod of docs/physics.md, "Worked examples" (1 kg, 1 m, 50 degrees to a floor with mu 0.8,
// tip striking, centre of mass at 1 m/s 20 degrees off vertical away from the tip): the coupled
// Newton law creates energy; the default (Stronge) law does not, and the tip separates.
TEST_F(NodeTest, RodOnRoughFloorGainsNoEnergyUnderTheDefaultLaw) {
  const double tilt = 50.0 * M_PI / 180.0, off_vertical = 20.0 * M_PI / 180.0;
  cr::BodyState rod =
      sphere("rod", 1.0, 0.0, pose(0.5 * std::cos(tilt), 0.0, 0.5 * std::sin(tilt)));
  rod.inertia.ixx = 0.5 * 0.01 * 0.01;  // thin cylinder (radius 1 cm) along body x
  rod.inertia.iyy = rod.inertia.izz = (3.0 * 0.01 * 0.01 + 1.0) / 12.0;
  rod.pose.orientation.y =
      -std::sin(tilt / 2.0);  // body x axis tilted 50 degrees up from the floor
  rod.pose.orientation.w = std::cos(tilt / 2.0);
  rod.twist.linear.x = std::sin(off_vertical);
  rod.twist.linear.z = -std::cos(off_vertical);
  cr::ComputeResponse srv;
  srv.request.header.frame_id = "world";
  srv.request.bodies = {ground(), rod};
  for (const double e : {0.9, 1.0}) {
    SCOPED_TRACE(e);
    srv.request.contacts = {contact("ground", "rod", 0, 0, 0, 0, 0, 1, e, 0.8, 0.8)};
    srv.request.options.law = cr::SolverOptions::LAW_DEFAULT;
    const auto stronge = call(srv);
    ASSERT_TRUE(stronge.success) << stronge.message;
    EXPECT_LE(stronge.kinetic_energy_after, stronge.kinetic_energy_before * (1.0 + 1e-12));
    EXPECT_GT(stronge.impulses[0].normal_velocity_after, 0.0);
    srv.request.options.law = cr::SolverOptions::LAW_NEWTON;
    const auto newton = call(srv);
    ASSERT_TRUE(newton.success) << newton.message;
    EXPECT_GT(newton.kinetic_energy_after, newton.kinetic_energy_before * 1.05);
  }
}

// Newton's cradle, three equal balls, e = 1: the simultaneous answer (-1/3, 2/3, 2/3) v for Newton,
// Poisson, and Stronge by the two-phase scheme (options.multi_contact MULTI_CONTACT_TWO_PHASE);
// Stronge integrated simultaneously (the default) releases the first contact's work alone, and
// the second, which did no compression work, starts a new cycle: (1/3 - 1/sqrt(3), 1/3,
// 1/3 + 1/sqrt(3)) v (derivations in test_impact_laws.cpp and test_simultaneous_impact.cpp).
// Momentum and energy conserved in every case.
TEST_F(NodeTest, NewtonsCradleGivesTheSimultaneousAnswer) {
  cr::ComputeResponse srv;
  srv.request.header.frame_id = "world";
  for (int i = 0; i < 3; ++i)
    srv.request.bodies.push_back(sphere("ball" + std::to_string(i), 1.0, 0.1, pose(0.2 * i, 0, 0)));
  srv.request.bodies[0].twist.linear.x = 1.0;
  srv.request.contacts = {contact("ball0", "ball1", 0.1, 0, 0, 1, 0, 0, 1.0),
                          contact("ball1", "ball2", 0.3, 0, 0, 1, 0, 0, 1.0)};
  for (const uint8_t multi :
       {cr::SolverOptions::MULTI_CONTACT_DEFAULT, cr::SolverOptions::MULTI_CONTACT_TWO_PHASE}) {
    for (const uint8_t law : {cr::SolverOptions::LAW_NEWTON, cr::SolverOptions::LAW_POISSON,
                              cr::SolverOptions::LAW_STRONGE}) {
      SCOPED_TRACE(std::to_string(law) + " multi_contact " + std::to_string(multi));
      srv.request.options.law = law;
      srv.request.options.multi_contact = multi;
      const auto response = call(srv);
      ASSERT_TRUE(response.success) << response.message;
      const double a = 1.0 / std::sqrt(3.0);
      const bool integrated = law == cr::SolverOptions::LAW_STRONGE &&
                              multi == cr::SolverOptions::MULTI_CONTACT_DEFAULT;
      const double want[3] = {integrated ? 1.0 / 3.0 - a : -1.0 / 3.0,
                              integrated ? 1.0 / 3.0 : 2.0 / 3.0,
                              integrated ? 1.0 / 3.0 + a : 2.0 / 3.0};
      for (int i = 0; i < 3; ++i)
        EXPECT_NEAR(response.bodies[i].twist.linear.x, want[i], kTolerance) << "ball " << i;
      EXPECT_NEAR(response.kinetic_energy_after, response.kinetic_energy_before, kTolerance);
      ASSERT_EQ(response.islands.size(), 1u);
      if (law != cr::SolverOptions::LAW_NEWTON) {
        EXPECT_EQ(response.islands[0].method, multi == cr::SolverOptions::MULTI_CONTACT_TWO_PHASE
                                                  ? "two_phase_exact"
                                                  : "simultaneous_impulse_space");
      }
    }
  }
  srv.request.options.multi_contact = 7;
  const auto bad = call(srv);
  EXPECT_FALSE(bad.success);
  EXPECT_NE(bad.message.find("options.multi_contact"), std::string::npos) << bad.message;
}

// Resting contact through the service: a solid ball on the ground under gravity and a 1 N push
// rolls; the floor holds N = m g and friction -2/7 N (see test_resting_contact.cpp).
TEST_F(NodeTest, RestingBallGetsContactForces) {
  cr::ComputeResponse srv;
  srv.request.header.frame_id = "world";
  srv.request.bodies = {ground(), sphere("ball", 1.0, 0.1, pose(0, 0, 0.1))};
  srv.request.bodies[1].wrench.force.x = 1.0;
  srv.request.bodies[1].wrench.force.z = -9.81;
  srv.request.contacts = {contact("ground", "ball", 0, 0, 0, 0, 0, 1, 0.5, 0.5, 0.4)};
  const auto response = call(srv);
  ASSERT_TRUE(response.success) << response.message;
  const auto& contact = response.impulses[0];
  EXPECT_TRUE(contact.resting);
  EXPECT_TRUE(contact.sticking);
  EXPECT_NEAR(contact.normal_force, 9.81, kTolerance);
  EXPECT_NEAR(contact.friction_force.x, -2.0 / 7.0, kTolerance);
  EXPECT_EQ(response.islands[0].method, "resting_closed_form");
  EXPECT_NEAR(response.bodies[1].wrench.force.z, -9.81, kTolerance);
}

// A block resting on four corners with its tangential load in the band mu_d N < |L| <= mu_s N
// (issue 22, docs/physics.md, "Static friction first"): 2 kg, 0.2 m cube on the ground, weight
// 19.62 N, pushed with 11 N along y through its centre; mu_s = 0.6 holds 11.77 N, mu_d = 0.3 only
// 5.886 N. Static friction holds it (one-body statics, by hand): every corner sticks within its
// static cone and the corners carry sum N = 19.62 N and sum f = -11 N y, so the block's
// acceleration from the reported forces is zero (before the fix: sliding at (11 - 5.886) / 2 =
// 2.557 m/s^2).
TEST_F(NodeTest, RestingBlockOnFourCornersSticksInTheFrictionBand) {
  cr::ComputeResponse srv;
  srv.request.header.frame_id = "world";
  cr::BodyState block;
  block.id = "block";
  block.inertia.m = 2.0;
  block.inertia.ixx = block.inertia.iyy = block.inertia.izz = 2.0 * 0.04 / 6.0;
  block.pose = pose(0, 0, 0.1);
  block.wrench.force.y = 11.0;
  block.wrench.force.z = -2.0 * 9.81;
  srv.request.bodies = {ground(), block};
  for (const double x : {-0.1, 0.1}) {
    for (const double y : {-0.1, 0.1}) {
      srv.request.contacts.push_back(contact("ground", "block", x, y, 0, 0, 0, 1, 0.0, 0.6, 0.3));
    }
  }
  const auto response = call(srv);
  ASSERT_TRUE(response.success) << response.message;
  ASSERT_EQ(response.islands.size(), 1u);
  EXPECT_EQ(response.islands[0].method, "resting_iterative");
  EXPECT_TRUE(response.islands[0].converged);
  Eigen::Vector3d total(block.wrench.force.x, block.wrench.force.y, block.wrench.force.z);
  for (const auto& corner : response.impulses) {
    EXPECT_TRUE(corner.resting);
    EXPECT_TRUE(corner.sticking);
    const Eigen::Vector3d friction(corner.friction_force.x, corner.friction_force.y,
                                   corner.friction_force.z);
    EXPECT_GE(corner.normal_force, 0.0);
    EXPECT_LE(friction.norm(), 0.6 * corner.normal_force * (1.0 + 1e-9) + 1e-12);
    total += friction + corner.normal_force * Eigen::Vector3d::UnitZ();
  }
  EXPECT_LE(total.norm() / 2.0, 1e-6) << "the block accelerates at " << (total / 2.0).transpose();
}

// Random off-centre frictional impacts between two free bodies through the service: momentum is
// conserved, no contact is left approaching, impulses lie in the cone, and under the default
// (Stronge) law no energy is gained.
TEST_F(NodeTest, RandomImpactsKeepThePhysicalProperties) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), positive(0.2, 2.0), fraction(0.0, 1.0);
  int checked = 0;
  for (int trial = 0; trial < 300; ++trial) {
    cr::ComputeResponse srv;
    srv.request.header.frame_id = "world";
    for (const char* id : {"a", "b"}) {
      cr::BodyState body = sphere(id, positive(rng), 0.0, pose(unit(rng), unit(rng), unit(rng)));
      const double x = positive(rng), y = positive(rng);
      body.inertia.ixx = x;
      body.inertia.iyy = y;
      body.inertia.izz = std::abs(x - y) + (x + y - std::abs(x - y)) * fraction(rng);
      Eigen::Quaterniond q(unit(rng), unit(rng), unit(rng), unit(rng));
      q.normalize();
      body.pose.orientation.w = q.w();
      body.pose.orientation.x = q.x();
      body.pose.orientation.y = q.y();
      body.pose.orientation.z = q.z();
      body.twist.linear.x = unit(rng), body.twist.linear.y = unit(rng),
      body.twist.linear.z = unit(rng);
      body.twist.angular.x = unit(rng), body.twist.angular.y = unit(rng),
      body.twist.angular.z = unit(rng);
      srv.request.bodies.push_back(body);
    }
    Eigen::Vector3d n(unit(rng), unit(rng), unit(rng));
    n.normalize();
    const double mu_s = 1.2 * fraction(rng);
    srv.request.contacts = {contact("a", "b", unit(rng), unit(rng), unit(rng), n.x(), n.y(), n.z(),
                                    fraction(rng), mu_s, mu_s * fraction(rng))};
    for (const uint8_t law : {cr::SolverOptions::LAW_DEFAULT, cr::SolverOptions::LAW_NEWTON}) {
      SCOPED_TRACE("trial " + std::to_string(trial) + " law " + std::to_string(law));
      srv.request.options.law = law;
      const auto response = call(srv);
      ASSERT_TRUE(response.success) << response.message;
      Eigen::Vector3d momentum_change = Eigen::Vector3d::Zero();
      for (int i = 0; i < 2; ++i) {
        const auto& before = srv.request.bodies[i].twist.linear;
        const auto& after = response.bodies[i].twist.linear;
        momentum_change +=
            srv.request.bodies[i].inertia.m *
            Eigen::Vector3d(after.x - before.x, after.y - before.y, after.z - before.z);
      }
      EXPECT_NEAR(momentum_change.norm(), 0.0, 1e-9);
      const auto& impulse = response.impulses[0];
      const double friction = std::hypot(impulse.friction_impulse.x, impulse.friction_impulse.y,
                                         impulse.friction_impulse.z);
      EXPECT_LE(friction, mu_s * impulse.normal_impulse + 1e-9);
      EXPECT_GE(impulse.normal_impulse, 0.0);
      if (impulse.normal_velocity_before < 0.0) {
        const double e = srv.request.contacts[0].restitution;
        const double floor =
            law == cr::SolverOptions::LAW_NEWTON ? -e * impulse.normal_velocity_before : 0.0;
        EXPECT_GE(impulse.normal_velocity_after, floor - 1e-9);
        if (law == cr::SolverOptions::LAW_DEFAULT) {
          EXPECT_LE(response.kinetic_energy_after, response.kinetic_energy_before * (1.0 + 1e-10));
        }
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 200);  // about half the random contacts approach
}

// A request that cannot be solved within its options.time_budget fails with a message, reports
// the time it was given (at least the budget: the deadline fires only past it), and the node
// keeps serving. A row of 50 touching frictional spheres struck at one end, iterated with a
// budget of 1 microsecond.
TEST_F(NodeTest, TimedOutRequestFailsAndReportsTheTimeSpent) {
  cr::ComputeResponse srv;
  srv.request.header.frame_id = "world";
  for (int i = 0; i < 50; ++i) {  // the test node's ~max_bodies
    srv.request.bodies.push_back(sphere("ball" + std::to_string(i), 1.0, 0.1, pose(0.2 * i, 0, 0)));
    if (i > 0) {
      srv.request.contacts.push_back(contact("ball" + std::to_string(i - 1),
                                             "ball" + std::to_string(i), 0.2 * i - 0.1, 0, 0, 1, 0,
                                             0, 0.5, 0.3, 0.2));
    }
  }
  srv.request.bodies[0].twist.linear.x = 1.0;
  srv.request.bodies[0].twist.linear.z = 0.3;
  srv.request.options.solver = cr::SolverOptions::SOLVER_ITERATIVE;
  srv.request.options.time_budget = 1e-6;
  const auto response = call(srv);
  EXPECT_FALSE(response.success);
  EXPECT_NE(response.message.find("time budget"), std::string::npos) << response.message;
  EXPECT_GE(response.solve_time, 1e-6);
  EXPECT_LT(response.solve_time, 10.0);
  EXPECT_TRUE(response.bodies.empty());
  EXPECT_TRUE(call(headOnSpheres()).success) << "node stopped serving after a timeout";
}

TEST_F(NodeTest, UnknownFrameIsAClearError) {
  cr::ComputeResponse srv = headOnSpheres();
  srv.request.bodies[1].frame_id = "no_such_frame";
  expectRejected(srv, "bodies[1].frame_id");
}

TEST_F(NodeTest, EveryBadInputNamesItsField) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<std::pair<std::function<void(cr::ComputeResponse&)>, std::string>> cases = {
      {[&](auto& s) { s.request.bodies[0].inertia.m = nan; }, "bodies[0].inertia.m"},
      {[&](auto& s) {
         s.request.bodies[1].twist.angular.z = std::numeric_limits<double>::infinity();
       },
       "bodies[1].twist.angular.z"},
      {[&](auto& s) { s.request.contacts[0].point.y = nan; }, "contacts[0].point.y"},
      {[](auto& s) { s.request.bodies[1].inertia.m = -1.0; }, "bodies[1].inertia.m"},
      {[](auto& s) { s.request.bodies[0].inertia.iyy = -0.004; }, "bodies[0].inertia"},
      {[](auto& s) {  // principal moments 1, 1, 3: positive but 1 + 1 < 3
         auto& i = s.request.bodies[0].inertia;
         i.ixx = 1.0, i.iyy = 1.0, i.izz = 3.0;
       },
       "triangle inequality"},
      {[](auto& s) { s.request.bodies[0].pose.orientation.w = 0.0; }, "bodies[0].pose.orientation"},
      {[](auto& s) { s.request.contacts[0].normal.x = 0.0; },
       "contacts[0].normal: is a zero vector"},
      {[](auto& s) { s.request.contacts[0].normal.x = 2.0; },
       "contacts[0].normal: is not a unit vector"},
      {[](auto& s) { s.request.contacts[0].restitution = 1.5; }, "contacts[0].restitution"},
      {[](auto& s) { s.request.contacts[0].static_friction = -0.1; },
       "contacts[0].static_friction"},
      {[](auto& s) {
         s.request.contacts[0].static_friction = 0.2;
         s.request.contacts[0].dynamic_friction = 0.3;
       },
       "contacts[0].dynamic_friction"},
      {[](auto& s) { s.request.contacts[0].body_b = "nobody"; }, "contacts[0].body_b"},
      {[](auto& s) { s.request.bodies[1].id = "left"; }, "bodies[1].id"},
      {[](auto& s) { s.request.contacts[0].body_b = "left"; }, "contacts[0].body_b"},
      {[](auto& s) { s.request.options.law = 99; }, "options.law"},
      {[](auto& s) { s.request.options.solver = 42; }, "options.solver"},
      {[](auto& s) { s.request.options.tolerance = -1.0; }, "options.tolerance"},
      {[](auto& s) { s.request.bodies.resize(51, s.request.bodies[0]); }, "bodies"},
  };
  for (const auto& [mutate, field] : cases) {
    SCOPED_TRACE(field);
    cr::ComputeResponse srv = headOnSpheres();
    mutate(srv);
    expectRejected(srv, field);
  }
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_collision_response_node");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  return RUN_ALL_TESTS();
}
