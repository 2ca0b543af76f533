// Per-contact cost of each impact law and solver (Google Benchmark).
//   devel/lib/collision_response/bench_solvers            (Release build)
// Closed forms are timed in a batch loop over pre-built contact-problem entries (K, frame and u of
// each contact computed once, as a caller embedding the core would keep them); the multi-contact
// scenes go through computeResponse() (validation and building the contact problem included).
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <random>
#include <vector>

#include "collision_response/core/compute_response.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/contact_problem.h"
#include "collision_response/core/impulse_space_integrator.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/single_contact.h"

namespace core = collision_response::core;

namespace {

// Random off-centre contacts between two free bodies (or a body and the immovable ground).
struct ContactBatch {
  std::vector<core::RigidBody> a, b;
  std::vector<core::ProblemContact> rows;
};

core::BodyState randomBody(std::mt19937& rng, bool immovable) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0), positive(0.5, 2.0);
  core::BodyState body;
  body.id = "body";
  if (!immovable) {
    body.mass = positive(rng);
    const double x = positive(rng), y = positive(rng), z = std::min(x + y, positive(rng));
    body.inertia = Eigen::Vector3d(x, y, z).asDiagonal();
  }
  body.orientation = Eigen::Quaterniond(unit(rng), unit(rng), unit(rng), unit(rng)).normalized();
  body.position = Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
  body.linear_velocity = Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
  body.angular_velocity = Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
  return body;
}

ContactBatch makeBatch(std::size_t count, double mu, bool planar, unsigned seed = 7) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  ContactBatch batch;
  while (batch.rows.size() < count) {
    core::BodyState ground = randomBody(rng, true);
    core::BodyState body = randomBody(rng, false);
    Eigen::Vector3d normal(unit(rng), unit(rng), unit(rng));
    Eigen::Vector3d point(unit(rng), unit(rng), unit(rng));
    if (planar) {  // everything in the x-y plane, rotation about z only
      ground = core::BodyState{};
      body.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(unit(rng), Eigen::Vector3d::UnitZ()));
      body.position.z() = point.z() = normal.z() = 0.0;
      body.linear_velocity.z() = 0.0;
      body.angular_velocity.x() = body.angular_velocity.y() = 0.0;
    }
    normal.normalize();
    batch.a.push_back(core::makeRigidBody(ground));
    batch.b.push_back(core::makeRigidBody(body));
    const core::ProblemContact row = core::ContactProblem::rigidImpactContact(
        batch.a.back(), batch.b.back(), core::ContactPoint(0, 1, point, normal, 0.5, mu, 0.8 * mu));
    if (row.normal.dot(row.free_velocity) >= 0.0) {
      batch.a.pop_back();
      batch.b.pop_back();
      continue;  // keep approaching contacts only
    }
    batch.rows.push_back(row);
  }
  return batch;
}

// u = v_b(p) - v_a(p) from the bodies' current velocities (the entry's K and lever arms are kept;
// the velocities are what changes from one impact to the next), as the solvers read it before.
Eigen::Vector3d relativeVelocity(const ContactBatch& batch, std::size_t i) {
  const core::ProblemContact& row = batch.rows[i];
  return batch.b[i].pointVelocity(row.lever_arm_b) - batch.a[i].pointVelocity(row.lever_arm_a);
}

void closedForm(benchmark::State& state, double mu, core::ImpactLaw law) {
  const ContactBatch batch = makeBatch(1024, mu, false);
  for (auto _ : state) {
    for (std::size_t i = 0; i < batch.rows.size(); ++i) {
      benchmark::DoNotOptimize(
          core::solveSingleContact(batch.rows[i], relativeVelocity(batch, i), law));
    }
  }
  state.SetItemsProcessed(state.iterations() * batch.rows.size());
}

void BM_Newton_Frictionless(benchmark::State& state) {
  closedForm(state, 0.0, core::ImpactLaw::kNewton);
}
void BM_Newton_Friction(benchmark::State& state) {
  closedForm(state, 0.6, core::ImpactLaw::kNewton);
}
void BM_SeedOnePass_Friction(benchmark::State& state) {
  closedForm(state, 0.6, core::ImpactLaw::kSeedOnePass);
}

void impulseSpace(benchmark::State& state, core::ImpactLaw law, bool planar) {
  const double tolerance = std::pow(10.0, -static_cast<double>(state.range(0)));
  const ContactBatch batch = makeBatch(256, 0.6, planar);
  for (auto _ : state) {
    for (std::size_t i = 0; i < batch.rows.size(); ++i) {
      benchmark::DoNotOptimize(
          core::integrateSingleContact(batch.rows[i], relativeVelocity(batch, i), law, tolerance));
    }
  }
  state.SetItemsProcessed(state.iterations() * batch.rows.size());
}

void BM_Stronge_3D(benchmark::State& state) {
  impulseSpace(state, core::ImpactLaw::kStronge, false);
}
void BM_Poisson_3D(benchmark::State& state) {
  impulseSpace(state, core::ImpactLaw::kPoisson, false);
}
void BM_Stronge_Planar(benchmark::State& state) {
  impulseSpace(state, core::ImpactLaw::kStronge, true);
}

// A unit cube landing flat on the ground: 4 corner contacts, one island.
core::Scene cubeScene(double mu) {
  core::Scene scene;
  core::BodyState ground;
  ground.id = "ground";
  core::BodyState cube;
  cube.id = "cube";
  cube.mass = 1.0;
  cube.inertia = Eigen::Matrix3d::Identity() / 6.0;
  cube.position = {0.0, 0.5, 0.0};
  cube.linear_velocity = {0.3, -1.0, 0.1};
  scene.bodies = {ground, cube};
  for (const double x : {-0.5, 0.5}) {
    for (const double z : {-0.5, 0.5}) {
      core::Contact contact;
      contact.body_a = "ground";
      contact.body_b = "cube";
      contact.point = {x, 0.0, z};
      contact.normal = {0.0, 1.0, 0.0};
      contact.restitution = 0.5;
      contact.static_friction = mu;
      contact.dynamic_friction = 0.8 * mu;
      scene.contacts.push_back(contact);
    }
  }
  return scene;
}

// A row of spheres along x, each touching the next, the first one moving: n - 1 contacts.
core::Scene chainScene(int spheres, double mu) {
  core::Scene scene;
  for (int i = 0; i < spheres; ++i) {
    core::BodyState ball;
    ball.id = "ball" + std::to_string(i);
    ball.mass = 1.0;
    ball.inertia = Eigen::Matrix3d::Identity() * 0.004;
    ball.position = {0.2 * i, 0.0, 0.0};
    ball.linear_velocity = {i == 0 ? 1.0 : 0.0, 0.0, i == 0 ? 0.2 : 0.0};
    scene.bodies.push_back(ball);
    if (i > 0) {
      core::Contact contact;
      contact.body_a = scene.bodies[i - 1].id;
      contact.body_b = ball.id;
      contact.point = {0.2 * i - 0.1, 0.0, 0.0};
      contact.normal = {1.0, 0.0, 0.0};
      contact.restitution = 0.5;
      contact.static_friction = mu;
      contact.dynamic_friction = 0.8 * mu;
      scene.contacts.push_back(contact);
    }
  }
  return scene;
}

void scene(benchmark::State& state, const core::Scene& scene, core::ImpactLaw law,
           core::SolverMethod method, bool simultaneous = false,
           core::SimultaneousSharing sharing = core::SimultaneousSharing::kSpring) {
  core::SolverOptions options;
  options.law = law;
  options.method = method;
  options.simultaneous_impulse_space = simultaneous;
  options.simultaneous_sharing = sharing;
  options.tolerance = 1e-10;
  for (auto _ : state) benchmark::DoNotOptimize(core::computeResponse(scene, options));
  state.SetItemsProcessed(state.iterations() * scene.contacts.size());
}

void BM_Cube4_Newton_Exact(benchmark::State& s) {
  scene(s, cubeScene(0.5), core::ImpactLaw::kNewton, core::SolverMethod::kExact);
}
void BM_Cube4_Newton_Iterative(benchmark::State& s) {
  scene(s, cubeScene(0.5), core::ImpactLaw::kNewton, core::SolverMethod::kIterative);
}
void BM_Cube4_Stronge_Exact(benchmark::State& s) {
  scene(s, cubeScene(0.5), core::ImpactLaw::kStronge, core::SolverMethod::kExact);
}
// The simultaneous impulse-space integration (the default for Poisson / Stronge islands,
// SolverOptions::simultaneous_impulse_space) with the spring sharing rule
// (SolverOptions::simultaneous_sharing = kSpring).
void BM_Cube4_Stronge_Simultaneous(benchmark::State& s) {
  scene(s, cubeScene(0.5), core::ImpactLaw::kStronge, core::SolverMethod::kAuto, true);
}
// The same with the velocity-consistent sharing rule (the default).
void BM_Cube4_Stronge_SimultaneousConsistent(benchmark::State& s) {
  scene(s, cubeScene(0.5), core::ImpactLaw::kStronge, core::SolverMethod::kAuto, true,
        core::SimultaneousSharing::kVelocityConsistent);
}
void BM_Chain_Newton_Iterative(benchmark::State& s) {
  scene(s, chainScene(static_cast<int>(s.range(0)), 0.3), core::ImpactLaw::kNewton,
        core::SolverMethod::kIterative);
}
void BM_Chain_Newton_Exact(benchmark::State& s) {
  scene(s, chainScene(static_cast<int>(s.range(0)), 0.3), core::ImpactLaw::kNewton,
        core::SolverMethod::kExact);
}
void BM_SingleContact_ComputeResponse(benchmark::State& s) {
  scene(s, chainScene(2, 0.3), core::ImpactLaw::kNewton, core::SolverMethod::kAuto);
}

}  // namespace

BENCHMARK(BM_Newton_Frictionless);
BENCHMARK(BM_Newton_Friction);
BENCHMARK(BM_SeedOnePass_Friction);
BENCHMARK(BM_Stronge_Planar)->Arg(9);
BENCHMARK(BM_Stronge_3D)->Arg(6)->Arg(9)->Arg(12);
BENCHMARK(BM_Poisson_3D)->Arg(9);
BENCHMARK(BM_Cube4_Newton_Exact);
BENCHMARK(BM_Cube4_Newton_Iterative);
BENCHMARK(BM_Cube4_Stronge_Exact);
BENCHMARK(BM_Cube4_Stronge_Simultaneous);
BENCHMARK(BM_Cube4_Stronge_SimultaneousConsistent);
BENCHMARK(BM_Chain_Newton_Exact)->Arg(4)->Arg(13);
BENCHMARK(BM_Chain_Newton_Iterative)->Arg(4)->Arg(13)->Arg(64);
BENCHMARK(BM_SingleContact_ComputeResponse);
BENCHMARK_MAIN();
