// Load: several concurrent clients on persistent connections, thousands of calls mixing good, bad
// and oversized rigid-body requests with robot requests (the arm of load.test striking a box, with
// the request's own joint state or the latest of /joint_states, which this test publishes at
// 100 Hz). Every call is answered correctly, every robot answer equals the one computed once before
// the load, and the node's memory does not grow.
#include <collision_response/ComputeResponse.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>
#include <xmlrpcpp/XmlRpcClient.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "arm_strike.h"

namespace cr = collision_response;

namespace {

const char* const kService = "/collision_response/compute";

cr::BodyState ball(const std::string& id, double mass, double x, double v) {
  cr::BodyState body;
  body.id = id;
  body.inertia.m = mass;
  body.inertia.ixx = body.inertia.iyy = body.inertia.izz = 0.004 * mass;
  body.pose.position.x = x;
  body.pose.orientation.w = 1.0;
  body.twist.linear.x = v;
  return body;
}

// Head-on spheres, m1 = 1 at 2 m/s, m2 = 2 at -1 m/s, e = 0.5: v1' = -1, v2' = 0.5.
cr::ComputeResponse good() {
  cr::ComputeResponse srv;
  srv.request.header.frame_id = "world";
  srv.request.bodies = {ball("left", 1.0, -0.1, 2.0), ball("right", 2.0, 0.1, -1.0)};
  cr::Contact contact;
  contact.body_a = "left";
  contact.body_b = "right";
  contact.normal.x = 1.0;
  contact.restitution = 0.5;
  srv.request.contacts = {contact};
  return srv;
}

cr::ComputeResponse bad() {
  cr::ComputeResponse srv = good();
  srv.request.bodies[1].inertia.m = std::numeric_limits<double>::quiet_NaN();
  return srv;
}

cr::ComputeResponse oversized() {  // the test launch sets max_bodies to 50
  cr::ComputeResponse srv = good();
  for (int i = 0; i < 2000; ++i)
    srv.request.bodies.push_back(ball("extra" + std::to_string(i), 1.0, i, 0.0));
  return srv;
}

// What this test publishes on /joint_states (kArmJoints order) [rad | m, rad/s | m/s], and the
// state robot requests give themselves.
const std::vector<double>& kPublishedPositions = cr::testing::kArmSwingPositions;
const std::vector<double>& kPublishedVelocities = cr::testing::kArmSwingVelocities;
const std::vector<double> kOwnPositions = {-0.3, 0.4, 0.5, -0.9, -0.2, 1.1, -0.4, 0.0, 0.02};
const std::vector<double> kOwnVelocities = {-0.4, 0.7, 0.2, -0.8, 0.3, 0.6, -0.2, 0.0, 0.0};

// The robot request: the arm at (q, qdot) striking a box at rest, the joint state in the request
// when `own`, else the latest of /joint_states (which must then be q, qdot).
cr::ComputeResponse robotStrike(const std::vector<double>& q, const std::vector<double>& qdot,
                                bool own) {
  std::string urdf;
  if (!ros::param::get("/robot_description", urdf))
    throw std::runtime_error("no robot_description");
  return cr::testing::armStrikeRequest(urdf, q, qdot, own);
}

// Whether two answers to the same robot request agree: the computed numbers bit for bit (the same
// state gives the same arithmetic); header stamps and timings are left out.
bool sameRobotAnswer(const cr::ComputeResponse::Response& a,
                     const cr::ComputeResponse::Response& b) {
  if (!a.success || !b.success || a.robots.size() != 1 || b.robots.size() != 1) return false;
  const cr::RobotResult &ra = a.robots[0], &rb = b.robots[0];
  return ra.name == rb.name && ra.joint_state.name == rb.joint_state.name &&
         ra.joint_state.position == rb.joint_state.position &&
         ra.joint_state.velocity == rb.joint_state.velocity &&
         ra.joint_state.effort == rb.joint_state.effort &&
         ra.joint_state_before.position == rb.joint_state_before.position &&
         ra.joint_state_before.velocity == rb.joint_state_before.velocity &&
         ra.base_pose == rb.base_pose && a.effective_masses == b.effective_masses &&
         a.kinetic_energy_before == b.kinetic_energy_before &&
         a.kinetic_energy_after == b.kinetic_energy_after && a.bodies == b.bodies &&
         a.impulses == b.impulses;
}

// Resident memory of the node [kB], through its XML-RPC getPid and /proc.
long nodeResidentKilobytes() {
  XmlRpc::XmlRpcValue args, result, payload;
  args[0] = ros::this_node::getName();
  args[1] = "/collision_response";
  if (!ros::master::execute("lookupNode", args, result, payload, true)) return -1;
  std::string uri = payload;
  uri = uri.substr(uri.find("//") + 2);
  const std::string host = uri.substr(0, uri.find(':'));
  const int port = std::stoi(uri.substr(uri.find(':') + 1));
  XmlRpc::XmlRpcClient client(host.c_str(), port, "/");
  XmlRpc::XmlRpcValue pid_args, pid_result;
  pid_args[0] = ros::this_node::getName();
  if (!client.execute("getPid", pid_args, pid_result)) return -1;
  const int pid = pid_result[2];
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
  }
  return -1;
}

struct Counts {
  std::atomic<int> calls{0}, transport_failures{0}, wrong{0};
};

// The robot requests and their answers computed once, before the load.
struct RobotReference {
  cr::ComputeResponse own;    // the request's joint state
  cr::ComputeResponse topic;  // the latest of /joint_states
};

// One client thread: `calls` requests on one persistent connection, cycling good, robot (own joint
// state), bad, good, robot (joint state from the topic), oversized.
void client(int calls, const RobotReference& robot, Counts& counts) {
  ros::NodeHandle node;
  ros::ServiceClient service = node.serviceClient<cr::ComputeResponse>(kService, true);
  const cr::ComputeResponse requests[] = {good(), robot.own,   bad(),
                                          good(), robot.topic, oversized()};
  for (int i = 0; i < calls; ++i) {
    cr::ComputeResponse srv = requests[i % 6];
    srv.response = {};
    if (!service.isValid()) service = node.serviceClient<cr::ComputeResponse>(kService, true);
    if (!service.call(srv)) {
      ++counts.transport_failures;
      continue;
    }
    ++counts.calls;
    const auto& r = srv.response;
    bool right = false;
    switch (i % 6) {
      case 0:
      case 3:
        right = r.success && r.bodies.size() == 2 &&
                std::abs(r.bodies[0].twist.linear.x + 1.0) < 1e-9 &&
                std::abs(r.bodies[1].twist.linear.x - 0.5) < 1e-9;
        break;
      case 1:
        right = sameRobotAnswer(r, robot.own.response);
        break;
      case 4:
        right = sameRobotAnswer(r, robot.topic.response);
        break;
      case 2:
        right = !r.success && r.message.find("bodies[1].inertia.m") != std::string::npos;
        break;
      case 5:
        right = !r.success && r.message.rfind("bodies:", 0) == 0 &&
                r.message.find("limit of 50") != std::string::npos;
        break;
    }
    if (!right) {
      if (counts.wrong++ < 3)
        std::fprintf(stderr, "load: wrong answer to request %d: %s\n", i % 6, r.message.c_str());
    }
  }
}

void round(int threads, int calls_each, const RobotReference& robot, Counts& counts) {
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t)
    pool.emplace_back(client, calls_each, std::cref(robot), std::ref(counts));
  for (auto& thread : pool) thread.join();
}

// CR_LOAD_SCALE (default 1) multiplies the calls of each round: the benchmark's soak runs the same
// test with 10 (40,000 measured calls).
#if defined(__SANITIZE_ADDRESS__)
constexpr long kResidentGrowthBoundKilobytes = 8192;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr long kResidentGrowthBoundKilobytes = 8192;
#else
constexpr long kResidentGrowthBoundKilobytes = 2048;
#endif
#else
constexpr long kResidentGrowthBoundKilobytes = 2048;
#endif

int loadScale() {
  const char* value = std::getenv("CR_LOAD_SCALE");
  const int scale = value != nullptr ? std::atoi(value) : 1;
  return scale > 0 ? scale : 1;
}

TEST(Load, ConcurrentMixedRequestsAreAllAnsweredWithoutMemoryGrowth) {
  ASSERT_TRUE(ros::service::waitForService(kService, ros::Duration(20.0)));
  const int scale = loadScale();
  // The robot answers, once: the topic's request once the node has this test's joint states.
  RobotReference robot{robotStrike(kOwnPositions, kOwnVelocities, true),
                       robotStrike(kPublishedPositions, kPublishedVelocities, false)};
  ros::ServiceClient service = ros::NodeHandle().serviceClient<cr::ComputeResponse>(kService);
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(20.0);
  cr::ComputeResponse probe = robot.topic;
  while (ros::WallTime::now() < deadline && !(service.call(probe) && probe.response.success))
    ros::WallDuration(0.05).sleep();
  ASSERT_TRUE(service.call(robot.topic)) << "no answer to the robot request";
  ASSERT_TRUE(service.call(robot.own)) << "no answer to the robot request";
  for (const cr::ComputeResponse* srv : {&robot.own, &robot.topic}) {
    const auto& r = srv->response;
    ASSERT_TRUE(r.success) << r.message;
    ASSERT_EQ(r.robots.size(), 1u);
    ASSERT_EQ(r.impulses.size(), 1u);
    EXPECT_GT(r.impulses[0].normal_impulse, 0.0);  // the hand strikes the box
    EXPECT_EQ(r.effective_masses.size(), 1u);
  }
  EXPECT_EQ(robot.topic.response.robots[0].joint_state_before.position, kPublishedPositions);
  EXPECT_EQ(robot.topic.response.robots[0].joint_state_before.velocity, kPublishedVelocities);
  EXPECT_EQ(robot.own.response.robots[0].joint_state_before.velocity, kOwnVelocities);
  Counts warm_up;
  round(4, 250, robot, warm_up);  // allocator and connection warm-up
  const long before = nodeResidentKilobytes();
  ASSERT_GT(before, 0) << "could not read the node's memory";
  Counts first, second;
  const auto start = std::chrono::steady_clock::now();
  round(4, 500 * scale, robot, first);
  const long middle = nodeResidentKilobytes();
  round(4, 500 * scale, robot, second);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const long after = nodeResidentKilobytes();
  for (const Counts* counts : {&warm_up, &first, &second}) {
    EXPECT_EQ(counts->transport_failures.load(), 0);
    EXPECT_EQ(counts->wrong.load(), 0);
  }
  EXPECT_EQ(first.calls.load() + second.calls.load(), 4000 * scale);
  std::printf(
      "load: 4 clients, %d mixed calls (good, bad, oversized; robot with its own and the topic's "
      "joint states) in %.1f s (%.0f calls/s); "
      "node VmRSS %ld kB after warm-up, %ld kB after %d calls, %ld kB after %d\n",
      4000 * scale, seconds, 4000 * scale / seconds, before, middle, 2000 * scale, after,
      4000 * scale);
  // Gross leaks only: 1 kB per call would add 2 MB per round. Buffers of the oversized requests and
  // per-thread allocator arenas make a few hundred kB of noise; exact leak checks are the
  // LeakSanitizer build's (scripts/sanitize.sh). Under AddressSanitizer the node's own allocator
  // (redzones, its quarantine of freed blocks, per-thread caches) grew the node by 2.1 MB in a
  // round on a CI machine with LeakSanitizer finding no leak, so there the bound is 8 MB: growth
  // without a leak (an unbounded cache) is this test's to catch in the plain build.
  EXPECT_LT(after - middle, kResidentGrowthBoundKilobytes) << "resident memory keeps growing";
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_load");
  ros::NodeHandle node;
  // The arm's joint states during the load: 100 Hz, stamped now, from a spinner thread of its own.
  ros::Publisher joint_states = node.advertise<sensor_msgs::JointState>("/joint_states", 10);
  const ros::WallTimer publish =
      node.createWallTimer(ros::WallDuration(0.01), [&joint_states](const ros::WallTimerEvent&) {
        joint_states.publish(cr::testing::armJointState(kPublishedPositions, kPublishedVelocities));
      });
  ros::AsyncSpinner spinner(1);
  spinner.start();
  return RUN_ALL_TESTS();
}
