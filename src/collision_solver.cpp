#include "collision_response/collision_solver.h"

#include "collision_response/contact_row.h"
#include "collision_response/island_solver.h"
#include "collision_response/islands.h"
#include "collision_response/resting_contact.h"
#include "collision_response/rigid_body.h"
#include "collision_response/validation.h"

namespace collision_response::core {
namespace {

double normalVelocity(const std::vector<RigidBody>& bodies, const ContactRow& row) {
  return row.normal.dot(row.space.relativeVelocity(bodies[row.body_a], bodies[row.body_b]));
}

bool anyApproaching(const std::vector<ContactImpulse>& impulses, const Island& island) {
  for (const int c : island.contacts) {
    if (impulses[c].normal_velocity_before < 0.0) return true;
  }
  return false;
}

}  // namespace

CollisionResult computeResponse(const Scene& scene, const SolverOptions& requested,
                                const RequestLimits& limits) {
  const std::vector<std::pair<int, int>> contact_bodies = validate(scene, requested, limits);
  SolverOptions options = requested;
  options.deadline = Deadline::in(requested.time_budget);

  std::vector<RigidBody> bodies;
  bodies.reserve(scene.bodies.size());
  for (const BodyState& state : scene.bodies) bodies.push_back(makeRigidBody(state));

  std::vector<ContactRow> rows;
  rows.reserve(scene.contacts.size());
  for (std::size_t c = 0; c < scene.contacts.size(); ++c) {
    const Contact& contact = scene.contacts[c];
    const auto [a, b] = contact_bodies[c];
    rows.emplace_back(a, b, bodies[a], bodies[b], contact.point, contact.normal.normalized(),
                      contact.restitution, contact.static_friction, contact.dynamic_friction);
  }

  CollisionResult result;
  result.impulses.resize(rows.size());
  for (std::size_t c = 0; c < rows.size(); ++c) {
    result.impulses[c].normal_velocity_before = normalVelocity(bodies, rows[c]);
  }
  for (const Island& island : findIslands(bodies, contact_bodies)) {
    IslandReport report;
    report.contacts = island.contacts;
    if (anyApproaching(result.impulses, island)) {
      const IslandStats stats =
          solveIsland(bodies, rows, island.contacts, options, result.impulses);
      report.method = stats.method;
      report.iterations = stats.iterations;
      report.residual = stats.residual;
      report.converged = stats.converged;
    } else {
      const IslandStats stats =
          solveRestingIsland(scene.bodies, bodies, rows, island.contacts, options, result.impulses);
      report.method = stats.method;
      report.iterations = stats.iterations;
      report.residual = stats.residual;
      report.converged = stats.converged;
    }
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
  for (std::size_t c = 0; c < rows.size(); ++c) {
    result.impulses[c].normal_velocity_after = normalVelocity(bodies, rows[c]);
  }
  return result;
}

}  // namespace collision_response::core
