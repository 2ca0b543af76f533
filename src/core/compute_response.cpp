#include "collision_response/core/compute_response.h"

#include <cstdio>

#include "collision_response/core/approach_warnings.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/contact_problem.h"
#include "collision_response/core/island_solver.h"
#include "collision_response/core/islands.h"
#include "collision_response/core/resting_contact.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/validation.h"

namespace collision_response::core {
namespace {

double normalVelocity(const std::vector<RigidBody>& bodies, const ContactPoint& contact) {
  const RigidBody& a = bodies[contact.body_a];
  const RigidBody& b = bodies[contact.body_b];
  return contact.normal.dot(b.pointVelocity(contact.point - b.com) -
                            a.pointVelocity(contact.point - a.com));
}

bool anyApproaching(const std::vector<ContactImpulse>& impulses, const Island& island) {
  for (const int c : island.contacts) {
    if (impulses[c].normal_velocity_before < 0.0) return true;
  }
  return false;
}

std::string formatNumber(const char* format, double value) {
  char text[32];
  std::snprintf(text, sizeof text, format, value);
  return text;
}

// Valid input that is usually a mistake (CollisionResult::warnings), found from the scene and the
// answer; costs a pass over bodies and contacts, no allocation unless something is found.
void addWarnings(const Scene& scene, const SolverOptions& options, CollisionResult& result) {
  for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
    const BodyState& body = scene.bodies[i];
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
    result.warnings.push_back({"bodies[" + std::to_string(i) + "].inertia", std::move(reason)});
  }
  for (std::size_t c = 0; c < scene.contacts.size(); ++c) {
    const ContactImpulse& impulse = result.impulses[c];
    if (!(impulse.normal_velocity_before > options.resting_velocity)) continue;
    if (impulse.normal_impulse != 0.0 || !impulse.friction_impulse.isZero(0.0)) continue;
    const Contact& contact = scene.contacts[c];
    result.warnings.push_back({"contacts[" + std::to_string(c) + "]",
                               "separating at " +
                                   formatNumber("%+.3g", impulse.normal_velocity_before) +
                                   " m/s, no impulse (the normal must point from body_a '" +
                                   contact.body_a + "' towards body_b '" + contact.body_b + "')",
                               Warning::Kind::kSeparating});
  }
  warnApproachingContacts(result.impulses, {}, result.islands, options, result.warnings);
}

}  // namespace

CollisionResult computeResponse(const Scene& scene, const SolverOptions& options,
                                const RequestLimits& limits) {
  return computeValidatedResponse(scene, validate(scene, options, limits), options);
}

CollisionResult computeValidatedResponse(const Scene& scene,
                                         const std::vector<std::pair<int, int>>& contact_bodies,
                                         const SolverOptions& requested) {
  SolverOptions options = requested;
  options.deadline = Deadline::in(requested.time_budget);

  std::vector<RigidBody> bodies;
  bodies.reserve(scene.bodies.size());
  for (const BodyState& state : scene.bodies) bodies.push_back(makeRigidBody(state));

  std::vector<ContactPoint> contacts;
  contacts.reserve(scene.contacts.size());
  for (std::size_t c = 0; c < scene.contacts.size(); ++c) {
    const Contact& contact = scene.contacts[c];
    const auto [a, b] = contact_bodies[c];
    contacts.emplace_back(a, b, contact.point, contact.normal.normalized(), contact.restitution,
                          contact.static_friction, contact.dynamic_friction);
  }

  CollisionResult result;
  result.impulses.resize(contacts.size());
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    result.impulses[c].normal_velocity_before = normalVelocity(bodies, contacts[c]);
  }
  // One problem per island, its storage reused across islands and calls on this thread (a
  // single-contact call then allocates nothing for it). One thread_local object, referenced once:
  // each use of a thread_local goes through its TLS wrapper.
  struct Workspace {
    ContactProblem problem;
    std::vector<ContactImpulse> answer;
  };
  thread_local Workspace workspace;
  ContactProblem& problem = workspace.problem;
  std::vector<ContactImpulse>& answer = workspace.answer;
  for (const Island& island : findIslands(bodies, contact_bodies)) {
    SolveReport report;
    if (anyApproaching(result.impulses, island)) {
      problem.buildImpact(bodies, contacts, island.contacts);
      report = solveIsland(problem, options, answer);
      problem.addVelocityChangesTo(bodies);
      problem.scatterImpulses(answer, result.impulses);
    } else {
      problem.buildResting(scene.bodies, bodies, contacts, island.contacts,
                           options.resting_velocity);
      report = solveRestingIsland(problem, options, answer);
      problem.scatterForces(answer, result.impulses);
    }
    report.contacts = island.contacts;
    result.islands.push_back(std::move(report));
  }

  // Post-impact states and the normal velocity each contact ends with.
  result.bodies = scene.bodies;
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    result.bodies[i].linear_velocity = bodies[i].linear_velocity;
    result.bodies[i].angular_velocity = bodies[i].angular_velocity;
    result.kinetic_energy_before += kineticEnergy(scene.bodies[i]);
    result.kinetic_energy_after += kineticEnergy(result.bodies[i]);
  }
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    result.impulses[c].normal_velocity_after = normalVelocity(bodies, contacts[c]);
  }
  addWarnings(scene, options, result);
  return result;
}

}  // namespace collision_response::core
