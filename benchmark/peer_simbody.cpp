// Simbody peer adapter (see peer_simbody.h).
#include "peer_simbody.h"

#include <Simbody.h>
#include <fcntl.h>
#include <unistd.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>

#include "peer_isolated.h"

namespace collision_response::bench {
namespace {

constexpr double kStep = 1e-12;  // [s]: the step's smooth motion (gyroscopic terms) is negligible

SimTK::Vec3 vec(const Eigen::Vector3d& v) {
  return SimTK::Vec3(v.x(), v.y(), v.z());
}
Eigen::Vector3d eig(const SimTK::Vec3& v) {
  return Eigen::Vector3d(v[0], v[1], v[2]);
}

/// The gist of a Simbody exception: its message names where it was thrown on a first line, then
/// "Error detected by Simbody method M(): what; details" on the next; this keeps "what".
std::string gist(const std::exception& e) {
  std::string what = e.what();
  const std::size_t method = what.find("Error detected by Simbody method");
  if (method != std::string::npos) {
    const std::size_t colon = what.find("): ", method);
    if (colon != std::string::npos) what = what.substr(colon + 3);
  }
  const std::size_t start = what.find_first_not_of(" \n");
  if (start == std::string::npos) return what;
  return what.substr(start, what.find_first_of(";\n", start) - start);
}

/// Debian's libsimbody is built without NDEBUG: its stepper and impulse solvers print a trace of
/// every step on standard output. While one of these lives, standard output goes to /dev/null.
class SilencedStdout {
 public:
  SilencedStdout() {
    std::cout.flush();
    std::fflush(stdout);
    saved_ = dup(STDOUT_FILENO);
    const int null = open("/dev/null", O_WRONLY);
    if (null >= 0) {
      dup2(null, STDOUT_FILENO);
      close(null);
    }
  }
  ~SilencedStdout() {
    std::cout.flush();
    std::fflush(stdout);
    if (saved_ >= 0) {
      dup2(saved_, STDOUT_FILENO);
      close(saved_);
    }
  }
  SilencedStdout(const SilencedStdout&) = delete;
  SilencedStdout& operator=(const SilencedStdout&) = delete;

 private:
  int saved_ = -1;
};

/// Where a body of the scene is in Simbody: its mobilized body and its body frame in the world
/// (Ground: the identity).
struct Placed {
  SimTK::MobilizedBody mobod;
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  ///< body frame to world
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();                 ///< [m] world
  bool movable = false;

  Eigen::Vector3d toBody(const Eigen::Vector3d& world_point) const {
    return orientation.conjugate() * (world_point - origin);
  }
};

/// runSimbody() without its guards: throws what Simbody throws (SimTK::Exception::Base is a
/// std::exception).
PeerRun simulate(const core::Scene& scene, const SimbodyConfig& config, int repetitions) {
  PeerRun run;
  SimTK::MultibodySystem system;
  SimTK::SimbodyMatterSubsystem matter(system);
  std::vector<Placed> placed;
  for (const auto& b : scene.bodies) {
    Placed p{matter.updGround()};
    if (b.mass > 0.0) {
      // Body frame at the centre of mass, along the body axes of our inertia.
      SimTK::Mat33 inertia;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) inertia(i, j) = b.inertia(i, j);
      const SimTK::Body::Rigid body(
          SimTK::MassProperties(b.mass, SimTK::Vec3(0), SimTK::Inertia(inertia)));
      p.mobod = SimTK::MobilizedBody::Free(matter.updGround(), SimTK::Transform(), body,
                                           SimTK::Transform());
      p.orientation = b.orientation.normalized();
      p.origin = b.worldCom();
      p.movable = true;
    }
    placed.push_back(p);
  }
  auto index = [&](const std::string& id) {
    for (std::size_t i = 0; i < scene.bodies.size(); ++i)
      if (scene.bodies[i].id == id) return static_cast<int>(i);
    return -1;
  };
  for (const auto& c : scene.contacts) {
    Placed& a = placed[index(c.body_a)];
    Placed& b = placed[index(c.body_b)];
    // The plane on a: through our point, normal n (towards b); the follower point on b.
    const Eigen::Vector3d normal_a = a.orientation.conjugate() * c.normal;
    const double height = normal_a.dot(a.toBody(c.point));
    const SimTK::UnitVec3 normal(vec(normal_a));
    const SimTK::Vec3 point_b = vec(b.toBody(c.point));
    if (c.frictionless())
      matter.adoptUnilateralContact(new SimTK::PointPlaneFrictionlessContact(
          a.mobod, normal, height, b.mobod, point_b, c.restitution));
    else
      matter.adoptUnilateralContact(
          new SimTK::PointPlaneContact(a.mobod, normal, height, b.mobod, point_b, c.restitution,
                                       c.static_friction, c.dynamic_friction, 0.0));
  }
  system.realizeTopology();
  SimTK::State state = system.getDefaultState();
  for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
    if (!placed[i].movable) continue;
    const auto& b = scene.bodies[i];
    const Eigen::Quaterniond& q = placed[i].orientation;
    placed[i].mobod.setQToFitTransform(
        state, SimTK::Transform(SimTK::Rotation(SimTK::Quaternion(q.w(), q.x(), q.y(), q.z())),
                                vec(placed[i].origin)));
    // Free mobilizer: angular velocity and body-origin (centre of mass) velocity, in Ground.
    placed[i].mobod.setUToFitVelocity(
        state, SimTK::SpatialVec(vec(b.angular_velocity), vec(b.linear_velocity)));
  }
  system.realize(state, SimTK::Stage::Velocity);

  using Stepper = SimTK::SemiExplicitEulerTimeStepper;
  Stepper stepper(system);
  stepper.setInducedImpactModel(Stepper::Simultaneous);
  stepper.setRestitutionModel(config.restitution == SimbodyRestitution::kPoisson ? Stepper::Poisson
                                                                                 : Stepper::Newton);
  stepper.setPositionProjectionMethod(Stepper::NoPositionProjection);
  stepper.setConstraintTolerance(config.constraint_tolerance);
  stepper.setDefaultImpactCaptureVelocity(0.0);       // in use: 2 x the constraint tolerance
  stepper.setDefaultImpactMinCORVelocity(0.0);        // in use: the capture velocity
  stepper.setDefaultFrictionTransitionVelocity(0.0);  // mu_s only for a contact not slipping
  const bool plus = config.solver == SimbodySolver::kPlus;
  stepper.setImpulseSolverType(plus ? Stepper::PLUS : Stepper::PGS);
  const double rolling = stepper.getDefaultFrictionTransitionVelocityInUse();
  SimTK::ImpulseSolver* solver =
      plus ? static_cast<SimTK::ImpulseSolver*>(new SimTK::PLUSImpulseSolver(rolling))
           : new SimTK::PGSImpulseSolver(rolling);
  if (config.iterations > 0) solver->setMaxIterations(config.iterations);
  if (config.tolerance >= 0.0) solver->setConvergenceTol(config.tolerance);
  stepper.setImpulseSolver(solver);  // the stepper owns it

  std::vector<double> times;
  for (int r = 0; r < repetitions; ++r) {
    stepper.initialize(state);
    const auto t0 = std::chrono::steady_clock::now();
    stepper.stepTo(state.getTime() + kStep);
    const auto t1 = std::chrono::steady_clock::now();
    times.push_back(std::chrono::duration<double, std::nano>(t1 - t0).count());
  }
  std::nth_element(times.begin(), times.begin() + times.size() / 2, times.end());
  run.ns_per_solve = times[times.size() / 2];
  const SimTK::State& after = stepper.getState();
  for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
    if (!placed[i].movable) {
      run.after.linear.push_back(scene.bodies[i].linear_velocity);
      run.after.angular.push_back(scene.bodies[i].angular_velocity);
      continue;
    }
    run.after.linear.push_back(eig(placed[i].mobod.getBodyOriginVelocity(after)));
    run.after.angular.push_back(eig(placed[i].mobod.getBodyAngularVelocity(after)));
  }
  return run;
}

}  // namespace

PeerRun runSimbody(const core::Scene& scene, const SimbodyConfig& config, int repetitions) {
  for (const auto& b : scene.bodies) {
    if (b.mass == 0.0 && (b.linear_velocity.norm() > 0.0 || b.angular_velocity.norm() > 0.0)) {
      PeerRun run;  // immovable bodies become Ground, which is at rest
      run.note = "not run: an immovable body moves (Simbody's Ground is at rest)";
      return run;
    }
  }
  return runIsolated(
      [&] {
        SilencedStdout quiet;
        try {
          return simulate(scene, config, repetitions);
        } catch (const std::exception& e) {
          PeerRun run;
          run.note = "not run: Simbody: " + gist(e);
          return run;
        }
      },
      config.time_limit);
}

}  // namespace collision_response::bench
