#include "collision_response/core/compute_response.h"

#include <cstdio>

#include <iterator>

#include "collision_response/core/contact_point.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/solve_islands.h"
#include "collision_response/core/validation.h"

namespace collision_response::core {
namespace {

std::string formatNumber(const char* format, double value) {
  char text[32];
  std::snprintf(text, sizeof text, format, value);
  return text;
}

}  // namespace

void addBodyWarnings(const std::vector<BodyState>& bodies, std::vector<Warning>& warnings) {
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    const BodyState& body = bodies[i];
    if (!body.immovable()) continue;
    const bool moving = !body.linear_velocity.isZero(0.0) || !body.angular_velocity.isZero(0.0);
    const bool has_inertia = !body.inertia.isZero(0.0);
    if (!moving && !has_inertia) continue;  // a fixed floor or wall: immovable by intent
    std::string reason = "mass 0, treated as immovable (";
    reason += has_inertia ? "an inertia tensor is given but no mass"
                          : "it moves at " + formatNumber("%.3g", body.linear_velocity.norm()) +
                                " m/s and " + formatNumber("%.3g", body.angular_velocity.norm()) +
                                " rad/s but has no mass";
    reason += ": set inertia.m for a movable body)";
    warnings.push_back({"bodies[" + std::to_string(i) + "].inertia", std::move(reason)});
  }
}

namespace {

// Valid input that is usually a mistake (CollisionResult::warnings), found from the scene and the
// answer, placed before the pipeline's approach warnings; costs a pass over bodies and contacts, no
// allocation unless something is found.
void addSceneWarnings(const Scene& scene, const SolverOptions& options, CollisionResult& result) {
  std::vector<Warning> warnings;
  addBodyWarnings(scene.bodies, warnings);
  for (std::size_t c = 0; c < scene.contacts.size(); ++c) {
    const ContactImpulse& impulse = result.impulses[c];
    if (!(impulse.normal_velocity_before > options.resting_velocity)) continue;
    if (impulse.normal_impulse != 0.0 || !impulse.friction_impulse.isZero(0.0)) continue;
    const Contact& contact = scene.contacts[c];
    warnings.push_back({"contacts[" + std::to_string(c) + "]",
                        "separating at " + formatNumber("%+.3g", impulse.normal_velocity_before) +
                            " m/s, no impulse (the normal must point from body_a '" +
                            contact.body_a + "' towards body_b '" + contact.body_b + "')",
                        Warning::Kind::kSeparating});
  }
  if (warnings.empty()) return;
  result.warnings.insert(result.warnings.begin(), std::make_move_iterator(warnings.begin()),
                         std::make_move_iterator(warnings.end()));
}

// The bodies behind the body interface (each a free rigid body: the contact problem's closed-form
// path), the pointers to them and the contacts, in storage reused per thread.
struct Workspace {
  std::vector<RigidBody> bodies;
  std::vector<BodyModel*> models;
  std::vector<ContactPoint> contacts;
};

// Looked up once per call (solve_islands.cpp says why this is a function).
[[gnu::noinline]] Workspace& threadWorkspace() {
  thread_local Workspace workspace;
  return workspace;
}

}  // namespace

CollisionResult computeResponse(const Scene& scene, const SolverOptions& options,
                                const RequestLimits& limits) {
  return computeValidatedResponse(scene, validate(scene, options, limits), options);
}

void makeContactPoints(const Scene& scene, const std::vector<std::pair<int, int>>& contact_bodies,
                       std::vector<ContactPoint>& points) {
  points.clear();
  points.reserve(scene.contacts.size());
  for (std::size_t c = 0; c < scene.contacts.size(); ++c) {
    const Contact& contact = scene.contacts[c];
    const auto [a, b] = contact_bodies[c];
    points.emplace_back(a, b, contact.point, contact.normal.normalized(), contact.restitution,
                        contact.static_friction, contact.dynamic_friction);
  }
}

void solveRigidIslands(const std::vector<BodyState>& states,
                       const std::vector<ContactPoint>& points, const SolverOptions& options,
                       std::vector<RigidBody>& bodies, std::vector<BodyModel*>& models,
                       ContactResponse& response) {
  makeRigidBodies(states, bodies);
  models.clear();
  for (RigidBody& body : bodies) models.push_back(&body);
  // Resting contacts read each body's free acceleration under its wrench.
  solveIslands(models, points, options, response, [&] { setFreeAccelerations(states, bodies); });
}

CollisionResult computeValidatedResponse(const Scene& scene,
                                         const std::vector<std::pair<int, int>>& contact_bodies,
                                         const SolverOptions& options) {
  Workspace& workspace = threadWorkspace();
  std::vector<RigidBody>& bodies = workspace.bodies;
  std::vector<ContactPoint>& contacts = workspace.contacts;
  makeContactPoints(scene, contact_bodies, contacts);

  CollisionResult result;
  solveRigidIslands(scene.bodies, contacts, options, bodies, workspace.models, result);

  // Post-impact states.
  result.bodies = scene.bodies;
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    result.bodies[i].linear_velocity = bodies[i].linear_velocity;
    result.bodies[i].angular_velocity = bodies[i].angular_velocity;
    result.kinetic_energy_before += kineticEnergy(scene.bodies[i]);
    result.kinetic_energy_after += kineticEnergy(result.bodies[i]);
  }
  addSceneWarnings(scene, options, result);
  return result;
}

}  // namespace collision_response::core
