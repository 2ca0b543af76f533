// Integration test: impact episodes through the node (episode_node.test): ~compute_episode,
// ~compute_episode_batch and ~episodes, against closed forms of balls dropped on a floor and
// colliding head-on; bad input named by its field, the node serving on.
#include <collision_response/ComputeEpisode.h>
#include <collision_response/ComputeEpisodeBatch.h>
#include <collision_response/Episode.h>
#include <collision_response/EpisodeResult.h>
#include <gtest/gtest.h>
#include <ros/ros.h>

#include <cmath>
#include <limits>
#include <mutex>
#include <string>
#include <vector>

#include "node_test_messages.h"

namespace cr = collision_response;
using namespace collision_response::testing;

namespace {

constexpr double kG = 9.81;          // [m/s^2]
constexpr double kTolerance = 1e-6;  // the requests' contact tolerance [m]
constexpr double kRadius = 0.1;      // [m]
constexpr double kMass = 0.5;        // [kg]

cr::BodyState floorBody() {
  cr::BodyState body;
  body.id = "floor";  // m = 0: immovable
  body.pose.orientation.w = 1.0;
  shape_msgs::Plane plane;
  plane.coef = {0.0, 0.0, 1.0, 0.0};  // z = 0, solid below
  body.planes.push_back(plane);
  body.plane_poses.push_back(pose(0, 0, 0));
  return body;
}

/// A solid ball (I = 2/5 m r^2) carrying a sphere primitive, its lowest point `height` above z = 0.
cr::BodyState ball(const std::string& id, double mass, double height, double x = 0.0) {
  cr::BodyState body = sphere(id, mass, kRadius, pose(x, 0, kRadius + height));
  shape_msgs::SolidPrimitive shape;
  shape.type = shape_msgs::SolidPrimitive::SPHERE;
  shape.dimensions = {kRadius};
  body.primitives.push_back(shape);
  body.primitive_poses.push_back(pose(0, 0, 0));
  return body;
}

/// A ball of mass kMass dropped from rest, `height` above a frictionless floor, restitution e.
cr::ComputeEpisode::Request drop(double height, double e) {
  cr::ComputeEpisode::Request request;
  request.header.frame_id = "world";
  request.bodies = {floorBody(), ball("ball", kMass, height)};
  request.detection.contact_tolerance = kTolerance;
  request.detection.restitution = e;
  request.gravity.z = -kG;
  request.horizon = 10.0;
  request.max_impacts = 1000;
  return request;
}

/// The z component of the impulse the impact's contact c exerts on the body called `id`.
double impulseOnZ(const cr::EpisodeImpact& impact, std::size_t c, const std::string& id) {
  const cr::Contact& contact = impact.contacts[c];
  const cr::ContactImpulse& impulse = impact.impulses[c];
  const double jz = impulse.normal_impulse * contact.normal.z + impulse.friction_impulse.z;
  if (contact.body_b == id) return jz;
  if (contact.body_a == id) return -jz;
  ADD_FAILURE() << "contact " << c << " does not touch " << id;
  return std::numeric_limits<double>::quiet_NaN();
}

/// The closed form of a ball dropped from rest from `height` onto a frictionless floor with
/// restitution e < 1: impact k (k = 0, 1, ...) comes at t_k = t_0 + (2 v_0 / g) sum_{j=1..k} e^j
/// (t_0 = sqrt(2 h / g), v_0 = sqrt(2 g h)) with the upward impulse m (1 + e) e^k v_0; the bounces
/// accumulate at t_inf = t_0 (1 + e) / (1 - e), where the ball comes to rest on the floor under
/// the normal force m g. The episode finds each impact with a gap in [0, tol] (tol the contact
/// tolerance), which moves it earlier by at most tol / v and shortens the flight after it by as
/// much: the times drift from the closed form by at most sum_k 2 tol / v_k over the impacts so far
/// (to first order), the speeds by g tol / v^2 relatively. The impacts are checked one by one while
/// e^k v_0 >= 0.2 m/s (relative speed error < 3e-4), the end against the drift of every impact
/// until the rebound rises less than tol (v_k < sqrt(2 g tol)), where the series is summed.
void expectBouncingBall(const cr::EpisodeResult& result, double height, double e) {
  ASSERT_TRUE(result.success) << result.message;
  const double t0 = std::sqrt(2.0 * height / kG);
  const double v0 = std::sqrt(2.0 * kG * height);
  ASSERT_FALSE(result.impacts.empty());
  double t = t0;
  double v = v0;
  double drift = 0.0;  // [s] bound on the time drift so far
  std::size_t checked = 0;
  for (std::size_t k = 0; k < result.impacts.size() && v >= 0.2; ++k) {
    SCOPED_TRACE("impact " + std::to_string(k));
    const cr::EpisodeImpact& impact = result.impacts[k];
    drift += 2.0 * kTolerance / v;
    EXPECT_NEAR(impact.time, t, drift + 1e-9);
    ASSERT_EQ(impact.contacts.size(), 1u);
    ASSERT_EQ(impact.impulses.size(), 1u);
    EXPECT_NEAR(impulseOnZ(impact, 0, "ball"), kMass * (1.0 + e) * v, 1e-3 * kMass * v);
    EXPECT_NEAR(impact.contacts[0].point.z, 0.0, 2.0 * kTolerance);
    ASSERT_EQ(impact.bodies.size(), 2u);
    EXPECT_EQ(impact.bodies[1].id, "ball");
    EXPECT_NEAR(impact.bodies[1].twist.linear.z, e * v, 1e-3 * v);
    EXPECT_NEAR(impact.bodies[1].pose.position.z, kRadius, 2.0 * kTolerance);
    t += 2.0 * e * v / kG;
    v *= e;
    ++checked;
  }
  EXPECT_GE(checked, 3u) << "the first bounces are listed one by one";
  EXPECT_EQ(result.end_reason, cr::EpisodeResult::END_SUSTAINED_CONTACT);
  drift = 0.0;
  for (v = v0; v >= std::sqrt(2.0 * kG * kTolerance); v *= e) drift += 2.0 * kTolerance / v;
  EXPECT_NEAR(result.end_time, t0 * (1.0 + e) / (1.0 - e), drift);
  ASSERT_EQ(result.outcomes.size(), 2u);
  EXPECT_EQ(result.outcomes[1], cr::EpisodeResult::OUTCOME_STICKING);  // at rest, not turning
  ASSERT_EQ(result.bodies.size(), 2u);
  EXPECT_NEAR(result.bodies[1].pose.position.z, kRadius, 1e-4);
  EXPECT_NEAR(result.bodies[1].twist.linear.z, 0.0, 1e-3);
  // At rest: the floor carries the weight.
  ASSERT_FALSE(result.resting_forces.empty());
  ASSERT_EQ(result.resting_forces.size(), result.resting_contacts.size());
  double weight_carried = 0.0;
  for (std::size_t c = 0; c < result.resting_forces.size(); ++c) {
    EXPECT_TRUE(result.resting_forces[c].resting);
    const double fz = result.resting_forces[c].normal_force * result.resting_contacts[c].normal.z;
    weight_carried += result.resting_contacts[c].body_b == "ball" ? fz : -fz;
  }
  EXPECT_NEAR(weight_carried, kMass * kG, 1e-6 * kMass * kG);
  ASSERT_EQ(result.accelerations.size(), 2u);
  EXPECT_NEAR(result.accelerations[1].linear.z, 0.0, 1e-6);
}

/// The service's answer as an EpisodeResult (the same fields), to check both alike.
cr::EpisodeResult asResult(const cr::ComputeEpisode::Response& response) {
  cr::EpisodeResult result;
  result.success = response.success;
  result.message = response.message;
  result.warnings = response.warnings;
  result.bodies = response.bodies;
  result.impacts = response.impacts;
  result.accumulated_impacts = response.accumulated_impacts;
  result.outcomes = response.outcomes;
  result.end_reason = response.end_reason;
  result.end_time = response.end_time;
  result.resting_contacts = response.resting_contacts;
  result.resting_forces = response.resting_forces;
  result.accelerations = response.accelerations;
  result.solve_time = response.solve_time;
  return result;
}

class EpisodeNodeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    for (const char* service :
         {"/collision_response/compute_episode", "/collision_response/compute_episode_batch"}) {
      ASSERT_TRUE(ros::service::waitForService(service, ros::Duration(20.0)))
          << "node did not come up: " << service;
    }
    client_ = node_.serviceClient<cr::ComputeEpisode>("/collision_response/compute_episode", true);
    batch_client_ = node_.serviceClient<cr::ComputeEpisodeBatch>(
        "/collision_response/compute_episode_batch", true);
  }

  cr::ComputeEpisode::Response call(const cr::ComputeEpisode::Request& request) {
    cr::ComputeEpisode srv;
    srv.request = request;
    EXPECT_TRUE(client_.call(srv)) << "the service call itself failed: the node must always answer";
    return srv.response;
  }

  /// A bad request: success false, a message naming `field`, no answer; and the node still serves.
  void expectRejected(const cr::ComputeEpisode::Request& request, const std::string& field) {
    SCOPED_TRACE(field);
    const cr::ComputeEpisode::Response response = call(request);
    EXPECT_FALSE(response.success);
    EXPECT_EQ(response.message.rfind(field + ":", 0), 0u)
        << "message '" << response.message << "' does not start with " << field;
    EXPECT_TRUE(response.bodies.empty());
    EXPECT_TRUE(response.impacts.empty());
    EXPECT_TRUE(response.outcomes.empty());
    EXPECT_TRUE(call(drop(0.2, 0.5)).success) << "the node stopped serving";
  }

  ros::NodeHandle node_;
  ros::ServiceClient client_;
  ros::ServiceClient batch_client_;
};

TEST_F(EpisodeNodeTest, BallDroppedOnAFloorBouncesToRest) {
  for (const double e : {0.5, 0.8}) {
    SCOPED_TRACE("e = " + std::to_string(e));
    expectBouncingBall(asResult(call(drop(0.4, e))), 0.4, e);
  }
}

TEST_F(EpisodeNodeTest, EndsWhenNothingTouchesBeforeTheHorizonOrAtTheCap) {
  const double h = 0.4, e = 0.5;
  const double t0 = std::sqrt(2.0 * h / kG);
  const double v0 = std::sqrt(2.0 * kG * h);

  // The first contact (t0) past the horizon: nothing will touch before it, so the episode ends
  // (episode.h: at once, at whatever time it has followed the fall to), the ball separated and in
  // free fall: z = r + h - g t^2 / 2, v = -g t at end_time.
  cr::ComputeEpisode::Request request = drop(h, e);
  request.horizon = 0.5 * t0;
  cr::ComputeEpisode::Response response = call(request);
  ASSERT_TRUE(response.success) << response.message;
  EXPECT_TRUE(response.impacts.empty());
  EXPECT_EQ(response.end_reason, cr::EpisodeResult::END_SEPARATED);
  EXPECT_GE(response.end_time, 0.0);
  EXPECT_LE(response.end_time, request.horizon);
  double t = response.end_time;
  ASSERT_EQ(response.bodies.size(), 2u);
  EXPECT_NEAR(response.bodies[1].pose.position.z, kRadius + h - 0.5 * kG * t * t, 1e-9);
  EXPECT_NEAR(response.bodies[1].twist.linear.z, -kG * t, 1e-9);
  ASSERT_EQ(response.outcomes.size(), 2u);
  EXPECT_EQ(response.outcomes[1], cr::EpisodeResult::OUTCOME_SEPARATED);
  EXPECT_TRUE(response.resting_forces.empty());

  // The horizon between the first impact (t0) and the second (t0 (1 + 2 e) = 2 t0): one impact,
  // then the ball rises at e v0 and will not touch again before the horizon; at end_time it is in
  // the ballistic flight from (t0, z = r, e v0).
  request.horizon = 1.5 * t0;
  response = call(request);
  ASSERT_TRUE(response.success) << response.message;
  ASSERT_EQ(response.impacts.size(), 1u);
  EXPECT_NEAR(response.impacts[0].time, t0, 2.0 * kTolerance / v0 + 1e-9);
  EXPECT_EQ(response.end_reason, cr::EpisodeResult::END_SEPARATED);
  EXPECT_GE(response.end_time, response.impacts[0].time);
  EXPECT_LE(response.end_time, request.horizon);
  t = response.end_time - t0;
  ASSERT_EQ(response.bodies.size(), 2u);
  // The impact comes up to tol early: the speeds differ by up to g tol / v0 + g 2 tol / v0.
  EXPECT_NEAR(response.bodies[1].twist.linear.z, e * v0 - kG * t, 1e-4 * v0);
  EXPECT_NEAR(response.bodies[1].pose.position.z, kRadius + e * v0 * t - 0.5 * kG * t * t,
              2.0 * kTolerance + 1e-4 * v0 * t);
  EXPECT_EQ(response.outcomes[1], cr::EpisodeResult::OUTCOME_SEPARATED);

  // One impact allowed: the second (at t0 + 2 e v0 / g) ends the episode, the ball touching.
  request = drop(h, e);
  request.max_impacts = 1;
  response = call(request);
  ASSERT_TRUE(response.success) << response.message;
  ASSERT_EQ(response.impacts.size(), 1u);
  EXPECT_NEAR(response.impacts[0].time, t0, 2.0 * kTolerance / v0 + 1e-9);
  EXPECT_EQ(response.end_reason, cr::EpisodeResult::END_IMPACT_CAP);
  EXPECT_NEAR(response.end_time, t0 + 2.0 * e * v0 / kG,
              2.0 * kTolerance / v0 + 2.0 * kTolerance / (e * v0) + 1e-9);
  ASSERT_EQ(response.outcomes.size(), 2u);
  EXPECT_EQ(response.outcomes[1], cr::EpisodeResult::OUTCOME_CAPPED);

  // A time budget far too short for the bouncing: the episode ends on it, reported, not failed.
  request = drop(h, e);
  request.options.time_budget = 1e-9;
  response = call(request);
  ASSERT_TRUE(response.success) << response.message;
  EXPECT_EQ(response.end_reason, cr::EpisodeResult::END_TIME_BUDGET);
  EXPECT_LE(response.end_time, request.horizon);
  EXPECT_EQ(response.bodies.size(), 2u);
  EXPECT_EQ(response.outcomes.size(), 2u);
}

TEST_F(EpisodeNodeTest, HeadOnBallsInZeroGravitySeparateAfterOneImpact) {
  // 1 kg at +2 m/s and 2 kg at -1 m/s along x, 0.3 m apart (gap 0.1 m), e = 0.5: one impact at
  // t = 0.1 / 3 s with the impulse (1 + e) m1 m2 / (m1 + m2) * 3 = 3 N s, +x on the right ball;
  // after it -1 and +0.5 m/s, apart for good.
  cr::ComputeEpisode::Request request;
  request.header.frame_id = "world";
  request.bodies = {ball("left", 1.0, 0.0, -0.15), ball("right", 2.0, 0.0, 0.15)};
  request.bodies[0].twist.linear.x = 2.0;
  request.bodies[1].twist.linear.x = -1.0;
  request.detection.contact_tolerance = kTolerance;
  request.detection.restitution = 0.5;
  request.horizon = 1.0;
  request.max_impacts = 10;
  const cr::ComputeEpisode::Response response = call(request);
  ASSERT_TRUE(response.success) << response.message;
  ASSERT_EQ(response.impacts.size(), 1u);
  const cr::EpisodeImpact& impact = response.impacts[0];
  EXPECT_NEAR(impact.time, 0.1 / 3.0, kTolerance / 3.0 + 1e-9);
  ASSERT_EQ(impact.impulses.size(), 1u);
  const cr::Contact& contact = impact.contacts[0];
  const double on_right = (contact.body_b == "right" ? 1.0 : -1.0) *
                          impact.impulses[0].normal_impulse * contact.normal.x;
  EXPECT_NEAR(on_right, 3.0, 1e-9);
  EXPECT_NEAR(impact.bodies[0].twist.linear.x, -1.0, 1e-9);
  EXPECT_NEAR(impact.bodies[1].twist.linear.x, 0.5, 1e-9);
  EXPECT_EQ(response.end_reason, cr::EpisodeResult::END_SEPARATED);
  EXPECT_EQ(response.outcomes, std::vector<std::string>(2, cr::EpisodeResult::OUTCOME_SEPARATED));
  EXPECT_TRUE(response.resting_forces.empty());
  EXPECT_EQ(response.accumulated_impacts, 0u);
}

TEST_F(EpisodeNodeTest, BatchOfTwoAnswersEachInOrder) {
  cr::ComputeEpisodeBatch batch;
  batch.request.header.frame_id = "world";
  const double heights[2] = {0.4, 0.1};
  const double restitutions[2] = {0.5, 0.8};
  for (int i = 0; i < 2; ++i) {
    cr::ComputeEpisode::Request single = drop(heights[i], restitutions[i]);
    cr::EpisodeScene scene;
    // The second scene takes the batch's header.
    if (i == 0) scene.header = single.header;
    scene.bodies = single.bodies;
    scene.detection = single.detection;
    scene.gravity = single.gravity;
    scene.horizon = single.horizon;
    scene.max_impacts = single.max_impacts;
    batch.request.scenes.push_back(scene);
  }
  ASSERT_TRUE(batch_client_.call(batch));
  ASSERT_TRUE(batch.response.success) << batch.response.message;
  ASSERT_EQ(batch.response.results.size(), 2u);
  for (int i = 0; i < 2; ++i) {
    SCOPED_TRACE("scene " + std::to_string(i));
    expectBouncingBall(batch.response.results[i], heights[i], restitutions[i]);
  }
  EXPECT_NEAR(batch.response.solve_time,
              batch.response.results[0].solve_time + batch.response.results[1].solve_time, 1e-12);

  // A bad scene is named in the batch; the other is followed all the same.
  batch.response = cr::ComputeEpisodeBatch::Response();
  batch.request.scenes[1].horizon = -1.0;
  ASSERT_TRUE(batch_client_.call(batch));
  ASSERT_TRUE(batch.response.success);
  ASSERT_EQ(batch.response.results.size(), 2u);
  EXPECT_TRUE(batch.response.results[0].success) << batch.response.results[0].message;
  EXPECT_FALSE(batch.response.results[1].success);
  EXPECT_EQ(batch.response.results[1].message.rfind("scenes[1].horizon:", 0), 0u)
      << batch.response.results[1].message;
}

TEST_F(EpisodeNodeTest, BadInputIsNamed) {
  cr::ComputeEpisode::Request request = drop(0.2, 0.5);
  request.horizon = -1.0;
  expectRejected(request, "horizon");

  request = drop(0.2, 0.5);
  request.horizon = 0.0;
  expectRejected(request, "horizon");

  request = drop(0.2, 0.5);
  request.gravity.y = std::numeric_limits<double>::quiet_NaN();
  expectRejected(request, "gravity");

  // The tolerance is named as the client sets it (detection.contact_tolerance), not as the core's
  // option: too large, and negative.
  for (const double tolerance : {2.0, -1e-4}) {
    request = drop(0.2, 0.5);
    request.detection.contact_tolerance = tolerance;
    expectRejected(request, "detection.contact_tolerance");
  }

  request = drop(0.2, 0.5);
  request.max_impacts = 0;
  expectRejected(request, "max_impacts");
  request.max_impacts = std::numeric_limits<uint32_t>::max();  // more than an int holds
  expectRejected(request, "max_impacts");

  request = drop(0.2, 0.5);
  request.bodies[1].primitives.clear();
  request.bodies[1].primitive_poses.clear();
  expectRejected(request, "bodies[1]");

  request = drop(0.2, 0.5);
  request.robots.emplace_back();
  request.robots.back().name = "arm";
  // This node serves no robot: the name is refused.
  expectRejected(request, "robots[0].name");

  request = drop(0.2, 0.5);
  request.contacts.push_back(contact("floor", "ball", 0, 0, 0, 0, 0, 1, 0.5));
  expectRejected(request, "contacts");

  request = drop(0.2, 0.5);
  request.detection.mode = cr::DetectionOptions::MODE_NEVER;
  expectRejected(request, "detection.mode");

  request = drop(0.2, 0.5);
  request.options.derivatives = true;  // only ~compute differentiates an impact
  expectRejected(request, "options.derivatives");

  request = drop(0.2, 0.5);
  request.options.joint_position_derivatives = true;
  expectRejected(request, "options.joint_position_derivatives");

  // Values the bodies' checks of ~compute refuse are refused here alike.
  request = drop(0.2, 0.5);
  request.bodies[1].inertia.m = -1.0;
  expectRejected(request, "bodies[1].inertia.m");
}

/// Keeps the latest message of ~episodes.
class EpisodesListener {
 public:
  explicit EpisodesListener(ros::NodeHandle& node)
      : subscriber_(node.subscribe<cr::Episode>("/collision_response/episodes", 10,
                                                [this](const cr::Episode::ConstPtr& msg) {
                                                  std::lock_guard<std::mutex> lock(mutex_);
                                                  latest_ = msg;
                                                })) {}

  bool waitForPublisher(double seconds) const {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(seconds);
    while (subscriber_.getNumPublishers() == 0 && ros::WallTime::now() < deadline)
      ros::WallDuration(0.01).sleep();
    return subscriber_.getNumPublishers() > 0;
  }

  cr::Episode::ConstPtr waitForMessage(double seconds) const {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(seconds);
    for (;;) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (latest_ || ros::WallTime::now() >= deadline) return latest_;
      }
      ros::WallDuration(0.01).sleep();
    }
  }

 private:
  mutable std::mutex mutex_;
  cr::Episode::ConstPtr latest_;
  ros::Subscriber subscriber_;
};

TEST_F(EpisodeNodeTest, AnswerIsPublishedOnEpisodes) {
  EpisodesListener listener(node_);
  ASSERT_TRUE(listener.waitForPublisher(10.0));
  cr::ComputeEpisode::Request request = drop(0.3, 0.5);
  request.header.frame_id = "";  // taken as ~default_frame, with a warning
  const cr::ComputeEpisode::Response response = call(request);
  ASSERT_TRUE(response.success) << response.message;
  ASSERT_FALSE(response.warnings.empty());
  EXPECT_EQ(response.warnings[0].rfind("header.frame_id:", 0), 0u) << response.warnings[0];
  const cr::Episode::ConstPtr published = listener.waitForMessage(10.0);
  ASSERT_TRUE(published);
  EXPECT_EQ(published->header.frame_id, "world");
  EXPECT_TRUE(published->result.success);
  EXPECT_EQ(published->result.end_reason, response.end_reason);
  EXPECT_EQ(published->result.end_time, response.end_time);
  ASSERT_EQ(published->result.impacts.size(), response.impacts.size());
  for (std::size_t k = 0; k < response.impacts.size(); ++k)
    EXPECT_EQ(published->result.impacts[k].time, response.impacts[k].time);
  EXPECT_EQ(published->result.bodies.size(), response.bodies.size());
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_episode_node");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  return RUN_ALL_TESTS();
}
