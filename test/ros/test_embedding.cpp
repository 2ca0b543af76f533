// Integration test of the embedding features, against the launch file started twice: as a node
// (/node/collision_response) and as a nodelet (/nodelet/collision_response).
#include <collision_response/CollisionResponse.h>
#include <collision_response/ComputeBatch.h>
#include <collision_response/ComputeResponse.h>
#include <diagnostic_msgs/DiagnosticArray.h>
#include <dynamic_reconfigure/Reconfigure.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <visualization_msgs/MarkerArray.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <vector>

#include "node_test_messages.h"

namespace cr = collision_response;
using namespace collision_response::testing;

namespace {

constexpr double kTolerance = 1e-9;
const std::string kNode = "/node/collision_response";
const std::string kNodelet = "/nodelet/collision_response";

/// A sphere on the x axis at x [m] moving at vx [m/s].
cr::BodyState movingSphere(const std::string& id, double mass, double radius, double x, double vx) {
  cr::BodyState body = sphere(id, mass, radius, pose(x, 0, 0));
  body.twist.linear.x = vx;
  return body;
}

// Head-on spheres on the x axis, m1 at v1 (left) and m2 at v2 (right), restitution e. Closed form:
// v1' = (m1 v1 + m2 v2 - m2 e (v1 - v2)) / (m1 + m2), v2' = (m1 v1 + m2 v2 + m1 e (v1 - v2)) / (m1
// + m2), normal impulse m2 (v2' - v2).
struct HeadOn {
  double m1, m2, v1, v2, e;
  double v1After() const { return (m1 * v1 + m2 * v2 - m2 * e * (v1 - v2)) / (m1 + m2); }
  double v2After() const { return (m1 * v1 + m2 * v2 + m1 * e * (v1 - v2)) / (m1 + m2); }
};

cr::ComputeResponse::Request headOnRequest(const HeadOn& s, const std::string& suffix = "") {
  cr::ComputeResponse::Request request;
  request.header.frame_id = "world";
  request.bodies = {movingSphere("left" + suffix, s.m1, 0.1, -0.1, s.v1),
                    movingSphere("right" + suffix, s.m2, 0.1, 0.1, s.v2)};
  request.contacts = {contact("left" + suffix, "right" + suffix, 0, 0, 0, 1, 0, 0, s.e)};
  return request;
}

const HeadOn kHeadOn{1.0, 2.0, 2.0, -1.0, 0.5};  // v1' = -1, v2' = 0.5, impulse 3 N s

// A tilted box (0.5 kg, 0.2 m cube) striking a table with one corner, rough: off-centre and
// frictional, where the laws differ.
cr::ComputeResponse::Request boxCorner(uint8_t law) {
  cr::ComputeResponse::Request request;
  request.header.frame_id = "world";
  cr::BodyState table;
  table.id = "table";
  table.pose.orientation.w = 1.0;
  cr::BodyState box;
  box.id = "box";
  box.inertia.m = 0.5;
  box.inertia.ixx = box.inertia.iyy = box.inertia.izz = 0.5 * 0.04 / 6.0;
  box.pose.position.z = 0.14;
  box.pose.orientation.y = std::sin(0.15);
  box.pose.orientation.w = std::cos(0.15);
  box.twist.linear.x = 0.7;
  box.twist.linear.z = -2.0;
  box.twist.angular.y = 1.5;
  request.bodies = {table, box};
  request.contacts = {contact("table", "box", -0.09, 0.1, 0.0, 0, 0, 1, 0.4, 0.6, 0.5)};
  request.options.law = law;
  return request;
}

// A ball pressed into a corner: two simultaneous contacts with friction (the exact solver).
cr::ComputeResponse::Request ballInCorner() {
  cr::ComputeResponse::Request request;
  request.header.frame_id = "world";
  cr::BodyState ground;
  ground.id = "ground";
  ground.pose.orientation.w = 1.0;
  cr::BodyState wall = ground;
  wall.id = "wall";
  cr::BodyState ball = movingSphere("ball", 1.0, 0.1, 0.0, 1.0);
  ball.pose.position.z = 0.1;
  ball.twist.linear.z = -1.5;
  ball.twist.angular.x = 3.0;
  request.bodies = {ground, wall, ball};
  request.contacts = {contact("ground", "ball", 0, 0, 0, 0, 0, 1, 0.6, 0.5, 0.4),
                      contact("wall", "ball", 0.1, 0, 0.1, -1, 0, 0, 0.3, 0.2, 0.2)};
  return request;
}

template <class Message>
std::vector<uint8_t> bytes(const Message& message) {
  const uint32_t length = ros::serialization::serializationLength(message);
  std::vector<uint8_t> buffer(length);
  ros::serialization::OStream stream(buffer.data(), length);
  ros::serialization::serialize(stream, message);
  return buffer;
}

/// Every field but the wall time.
std::vector<uint8_t> answerBytes(cr::ComputeResponse::Response response) {
  response.solve_time = 0.0;
  return bytes(response);
}

std::vector<uint8_t> answerBytes(cr::SceneResult result) {
  result.solve_time = 0.0;
  return bytes(result);
}

class EmbeddingTest : public ::testing::Test {
 protected:
  void SetUp() override {
    for (const std::string& ns : {kNode, kNodelet}) {
      ASSERT_TRUE(ros::service::waitForService(ns + "/compute", ros::Duration(30.0))) << ns;
      ASSERT_TRUE(ros::service::waitForService(ns + "/compute_batch", ros::Duration(30.0))) << ns;
    }
  }

  static cr::ComputeResponse::Response call(const std::string& ns,
                                            const cr::ComputeResponse::Request& request) {
    cr::ComputeResponse srv;
    srv.request = request;
    EXPECT_TRUE(callService(ns + "/compute", srv)) << ns << ": the call itself failed";
    return srv.response;
  }

  static cr::ComputeBatch::Response callBatch(const std::string& ns,
                                              const cr::ComputeBatch::Request& request) {
    cr::ComputeBatch srv;
    srv.request = request;
    EXPECT_TRUE(callService(ns + "/compute_batch", srv)) << ns << ": the call failed";
    return srv.response;
  }

  ros::NodeHandle node_;
};

std::vector<cr::ComputeResponse::Request> sampleRequests() {
  std::vector<cr::ComputeResponse::Request> requests = {headOnRequest(kHeadOn), ballInCorner()};
  for (const uint8_t law : {cr::SolverOptions::LAW_DEFAULT, cr::SolverOptions::LAW_NEWTON,
                            cr::SolverOptions::LAW_SEED_ONE_PASS, cr::SolverOptions::LAW_POISSON,
                            cr::SolverOptions::LAW_STRONGE})
    requests.push_back(boxCorner(law));
  cr::ComputeResponse::Request iterative = ballInCorner();
  iterative.options.solver = cr::SolverOptions::SOLVER_ITERATIVE;
  requests.push_back(iterative);
  cr::ComputeResponse::Request bad = headOnRequest(kHeadOn);
  bad.contacts[0].normal.x = 2.0;  // not a unit vector
  requests.push_back(bad);
  return requests;
}

TEST_F(EmbeddingTest, NodeletAnswersLikeTheNode) {
  const auto requests = sampleRequests();
  for (std::size_t i = 0; i < requests.size(); ++i) {
    const cr::ComputeResponse::Response from_node = call(kNode, requests[i]);
    const cr::ComputeResponse::Response from_nodelet = call(kNodelet, requests[i]);
    EXPECT_EQ(from_node.success, i + 1 < requests.size())
        << "request " << i << ": " << from_node.message;
    EXPECT_EQ(from_node.message, from_nodelet.message);
    EXPECT_EQ(answerBytes(from_node), answerBytes(from_nodelet))
        << "request " << i << ": the nodelet's answer differs from the node's";
  }
  // And the answers are the right ones: the closed form of the head-on impact.
  const auto response = call(kNodelet, requests[0]);
  ASSERT_TRUE(response.success) << response.message;
  EXPECT_NEAR(response.bodies[0].twist.linear.x, -1.0, kTolerance);
  EXPECT_NEAR(response.bodies[1].twist.linear.x, 0.5, kTolerance);
  EXPECT_NEAR(response.impulses[0].normal_impulse, 3.0, kTolerance);
  const auto rejected = call(kNodelet, requests.back());
  EXPECT_FALSE(rejected.success);
  EXPECT_NE(rejected.message.find("contacts[0].normal"), std::string::npos) << rejected.message;
}

// Scene i of the batch: masses, speeds and restitution all vary with i, body ids carry i.
HeadOn batchScene(std::size_t i) {
  return {1.0 + 0.5 * static_cast<double>(i % 5), 1.0 + static_cast<double>(i % 7),
          1.0 + 0.001 * static_cast<double>(i), -0.5 + 0.0003 * static_cast<double>(i),
          static_cast<double>(i % 11) / 10.0};
}

cr::ComputeBatch::Request batchOf(std::size_t count, std::size_t bad_scene) {
  cr::ComputeBatch::Request request;
  request.header.frame_id = "world";
  request.scenes.resize(count);
  for (std::size_t i = 0; i < count; ++i) {
    const cr::ComputeResponse::Request single = headOnRequest(batchScene(i), std::to_string(i));
    cr::Scene& scene = request.scenes[i];
    // Half the scenes name their frame, half take the batch header's.
    if (i % 2 == 0) scene.header = single.header;
    scene.bodies = single.bodies;
    scene.contacts = single.contacts;
    if (i % 3 == 0) scene.options.law = cr::SolverOptions::LAW_NEWTON;
  }
  request.scenes[bad_scene].bodies[1].inertia.m = -1.0;
  return request;
}

TEST_F(EmbeddingTest, BatchOf1000ScenesAnswersInOrder) {
  constexpr std::size_t kCount = 1000, kBad = 777;
  const cr::ComputeBatch::Request request = batchOf(kCount, kBad);
  std::map<std::string, std::vector<uint8_t>> first_answers;
  for (const std::string& ns : {kNode, kNodelet}) {
    const auto start = std::chrono::steady_clock::now();
    const cr::ComputeBatch::Response response = callBatch(ns, request);
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("%s: batch of %zu scenes: %.3f s wall (call), %.3f s in the solver\n", ns.c_str(),
                kCount, wall, response.solve_time);
    ASSERT_TRUE(response.success) << response.message;
    ASSERT_EQ(response.results.size(), kCount);
    for (std::size_t i = 0; i < kCount; ++i) {
      const cr::SceneResult& result = response.results[i];
      if (i == kBad) {
        EXPECT_FALSE(result.success);
        EXPECT_NE(result.message.find("scenes[777].bodies[1].inertia.m"), std::string::npos)
            << result.message;
        EXPECT_TRUE(result.bodies.empty());
        continue;
      }
      ASSERT_TRUE(result.success) << "scene " << i << ": " << result.message;
      ASSERT_EQ(result.bodies.size(), 2u);
      EXPECT_EQ(result.bodies[0].id, "left" + std::to_string(i)) << "results out of order";
      EXPECT_EQ(result.bodies[1].id, "right" + std::to_string(i)) << "results out of order";
      EXPECT_EQ(result.bodies[0].frame_id, "world");
      const HeadOn s = batchScene(i);
      EXPECT_NEAR(result.bodies[0].twist.linear.x, s.v1After(), kTolerance) << "scene " << i;
      EXPECT_NEAR(result.bodies[1].twist.linear.x, s.v2After(), kTolerance) << "scene " << i;
      ASSERT_EQ(result.impulses.size(), 1u);
      EXPECT_NEAR(result.impulses[0].normal_impulse, s.m2 * (s.v2After() - s.v2), kTolerance);
      ASSERT_EQ(result.islands.size(), 1u);
      EXPECT_EQ(result.islands[0].method, i % 3 == 0 ? "closed_form" : "impulse_space");
    }
    // A batch scene gets exactly the answer of the same request sent alone.
    for (const std::size_t i : {std::size_t{0}, std::size_t{1}, std::size_t{500}, kCount - 1}) {
      cr::ComputeResponse::Request single;
      single.header = request.header;
      single.bodies = request.scenes[i].bodies;
      single.contacts = request.scenes[i].contacts;
      single.options = request.scenes[i].options;
      cr::ComputeResponse::Response alone = call(ns, single);
      cr::SceneResult as_result;
      as_result.success = alone.success;
      as_result.message = alone.message;
      as_result.bodies = alone.bodies;
      as_result.impulses = alone.impulses;
      as_result.kinetic_energy_before = alone.kinetic_energy_before;
      as_result.kinetic_energy_after = alone.kinetic_energy_after;
      as_result.islands = alone.islands;
      EXPECT_EQ(answerBytes(as_result), answerBytes(response.results[i])) << "scene " << i;
    }
    cr::ComputeBatch::Response copy = response;
    copy.solve_time = 0.0;
    std::vector<uint8_t> all;
    for (const cr::SceneResult& result : copy.results) {
      const auto b = answerBytes(result);
      all.insert(all.end(), b.begin(), b.end());
    }
    first_answers[ns] = all;
  }
  EXPECT_EQ(first_answers[kNode], first_answers[kNodelet]) << "node and nodelet batches differ";
}

TEST_F(EmbeddingTest, OversizedBatchIsRejectedAsAWholeAndEmptyBatchIsFine) {
  const cr::ComputeBatch::Response oversized = callBatch(kNodelet, batchOf(1001, 0));
  EXPECT_FALSE(oversized.success);
  EXPECT_NE(oversized.message.find("max_batch_scenes (1000)"), std::string::npos)
      << oversized.message;
  EXPECT_TRUE(oversized.results.empty());
  const cr::ComputeBatch::Response empty = callBatch(kNode, cr::ComputeBatch::Request());
  EXPECT_TRUE(empty.success) << empty.message;
  EXPECT_TRUE(empty.results.empty());
  EXPECT_TRUE(call(kNode, headOnRequest(kHeadOn)).success) << "node stopped serving";
}

TEST_F(EmbeddingTest, MarkersShowContactsImpulsesAndVelocities) {
  std::mutex mutex;
  visualization_msgs::MarkerArray::ConstPtr received;
  const ros::Subscriber subscriber = node_.subscribe<visualization_msgs::MarkerArray>(
      kNode + "/markers", 1, [&](const visualization_msgs::MarkerArray::ConstPtr& msg) {
        std::lock_guard<std::mutex> lock(mutex);
        received = msg;
      });
  // Markers are published only to subscribers: call until the node has seen the subscription.
  for (int attempt = 0; attempt < 200; ++attempt) {
    ASSERT_TRUE(call(kNode, headOnRequest(kHeadOn)).success);
    ros::WallDuration(0.05).sleep();
    std::lock_guard<std::mutex> lock(mutex);
    if (received) break;
  }
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_TRUE(received) << "no MarkerArray on " << kNode << "/markers";
  std::map<std::string, std::vector<visualization_msgs::Marker>> by_ns;
  ASSERT_FALSE(received->markers.empty());
  EXPECT_EQ(received->markers[0].action, visualization_msgs::Marker::DELETEALL);
  for (std::size_t i = 1; i < received->markers.size(); ++i) {
    const auto& m = received->markers[i];
    EXPECT_EQ(m.header.frame_id, "world");
    EXPECT_EQ(m.action, visualization_msgs::Marker::ADD);
    by_ns[m.ns].push_back(m);
  }
  ASSERT_EQ(by_ns["contact_points"].size(), 1u);
  EXPECT_EQ(by_ns["contact_points"][0].type, visualization_msgs::Marker::SPHERE_LIST);
  ASSERT_EQ(by_ns["contact_points"][0].points.size(), 1u);
  EXPECT_NEAR(by_ns["contact_points"][0].points[0].x, 0.0, kTolerance);
  // Arrows: points[0] the tail, points[1] the head.
  const auto arrow = [&](const std::string& ns, double x0, double x1) {
    ASSERT_EQ(by_ns[ns].size(), ns.rfind("velocity", 0) == 0 ? 2u : 1u) << ns;
    const auto& m = by_ns[ns][0];
    EXPECT_EQ(m.type, visualization_msgs::Marker::ARROW) << ns;
    ASSERT_EQ(m.points.size(), 2u) << ns;
    EXPECT_NEAR(m.points[0].x, x0, kTolerance) << ns;
    EXPECT_NEAR(m.points[1].x, x1, kTolerance) << ns;
    EXPECT_NEAR(m.points[1].y, 0.0, kTolerance) << ns;
    EXPECT_NEAR(m.points[1].z, 0.0, kTolerance) << ns;
  };
  arrow("contact_normals", 0.0, 0.1);                // unit normal, 0.1 m
  arrow("contact_impulses", 0.0, 0.1 * 3.0);         // 3 N s x 0.1 m per N s
  arrow("velocity_before", -0.1, -0.1 + 0.2 * 2.0);  // 2 m/s x 0.2 m per m/s (params file)
  arrow("velocity_after", -0.1, -0.1 + 0.2 * -1.0);  // -1 m/s
  EXPECT_NEAR(by_ns["velocity_after"][1].points[1].x, 0.1 + 0.2 * 0.5, kTolerance);
}

TEST_F(EmbeddingTest, DynamicReconfigureChangesTheDefaultLaw) {
  const auto set_law = [](const std::string& law) {
    dynamic_reconfigure::Reconfigure srv;
    dynamic_reconfigure::StrParameter parameter;
    parameter.name = "law";
    parameter.value = law;
    srv.request.config.strs.push_back(parameter);
    EXPECT_TRUE(callService(kNodelet + "/set_parameters", srv));
    for (const auto& p : srv.response.config.strs)
      if (p.name == "law") return p.value;
    return std::string("(no law in the answer)");
  };
  // One central contact under the automatic solver: Stronge integrates in impulse space, Newton
  // is solved in closed form; the velocities agree (every law does for a central impact).
  ASSERT_EQ(call(kNodelet, headOnRequest(kHeadOn)).islands.at(0).method, "impulse_space");
  EXPECT_EQ(set_law("newton"), "newton");
  const auto newton = call(kNodelet, headOnRequest(kHeadOn));
  EXPECT_EQ(newton.islands.at(0).method, "closed_form");
  EXPECT_NEAR(newton.bodies.at(1).twist.linear.x, 0.5, kTolerance);
  // The node is not affected.
  EXPECT_EQ(call(kNode, headOnRequest(kHeadOn)).islands.at(0).method, "impulse_space");
  EXPECT_EQ(set_law("no_such_law"), "newton") << "an unknown law must keep the current one";
  EXPECT_EQ(set_law("stronge"), "stronge");
  EXPECT_EQ(call(kNodelet, headOnRequest(kHeadOn)).islands.at(0).method, "impulse_space");
}

TEST_F(EmbeddingTest, DiagnosticsCountCallsAndFailures) {
  std::mutex mutex;
  std::map<std::string, std::string> values;
  const ros::Subscriber subscriber = node_.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 10, [&](const diagnostic_msgs::DiagnosticArray::ConstPtr& msg) {
        std::lock_guard<std::mutex> lock(mutex);
        for (const auto& status : msg->status) {
          if (status.name != "node/collision_response: solver") continue;
          values.clear();
          for (const auto& kv : status.values) values[kv.key] = kv.value;
        }
      });
  cr::ComputeResponse::Request bad = headOnRequest(kHeadOn);
  bad.bodies[0].inertia.m = -2.0;
  EXPECT_FALSE(call(kNode, bad).success);
  EXPECT_TRUE(call(kNode, headOnRequest(kHeadOn)).success);
  // Diagnostics come at 1 Hz: wait for an update that has seen both calls.
  bool seen = false;
  for (int attempt = 0; attempt < 300 && !seen; ++attempt) {
    ros::WallDuration(0.05).sleep();
    std::lock_guard<std::mutex> lock(mutex);
    seen =
        !values.empty() && std::stoul(values["failures"]) >= 1 && std::stoul(values["calls"]) >= 2;
  }
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_TRUE(seen) << "no diagnostics of /node/collision_response with the calls counted";
  EXPECT_TRUE(values.count("call rate [1/s]"));
  EXPECT_GT(std::stod(values["mean solver time per scene [s]"]), 0.0);
  EXPECT_TRUE(values.count("max solver time per call since last update [s]"));
  EXPECT_GE(std::stoul(values["scenes"]), std::stoul(values["failures"]));
}

// ~responses is recorded into a bag and read back: the message equals the service's answer.
TEST_F(EmbeddingTest, PublishedResponsesRecordAndReplayWithRosbag) {
  std::mutex mutex;
  std::vector<cr::CollisionResponse::ConstPtr> received;
  const ros::Subscriber subscriber = node_.subscribe<cr::CollisionResponse>(
      kNodelet + "/responses", 100, [&](const cr::CollisionResponse::ConstPtr& msg) {
        std::lock_guard<std::mutex> lock(mutex);
        received.push_back(msg);
      });
  for (int attempt = 0; attempt < 200 && subscriber.getNumPublishers() == 0; ++attempt)
    ros::WallDuration(0.05).sleep();
  ASSERT_GT(subscriber.getNumPublishers(), 0u);
  cr::ComputeResponse::Request request = boxCorner(cr::SolverOptions::LAW_POISSON);
  request.header.stamp = ros::Time(4242, 17);  // marks our message
  const cr::ComputeResponse::Response answer = call(kNodelet, request);
  ASSERT_TRUE(answer.success) << answer.message;
  cr::CollisionResponse::ConstPtr ours;
  for (int attempt = 0; attempt < 200 && !ours; ++attempt) {
    ros::WallDuration(0.05).sleep();
    std::lock_guard<std::mutex> lock(mutex);
    for (const auto& msg : received)
      if (msg->header.stamp == request.header.stamp) ours = msg;
  }
  ASSERT_TRUE(ours) << "the response was not published";

  const std::string path = "/tmp/collision_response_test_" + std::to_string(::getpid()) + ".bag";
  {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    bag.write(kNodelet + "/responses", ros::Time(1, 0), *ours);
  }
  std::vector<cr::CollisionResponse> replayed;
  {
    rosbag::Bag bag(path, rosbag::bagmode::Read);
    for (const rosbag::MessageInstance& m : rosbag::View(bag)) {
      EXPECT_EQ(m.getTopic(), kNodelet + "/responses");
      EXPECT_EQ(m.getDataType(), "collision_response/CollisionResponse");
      const auto msg = m.instantiate<cr::CollisionResponse>();
      ASSERT_TRUE(msg);
      replayed.push_back(*msg);
    }
  }
  std::remove(path.c_str());
  ASSERT_EQ(replayed.size(), 1u);
  const cr::CollisionResponse& back = replayed[0];
  EXPECT_EQ(bytes(back), bytes(*ours));
  EXPECT_EQ(back.header.frame_id, "world");
  EXPECT_EQ(back.header.stamp, request.header.stamp);
  EXPECT_EQ(bytes(back.bodies), bytes(answer.bodies));
  EXPECT_EQ(bytes(back.impulses), bytes(answer.impulses));
  EXPECT_EQ(bytes(back.contacts), bytes(request.contacts));
  EXPECT_EQ(back.kinetic_energy_before, answer.kinetic_energy_before);
  EXPECT_EQ(back.kinetic_energy_after, answer.kinetic_energy_after);
}

// `rosbag record` (started by embedding.test with --limit=1) records the node's ~responses: the
// bag it closes holds the message of one of our calls, equal to that call's answer.
TEST_F(EmbeddingTest, RosbagRecordCapturesAPublishedResponse) {
  std::string path;
  ASSERT_TRUE(node_.getParam("/recorded_bag", path));
  const std::string service = "/bag/collision_response";
  ASSERT_TRUE(ros::service::waitForService(service + "/compute", ros::Duration(30.0)));
  // Stamps unique to this run (a bag of an earlier run may still be there).
  const int32_t run = static_cast<int32_t>(ros::WallTime::now().sec);
  std::map<ros::Time, std::pair<cr::ComputeResponse::Request, cr::ComputeResponse::Response>> calls;
  std::vector<cr::CollisionResponse> recorded;
  // Call until the recorder has subscribed, got one message and closed the bag.
  for (int attempt = 0; attempt < 300 && recorded.empty(); ++attempt) {
    cr::ComputeResponse::Request request = boxCorner(cr::SolverOptions::LAW_STRONGE);
    request.bodies[1].twist.linear.x = 0.01 * attempt;  // a different answer per call
    request.header.stamp = ros::Time(run, attempt);
    const cr::ComputeResponse::Response answer = call(service, request);
    ASSERT_TRUE(answer.success) << answer.message;
    calls[request.header.stamp] = {request, answer};
    ros::WallDuration(0.1).sleep();
    try {
      rosbag::Bag bag(path, rosbag::bagmode::Read);
      for (const rosbag::MessageInstance& m : rosbag::View(bag)) {
        const auto msg = m.instantiate<cr::CollisionResponse>();
        if (msg && calls.count(msg->header.stamp)) recorded.push_back(*msg);
      }
    } catch (const rosbag::BagException&) {
      // not there yet (still recording into PATH.active)
    }
  }
  ASSERT_EQ(recorded.size(), 1u) << "no bag with one of our responses at " << path;
  const cr::CollisionResponse& back = recorded[0];
  const auto& [request, answer] = calls.at(back.header.stamp);
  EXPECT_EQ(back.header.frame_id, "world");
  EXPECT_EQ(bytes(back.bodies), bytes(answer.bodies));
  EXPECT_EQ(bytes(back.impulses), bytes(answer.impulses));
  EXPECT_EQ(bytes(back.contacts), bytes(request.contacts));
  EXPECT_EQ(back.kinetic_energy_before, answer.kinetic_energy_before);
  EXPECT_EQ(back.kinetic_energy_after, answer.kinetic_energy_after);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_embedding");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
