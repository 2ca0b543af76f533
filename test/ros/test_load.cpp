// Load: several concurrent clients on persistent connections, thousands of calls mixing good, bad
// and oversized requests. Every call is answered correctly, and the node's memory does not grow.
#include <collision_response/ComputeResponse.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <xmlrpcpp/XmlRpcClient.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <string>
#include <thread>
#include <vector>

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

// One client thread: `calls` requests on one persistent connection, cycling good, bad, oversized.
void client(int calls, Counts& counts) {
  ros::NodeHandle node;
  ros::ServiceClient service = node.serviceClient<cr::ComputeResponse>(kService, true);
  const cr::ComputeResponse requests[] = {good(), good(), bad(), oversized()};
  for (int i = 0; i < calls; ++i) {
    cr::ComputeResponse srv = requests[i % 4];
    if (!service.isValid()) service = node.serviceClient<cr::ComputeResponse>(kService, true);
    if (!service.call(srv)) {
      ++counts.transport_failures;
      continue;
    }
    ++counts.calls;
    const auto& r = srv.response;
    bool right = false;
    switch (i % 4) {
      case 0:
      case 1:
        right = r.success && r.bodies.size() == 2 &&
                std::abs(r.bodies[0].twist.linear.x + 1.0) < 1e-9 &&
                std::abs(r.bodies[1].twist.linear.x - 0.5) < 1e-9;
        break;
      case 2:
        right = !r.success && r.message.find("bodies[1].inertia.m") != std::string::npos;
        break;
      case 3:
        right = !r.success && r.message.rfind("bodies:", 0) == 0 &&
                r.message.find("limit of 50") != std::string::npos;
        break;
    }
    if (!right) ++counts.wrong;
  }
}

void round(int threads, int calls_each, Counts& counts) {
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) pool.emplace_back(client, calls_each, std::ref(counts));
  for (auto& thread : pool) thread.join();
}

// CR_LOAD_SCALE (default 1) multiplies the calls of each round: the benchmark's soak runs the same
// test with 10 (40,000 measured calls).
int loadScale() {
  const char* value = std::getenv("CR_LOAD_SCALE");
  const int scale = value != nullptr ? std::atoi(value) : 1;
  return scale > 0 ? scale : 1;
}

TEST(Load, ConcurrentMixedRequestsAreAllAnsweredWithoutMemoryGrowth) {
  ASSERT_TRUE(ros::service::waitForService(kService, ros::Duration(20.0)));
  const int scale = loadScale();
  Counts warm_up;
  round(4, 250, warm_up);  // allocator and connection warm-up
  const long before = nodeResidentKilobytes();
  ASSERT_GT(before, 0) << "could not read the node's memory";
  Counts first, second;
  const auto start = std::chrono::steady_clock::now();
  round(4, 500 * scale, first);
  const long middle = nodeResidentKilobytes();
  round(4, 500 * scale, second);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const long after = nodeResidentKilobytes();
  for (const Counts* counts : {&warm_up, &first, &second}) {
    EXPECT_EQ(counts->transport_failures.load(), 0);
    EXPECT_EQ(counts->wrong.load(), 0);
  }
  EXPECT_EQ(first.calls.load() + second.calls.load(), 4000 * scale);
  std::printf(
      "load: 4 clients, %d mixed calls (good, bad, oversized) in %.1f s (%.0f calls/s); "
      "node VmRSS %ld kB after warm-up, %ld kB after %d calls, %ld kB after %d\n",
      4000 * scale, seconds, 4000 * scale / seconds, before, middle, 2000 * scale, after,
      4000 * scale);
  // Gross leaks only: 1 kB per call would add 2 MB per round. Buffers of the oversized requests and
  // per-thread allocator arenas make a few hundred kB of noise; exact leak checks are the
  // LeakSanitizer build's (scripts/sanitize.sh).
  EXPECT_LT(after - middle, 2048) << "resident memory keeps growing";
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_load");
  ros::NodeHandle node;
  return RUN_ALL_TESTS();
}
