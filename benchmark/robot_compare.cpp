// The robot benchmark's scene (robot_scene.h) predicted by us and by DART (peer_dart.h): the
// velocity jumps of each and their errors against our Newton closed form, and the time of one
// prediction (ours: computeBodyResponse() with the state update, as bench_robot times it; DART:
// one World::step()). Writes one CSV row per method:
//   devel/lib/collision_response/robot_compare --out benchmark/data/robot_dart.csv [--reps N]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "collision_response/core/body_response.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/robot/articulated_body.h"
#include "collision_response/robot/urdf_loader.h"
#include "peer_dart.h"
#include "robot_scene.h"

namespace cr = collision_response::core;
namespace rb = collision_response::robot;
namespace bench = collision_response::bench;

namespace {

struct Answer {
  Eigen::VectorXd joint_change;  // [rad/s, m/s]
  Eigen::Vector3d box_change;    // [m/s]
  double normal_after = 0.0;     // u_n' [m/s]
  bool sticking = false;         // the contact ends sticking
  double ns = 0.0;               // median per prediction [ns]
};

Answer ours(const bench::ArmBoxScene& scene, cr::ImpactLaw law, int reps) {
  rb::ArticulatedBody arm = rb::robotFromUrdfFile(ROBOT_URDF_DIR "/arm7.urdf");
  const Eigen::VectorXd q = scene.q, qdot = scene.qdot;
  const int hand = arm.linkIndex("hand");
  arm.setState(q, qdot);
  const Eigen::Vector3d p = arm.linkPose(hand).translation();
  cr::ContactPoint contact(0, 1, p, scene.normal, scene.restitution, scene.static_friction,
                           scene.dynamic_friction);
  contact.part_a = hand;
  const std::vector<cr::ContactPoint> contacts = {contact};
  cr::SolverOptions options;
  options.law = law;
  const Eigen::Vector3d inertia = scene.boxInertia();
  Answer a;
  std::vector<double> ns;
  for (int r = 0; r < reps; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    arm.setState(q, qdot);
    cr::RigidBody box;
    box.inverse_mass = 1.0 / scene.box_mass;
    box.inverse_inertia = inertia.cwiseInverse().asDiagonal();
    box.com = p + scene.box_offset * scene.normal;
    box.linear_velocity = scene.box_velocity;
    const cr::BodyResponse out = cr::computeBodyResponse({&arm, &box}, contacts, options);
    const auto t1 = std::chrono::steady_clock::now();
    ns.push_back(std::chrono::duration<double, std::nano>(t1 - t0).count());
    a.joint_change = arm.jointVelocities() - qdot;
    a.box_change = box.linear_velocity - scene.box_velocity;
    a.normal_after = out.impulses[0].normal_velocity_after;
    a.sticking = out.impulses[0].sticking;
  }
  std::nth_element(ns.begin(), ns.begin() + ns.size() / 2, ns.end());
  a.ns = ns[ns.size() / 2];
  return a;
}

std::vector<std::string> jointNames() {
  return rb::robotFromUrdfFile(ROBOT_URDF_DIR "/arm7.urdf").jointNames();
}

}  // namespace

int main(int argc, char** argv) {
  std::string out_path = "robot_dart.csv";
  int reps = 2001;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--out")) out_path = argv[i + 1];
    if (!std::strcmp(argv[i], "--reps")) reps = std::stoi(argv[i + 1]);
  }
  const bench::ArmBoxScene scene;
  const Answer newton = ours(scene, cr::ImpactLaw::kNewton, reps);
  const Answer stronge = ours(scene, cr::ImpactLaw::kStronge, reps);
  auto err = [](const Eigen::VectorXd& x, const Eigen::VectorXd& ref) {
    return (x - ref).norm() / ref.norm();
  };
  std::ofstream csv(out_path);
  csv << "engine,method,ns_per_prediction,joint_err_newton,joint_err_stronge,box_err_newton,"
         "normal_velocity_before,normal_velocity_after,note\n";
  auto row = [&](const std::string& engine, const std::string& method, double ns,
                 const Eigen::VectorXd& dq, const Eigen::Vector3d& dv, double un, double un_after,
                 const std::string& note) {
    char line[512];
    std::snprintf(line, sizeof line, "%s,%s,%.1f,%.3e,%.3e,%.3e,%.6f,%.6f,%s\n", engine.c_str(),
                  method.c_str(), ns, err(dq, newton.joint_change), err(dq, stronge.joint_change),
                  (dv - newton.box_change).norm() / newton.box_change.norm(), un, un_after,
                  note.c_str());
    csv << line;
    std::cout << line;
  };
  // u_n before, from our side: the box's velocity less the hand's at the contact.
  rb::ArticulatedBody arm = rb::robotFromUrdfFile(ROBOT_URDF_DIR "/arm7.urdf");
  arm.setState(scene.q, scene.qdot);
  const int hand = arm.linkIndex("hand");
  const Eigen::Vector3d p = arm.linkPose(hand).translation();
  const double un = scene.normal.dot(scene.box_velocity - arm.partPointVelocity(hand, p));
  row("ours", "newton_closed_form", newton.ns, newton.joint_change, newton.box_change, un,
      newton.normal_after,
      newton.sticking ? "the reference; the contact sticks" : "the reference; the contact slides");
  row("ours", "stronge", stronge.ns, stronge.joint_change, stronge.box_change, un,
      stronge.normal_after,
      stronge.sticking ? "Stronge's energetic e; sticks at the end"
                       : "Stronge's energetic e; slides at the end");

  struct Config {
    const char* name;
    bench::DartArmBoxConfig config;
  };
  std::vector<Config> configs(3);
  configs[0].name = "dart_dantzig";
  configs[1].name = "dart_dantzig cfm=1e-9";
  configs[1].config.cfm = 1e-9;
  configs[2].name = "dart_pgs";
  configs[2].config.pgs = true;
  const std::vector<std::string> names = jointNames();
  for (const Config& c : configs) {
    const bench::DartArmBoxRun d = bench::runDartArmBox(
        ROBOT_URDF_DIR "/arm7.urdf", ROBOT_PACKAGE_DIR, names, scene, c.config, reps);
    std::string note = d.note;
    const double offset = (d.hand_origin - p).norm();
    if (offset > 1e-12) {
      char buf[96];
      std::snprintf(buf, sizeof buf, "%scontact point %.1e m from ours", note.empty() ? "" : "; ",
                    offset);
      note += buf;
    }
    row("dart", c.name, d.ns_per_step, d.joint_velocity_change, d.box_velocity_change,
        d.normal_velocity_before, d.normal_velocity_after, note);
  }
  std::cout << "robot_compare: wrote " << out_path << "\n";
  return 0;
}
