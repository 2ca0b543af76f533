// One impact prediction for a robot (docs/robots.md): the 7-DOF arm of urdf/arm7.urdf (fixed
// base, 9 joints with the gripper's) strikes a free box with its hand, one frictional contact,
// Stronge. The model is loaded once; per request: the state (kinematics, M(q) by CRBA, its
// Cholesky factor), the contact's Jacobian and M^-1 J^T, the solve and the joint velocities.
// The scene is robot_scene.h's (robot_peer_dart gives DART the same one).
//   devel/lib/collision_response/bench_robot            (Release build)
// BM_Arm7StrikesBox: every joint free; BM_Arm7LockedStrikesBox: every joint locked (the arm an
// immovable body, the box alone moves).
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "collision_response/core/body_response.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/robot/articulated_body.h"
#include "collision_response/robot/urdf_loader.h"
#include "robot_scene.h"

namespace cr = collision_response::core;
namespace rb = collision_response::robot;

namespace {

void run(benchmark::State& state, bool locked) {
  const bool newton = state.range(0) == 1;
  const collision_response::bench::ArmBoxScene scene;
  rb::ArticulatedBody arm = rb::robotFromUrdfFile(ROBOT_URDF_DIR "/arm7.urdf");
  if (locked) {
    for (int j = 0; j < arm.jointCount(); ++j) arm.setJointModel(j, rb::JointModel::kLocked);
  }
  const Eigen::VectorXd q = scene.q, qdot = scene.qdot;
  const int hand = arm.linkIndex("hand");
  arm.setState(q, qdot);
  const Eigen::Vector3d p = arm.linkPose(hand).translation();
  const Eigen::Vector3d n = scene.normal;
  cr::ContactPoint contact(0, 1, p, n, scene.restitution, scene.static_friction,
                           scene.dynamic_friction);
  contact.part_a = hand;
  const std::vector<cr::ContactPoint> contacts = {contact};
  cr::SolverOptions options;
  options.law = newton ? cr::ImpactLaw::kNewton : cr::ImpactLaw::kStronge;
  const Eigen::Vector3d inertia = scene.boxInertia();
  for (auto _ : state) {
    arm.setState(q, qdot);
    cr::RigidBody box;
    box.inverse_mass = 1.0 / scene.box_mass;
    box.inverse_inertia = inertia.cwiseInverse().asDiagonal();
    box.com = p + scene.box_offset * n;
    box.linear_velocity = scene.box_velocity;
    const cr::BodyResponse out = cr::computeBodyResponse({&arm, &box}, contacts, options);
    benchmark::DoNotOptimize(out.impulses[0].normal_impulse);
    benchmark::DoNotOptimize(arm.jointVelocities().data());
  }
}

// A resting prediction (docs/robots.md, "Resting contacts"): the arm at rest at the scene's q, its
// hand on a table (n = +z), gravity -z, its actuators pushing 20 N into the table. Per request:
// the state, the loads, and computeBodyResponse() (an island without an approaching contact: the
// free acceleration by two Newton-Euler passes and M's factor, the force in closed form).
// Argument 0: the torques given (as JointState.effort); 1: gravity compensation computed per
// request (the node's default), no push.
void BM_Arm7RestsOnTable(benchmark::State& state) {
  const bool compensation = state.range(0) == 1;
  const collision_response::bench::ArmBoxScene scene;
  rb::ArticulatedBody arm = rb::robotFromUrdfFile(ROBOT_URDF_DIR "/arm7.urdf");
  const Eigen::VectorXd q = scene.q, rest = Eigen::VectorXd::Zero(arm.jointCount());
  const Eigen::Vector3d g(0, 0, -9.81), n = Eigen::Vector3d::UnitZ();
  const int hand = arm.linkIndex("hand");
  arm.setState(q, rest);
  const Eigen::Vector3d p = arm.linkPose(hand).translation();
  arm.setLoads(rest, g);
  const Eigen::VectorXd push =
      arm.gravityTorques() - arm.linkPointJacobian(hand, p).transpose() * n * 20.0;
  cr::ContactPoint contact(0, 1, p, n, 0.0, scene.static_friction, scene.dynamic_friction);
  contact.part_b = hand;
  const std::vector<cr::ContactPoint> contacts = {contact};
  cr::RigidBody table;
  for (auto _ : state) {
    arm.setState(q, rest);
    if (compensation) {
      arm.setGravityCompensation(g);
    } else {
      arm.setLoads(push, g);
    }
    const cr::BodyResponse out = cr::computeBodyResponse({&table, &arm}, contacts);
    benchmark::DoNotOptimize(out.impulses[0].normal_force);
  }
}

// Preparing a request as the node does (ros/robot_conversion.cpp, robotAtRequestState()): the
// served robot is copied and the copy takes the request's state; with `locked` joints, the
// request's own locks too. Not inlined, so that callgrind can count them alone:
//   valgrind --tool=callgrind --toggle-collect='*prepareRequest*' bench_robot \
//     --benchmark_filter=BM_Arm7PrepareRequest
// The copy is the data alone (the model is shared); the locks are held in it.
__attribute__((noinline)) rb::ArticulatedBody prepareRequest(const rb::ArticulatedBody& served,
                                                             const std::vector<bool>& locked,
                                                             const Eigen::VectorXd& q,
                                                             const Eigen::VectorXd& qdot) {
  rb::ArticulatedBody arm = served;
  if (!locked.empty()) arm.setLockedJoints(locked);
  arm.setState(q, qdot);
  return arm;
}

// Argument: 0 the entry's joint models, 1 the request locks joint6 and joint7.
void BM_Arm7PrepareRequest(benchmark::State& state) {
  const collision_response::bench::ArmBoxScene scene;
  const rb::ArticulatedBody served = rb::robotFromUrdfFile(ROBOT_URDF_DIR "/arm7.urdf");
  std::vector<bool> locked;
  if (state.range(0) == 1) {
    locked.assign(served.jointCount(), false);
    locked[served.jointIndex("joint6")] = locked[served.jointIndex("joint7")] = true;
  }
  const Eigen::VectorXd q = scene.q, qdot = scene.qdot;
  for (auto _ : state) {
    const rb::ArticulatedBody arm = prepareRequest(served, locked, q, qdot);
    benchmark::DoNotOptimize(arm.massMatrix().data());
  }
}

void BM_Arm7StrikesBox(benchmark::State& state) {
  run(state, false);
}
void BM_Arm7LockedStrikesBox(benchmark::State& state) {
  run(state, true);
}

}  // namespace

// Argument: 0 Stronge (impulse-space integration of the frictional contact, 3D slip), 1 Newton
// (closed form): the difference is the law's cost, the rest the robot's.
BENCHMARK(BM_Arm7StrikesBox)->Arg(0)->Arg(1);
BENCHMARK(BM_Arm7LockedStrikesBox)->Arg(0)->Arg(1);
BENCHMARK(BM_Arm7RestsOnTable)->Arg(0)->Arg(1);
BENCHMARK(BM_Arm7PrepareRequest)->Arg(0)->Arg(1);
BENCHMARK_MAIN();
