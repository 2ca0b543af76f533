// Service cost: round-trip latency and throughput of /collision_response/compute through one
// persistent roscpp connection, for requests of 1, 10 and 100 contacts (that many boxes, each
// striking the immovable ground on one off-centre frictional contact; the node's default law and
// solver), and the share of the round trip spent in the solver (response.solve_time). With
// --node-pid it also reads the node's peak resident size (VmHWM) after each request size.
// Robot rows, when the node serves robot "arm" (the shipped 7-DOF arm, urdf/arm7.urdf, from
// /robot_description, its base_link at the world origin through tf): the hand striking a 2 kg box,
// itself moving towards the hand at 1 m/s, at one contact, with the arm's full joint state in the
// request (robot_request_state), and with the request naming only the robot (robot_topic_state:
// the node takes the latest /joint_states, which this program publishes at 100 Hz, so no other
// node should publish them).
//   service_load [--calls N] [--out FILE] [--node-pid PID]
// Output CSV: case,contacts,calls,median_us,p99_us,mean_us,calls_per_s,solve_median_us,
// solver_share,node_vmhwm_kib; case is rigid, robot_request_state or robot_topic_state.
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "arm_strike.h"
#include "collision_response/ComputeResponse.h"

namespace {

/// `contacts` boxes (0.5..2 kg) above the immovable ground, each landing on one corner-like
/// off-centre point: e = 0.5, mu_s = 0.6, mu_d = 0.5, all approaching.
collision_response::ComputeResponse::Request makeRequest(int contacts, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), positive(0.5, 2.0);
  collision_response::ComputeResponse::Request req;
  req.header.frame_id = "world";
  collision_response::BodyState ground;
  ground.id = "ground";
  ground.pose.orientation.w = 1.0;
  req.bodies.push_back(ground);
  for (int i = 0; i < contacts; ++i) {
    collision_response::BodyState box;
    box.id = "box" + std::to_string(i);
    box.inertia.m = positive(rng);
    box.inertia.ixx = box.inertia.iyy = box.inertia.izz = 0.02 * box.inertia.m;
    box.pose.position.x = 2.0 * i;
    box.pose.position.z = 0.2;
    box.pose.orientation.w = 1.0;
    box.twist.linear.x = unit(rng);
    box.twist.linear.y = unit(rng);
    box.twist.linear.z = -1.0 - positive(rng);
    box.twist.angular.x = 0.5 * unit(rng);
    box.twist.angular.y = 0.5 * unit(rng);
    box.twist.angular.z = 0.5 * unit(rng);
    req.bodies.push_back(box);
    collision_response::Contact c;
    c.body_a = "ground";
    c.body_b = box.id;
    c.point.x = box.pose.position.x + 0.1 * unit(rng);
    c.point.y = 0.1 * unit(rng);
    c.point.z = 0.0;
    c.normal.z = 1.0;
    c.restitution = 0.5;
    c.static_friction = 0.6;
    c.dynamic_friction = 0.5;
    req.contacts.push_back(c);
  }
  return req;
}

// The arm's state for the robot rows (kArmJoints order).
const std::vector<double>& kArmPositions = collision_response::testing::kArmSwingPositions;
const std::vector<double>& kArmVelocities = collision_response::testing::kArmSwingVelocities;

double quantile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * v.size()))];
}

/// Peak resident size [KiB] of process `pid` (VmHWM in /proc/PID/status), -1 if unknown.
long peakRss(int pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stol(line.substr(6));
  return -1;
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "collision_response_service_load", ros::init_options::AnonymousName);
  int calls = 2000, node_pid = -1;
  std::string out_path = "benchmark/service_load.csv";
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--calls") && i + 1 < argc) calls = std::atoi(argv[++i]);
    if (!std::strcmp(argv[i], "--out") && i + 1 < argc) out_path = argv[++i];
    if (!std::strcmp(argv[i], "--node-pid") && i + 1 < argc) node_pid = std::atoi(argv[++i]);
  }
  ros::NodeHandle nh;
  const std::string name = "/collision_response/compute";
  if (!ros::service::waitForService(name, ros::Duration(30.0))) {
    std::fprintf(stderr, "service_load: %s not available\n", name.c_str());
    return 1;
  }
  ros::ServiceClient client =
      nh.serviceClient<collision_response::ComputeResponse>(name, /*persistent=*/true);
  FILE* out = std::fopen(out_path.c_str(), "w");
  if (!out) {
    std::perror(out_path.c_str());
    return 1;
  }
  std::fprintf(out,
               "case,contacts,calls,median_us,p99_us,mean_us,calls_per_s,solve_median_us,"
               "solver_share,node_vmhwm_kib\n");
  // `n` timed calls of `request` after a warm-up of the connection and the node; one CSV row.
  const auto measure = [&](const char* label, int contacts, int n,
                           const collision_response::ComputeResponse::Request& request) {
    collision_response::ComputeResponse srv;
    srv.request = request;
    for (int i = 0; i < 50; ++i) client.call(srv);
    std::vector<double> round_trip, solve, share;
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < n; ++i) {
      const auto t0 = std::chrono::steady_clock::now();
      const bool ok = client.call(srv);
      const auto t1 = std::chrono::steady_clock::now();
      if (!ok || !srv.response.success) {
        std::fprintf(stderr, "service_load: %s call failed: %s\n", label,
                     srv.response.message.c_str());
        return false;
      }
      const double us = std::chrono::duration<double, std::micro>(t1 - t0).count();
      round_trip.push_back(us);
      solve.push_back(srv.response.solve_time * 1e6);
      share.push_back(srv.response.solve_time * 1e6 / us);
    }
    const double total_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    double mean = 0.0;
    for (const double t : round_trip) mean += t / round_trip.size();
    std::fprintf(out, "%s,%d,%d,%.1f,%.1f,%.1f,%.0f,%.2f,%.4f,%ld\n", label, contacts, n,
                 quantile(round_trip, 0.5), quantile(round_trip, 0.99), mean, n / total_s,
                 quantile(solve, 0.5), quantile(share, 0.5), node_pid > 0 ? peakRss(node_pid) : -1);
    std::fflush(out);
    std::fprintf(stderr,
                 "service_load: %s, %d contact(s): median %.1f us, p99 %.1f us, solver %.1f us "
                 "(%.0f%%)\n",
                 label, contacts, quantile(round_trip, 0.5), quantile(round_trip, 0.99),
                 quantile(solve, 0.5), 100 * quantile(share, 0.5));
    return true;
  };
  for (const int contacts : {1, 10, 100}) {
    const int n = contacts == 100 ? std::max(1, calls / 4) : calls;
    if (!measure("rigid", contacts, n, makeRequest(contacts, 42))) return 1;
  }

  // Robot rows: only when the node serves robot "arm" of /robot_description.
  std::string urdf;
  XmlRpc::XmlRpcValue robots;
  bool serves_arm = false;
  if (ros::param::get("/collision_response/robots", robots) &&
      robots.getType() == XmlRpc::XmlRpcValue::TypeArray)
    for (int i = 0; i < robots.size(); ++i)
      serves_arm = serves_arm || (robots[i].hasMember("name") &&
                                  static_cast<std::string>(robots[i]["name"]) == "arm");
  if (!serves_arm || !ros::param::get("/robot_description", urdf)) {
    std::fprintf(stderr,
                 "service_load: the node serves no robot \"arm\" of /robot_description: robot "
                 "rows left out\n");
    std::fclose(out);
    return 0;
  }
  // The arm's joint states for the node, 100 Hz from a spinner thread of their own.
  ros::Publisher joint_states = nh.advertise<sensor_msgs::JointState>("/joint_states", 10);
  const ros::WallTimer publish =
      nh.createWallTimer(ros::WallDuration(0.01), [&joint_states](const ros::WallTimerEvent&) {
        joint_states.publish(
            collision_response::testing::armJointState(kArmPositions, kArmVelocities));
      });
  ros::AsyncSpinner spinner(1);
  spinner.start();
  const auto topic_request =
      collision_response::testing::armStrikeRequest(urdf, kArmPositions, kArmVelocities, false,
                                                    /*box_speed=*/1.0)
          .request;
  {  // until the node has the joint states
    collision_response::ComputeResponse probe;
    probe.request = topic_request;
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(10.0);
    while (ros::WallTime::now() < deadline && !(client.call(probe) && probe.response.success))
      ros::WallDuration(0.05).sleep();
  }
  if (!measure("robot_request_state", 1, calls,
               collision_response::testing::armStrikeRequest(urdf, kArmPositions, kArmVelocities,
                                                             true, /*box_speed=*/1.0)
                   .request) ||
      !measure("robot_topic_state", 1, calls, topic_request))
    return 1;
  std::fclose(out);
  return 0;
}
