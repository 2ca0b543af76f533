// ODE peer adapter (see peer_ode.h).
#include "peer_ode.h"

#include <ode/ode.h>

#include <algorithm>
#include <chrono>
#include <cstdarg>
#include <string>

namespace collision_response::bench {
namespace {

int ode_messages = 0;  // ODE's "LCP internal error" and the like, counted instead of printed

void countMessage(int, const char*, va_list) {
  ++ode_messages;
}

}  // namespace

PeerRun runOde(const core::Scene& scene, const OdeConfig& config, int repetitions) {
  static const bool initialised = (dInitODE2(0), dSetMessageHandler(countMessage), true);
  (void)initialised;
  const double dt = 1e-3;  // [s]; velocities do not depend on it with ERP 0, CFM 0 and no forces
  dWorldID world = dWorldCreate();
  dWorldSetGravity(world, 0, 0, 0);
  dWorldSetERP(world, 0.0);
  dWorldSetCFM(world, 0.0);  // exact constraints: the best answers (1e-10 gave 1e-7 errors)
  dWorldSetAutoDisableFlag(world, 0);
  dWorldSetContactSurfaceLayer(world, 0.0);
  dWorldSetQuickStepNumIterations(world, config.iterations);
  std::vector<dBodyID> bodies;
  for (const auto& b : scene.bodies) {
    if (b.mass == 0.0) {
      bodies.push_back(nullptr);  // immovable: the static environment (body 0)
      continue;
    }
    dBodyID body = dBodyCreate(world);
    dMass mass;
    dMassSetParameters(&mass, b.mass, 0, 0, 0, b.inertia(0, 0), b.inertia(1, 1), b.inertia(2, 2),
                       b.inertia(0, 1), b.inertia(0, 2), b.inertia(1, 2));
    dBodySetMass(body, &mass);
    dBodySetGyroscopicMode(body, 0);
    bodies.push_back(body);
  }
  auto index = [&](const std::string& id) {
    for (std::size_t i = 0; i < scene.bodies.size(); ++i)
      if (scene.bodies[i].id == id) return static_cast<int>(i);
    return -1;
  };
  dJointGroupID group = dJointGroupCreate(0);
  std::vector<dJointFeedback> feedback(scene.contacts.size());
  auto reset = [&] {
    dJointGroupEmpty(group);
    for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
      if (!bodies[i]) continue;
      const auto& b = scene.bodies[i];
      const Eigen::Vector3d c = b.worldCom();
      const Eigen::Quaterniond q = b.orientation.normalized();
      const dQuaternion dq = {q.w(), q.x(), q.y(), q.z()};
      dBodySetPosition(bodies[i], c.x(), c.y(), c.z());
      dBodySetQuaternion(bodies[i], dq);
      dBodySetLinearVel(bodies[i], b.linear_velocity.x(), b.linear_velocity.y(),
                        b.linear_velocity.z());
      dBodySetAngularVel(bodies[i], b.angular_velocity.x(), b.angular_velocity.y(),
                         b.angular_velocity.z());
    }
    for (std::size_t k = 0; k < scene.contacts.size(); ++k) {
      const auto& c = scene.contacts[k];
      dContact contact{};
      contact.surface.mode = dContactBounce | dContactApprox1;
      contact.surface.mu = c.dynamic_friction;
      contact.surface.bounce = c.restitution;
      contact.surface.bounce_vel = 0.0;
      for (int j = 0; j < 3; ++j) {
        contact.geom.pos[j] = c.point[j];
        contact.geom.normal[j] = c.normal[j];
      }
      contact.geom.depth = 0.0;
      dJointID joint = dJointCreateContact(world, group, &contact);
      // ODE pushes body 1 along +normal: body 1 is our b, body 2 our a.
      dJointAttach(joint, bodies[index(c.body_b)], bodies[index(c.body_a)]);
      dJointSetFeedback(joint, &feedback[k]);
    }
  };
  std::vector<double> times;
  PeerRun run;
  ode_messages = 0;
  for (int r = 0; r < repetitions; ++r) {
    reset();
    const auto t0 = std::chrono::steady_clock::now();
    if (config.stepper == OdeStepper::kStep)
      dWorldStep(world, dt);
    else
      dWorldQuickStep(world, dt);
    const auto t1 = std::chrono::steady_clock::now();
    times.push_back(std::chrono::duration<double, std::nano>(t1 - t0).count());
  }
  std::nth_element(times.begin(), times.begin() + times.size() / 2, times.end());
  run.ns_per_solve = times[times.size() / 2];
  for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
    if (!bodies[i]) {
      run.after.linear.push_back(scene.bodies[i].linear_velocity);
      run.after.angular.push_back(scene.bodies[i].angular_velocity);
      continue;
    }
    const dReal* v = dBodyGetLinearVel(bodies[i]);
    const dReal* w = dBodyGetAngularVel(bodies[i]);
    run.after.linear.emplace_back(v[0], v[1], v[2]);
    run.after.angular.emplace_back(w[0], w[1], w[2]);
  }
  for (const auto& f : feedback)  // force on body 1 (our b) over the step
    run.impulses.emplace_back(f.f1[0] * dt, f.f1[1] * dt, f.f1[2] * dt);
  if (ode_messages > 0)
    run.note = "ODE reported an internal LCP error in " + std::to_string(ode_messages) + " of " +
               std::to_string(repetitions) + " steps";
  dJointGroupDestroy(group);
  dWorldDestroy(world);
  return run;
}

}  // namespace collision_response::bench
