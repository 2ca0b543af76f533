#include "collision_response/core/body_response.h"

#include <cmath>
#include <limits>
#include <string>

#include "collision_response/core/approach_warnings.h"
#include "collision_response/core/contact_problem.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/island_solver.h"
#include "collision_response/core/islands.h"
#include "collision_response/core/resting_contact.h"

namespace collision_response::core {
namespace {

std::string field(std::size_t c, const char* name) {
  return "contacts[" + std::to_string(c) + "]." + name;
}

void validateContacts(const std::vector<BodyModel*>& bodies,
                      const std::vector<ContactPoint>& contacts) {
  const int count = static_cast<int>(bodies.size());
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    const ContactPoint& contact = contacts[c];
    if (contact.body_a < 0 || contact.body_a >= count || bodies[contact.body_a] == nullptr) {
      throw InvalidInput(field(c, "body_a"), "no body " + std::to_string(contact.body_a));
    }
    if (contact.body_b < 0 || contact.body_b >= count || bodies[contact.body_b] == nullptr) {
      throw InvalidInput(field(c, "body_b"), "no body " + std::to_string(contact.body_b));
    }
    // Two parts of one body (two links of a robot) may touch; one part cannot touch itself.
    if (contact.body_a == contact.body_b &&
        (contact.part_a == contact.part_b || bodies[contact.body_a]->asRigidBody() != nullptr)) {
      throw InvalidInput(field(c, "body_b"), contact.part_a == contact.part_b && contact.part_a >= 0
                                                 ? "a contact of a part with itself"
                                                 : "a contact of a body with itself");
    }
    if (!contact.point.allFinite()) throw InvalidInput(field(c, "point"), "not finite");
    if (!contact.normal.allFinite() || std::abs(contact.normal.norm() - 1.0) > 1e-6) {
      throw InvalidInput(field(c, "normal"), "not a unit vector");
    }
    if (!(contact.restitution >= 0.0 && contact.restitution <= 1.0)) {
      throw InvalidInput(field(c, "restitution"), "outside [0, 1]");
    }
    if (!(contact.static_friction >= 0.0 && std::isfinite(contact.static_friction))) {
      throw InvalidInput(field(c, "static_friction"), "negative or not finite");
    }
    if (!(contact.dynamic_friction >= 0.0 && contact.dynamic_friction <= contact.static_friction)) {
      throw InvalidInput(field(c, "dynamic_friction"), "outside [0, static_friction]");
    }
  }
}

double normalVelocity(const std::vector<BodyModel*>& bodies, const ContactPoint& contact) {
  const Eigen::Vector3d u =
      bodies[contact.body_b]->partPointVelocity(contact.part_b, contact.point) -
      bodies[contact.body_a]->partPointVelocity(contact.part_a, contact.point);
  return contact.normal.dot(u);
}

}  // namespace

BodyResponse computeBodyResponse(const std::vector<BodyModel*>& bodies,
                                 const std::vector<ContactPoint>& contacts,
                                 const SolverOptions& requested) {
  validateContacts(bodies, contacts);
  SolverOptions options = requested;
  options.deadline = Deadline::in(requested.time_budget);

  BodyResponse result;
  result.impulses.resize(contacts.size());
  result.effective_masses.assign(contacts.size(), std::numeric_limits<double>::infinity());
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    result.impulses[c].normal_velocity_before = normalVelocity(bodies, contacts[c]);
  }

  std::vector<std::pair<int, int>> contact_bodies;
  contact_bodies.reserve(contacts.size());
  for (const ContactPoint& contact : contacts) {
    contact_bodies.emplace_back(contact.body_a, contact.body_b);
  }

  // One problem per island, its storage reused across islands and calls on this thread, as in
  // computeResponse() (one thread_local object: each use of one goes through its TLS wrapper).
  struct Workspace {
    std::vector<const BodyModel*> views;
    ContactProblem problem;
    std::vector<ContactImpulse> answer;
  };
  thread_local Workspace workspace;
  workspace.views.assign(bodies.begin(), bodies.end());
  ContactProblem& problem = workspace.problem;
  for (Island& island : findIslands(bodies, contact_bodies)) {
    // An island between bodies without velocity unknowns (a fixed-base robot with every joint
    // locked, immovable bodies): nothing can move, no impulse and no force (effective masses
    // infinite); the solvers need at least one unknown.
    bool movable = false;
    for (const int c : island.contacts) {
      movable |= bodies[contacts[c].body_a]->velocityCount() > 0 ||
                 bodies[contacts[c].body_b]->velocityCount() > 0;
    }
    if (!movable) {
      SolveReport report;
      report.contacts = std::move(island.contacts);
      result.islands.push_back(std::move(report));
      continue;
    }
    problem.buildImpact(workspace.views, contacts, island.contacts);
    for (std::size_t i = 0; i < problem.size(); ++i) {
      const double w = problem.contact(i).normalDelassus();
      if (w > 0.0) result.effective_masses[problem.contact(i).source] = 1.0 / w;
    }
    bool approaching = false;
    for (const int c : island.contacts)
      approaching |= result.impulses[c].normal_velocity_before < 0.0;
    SolveReport report;
    if (approaching) {
      report = solveIsland(problem, options, workspace.answer);
      problem.addVelocityChangesTo(bodies);
      problem.scatterImpulses(workspace.answer, result.impulses);
    } else {
      problem.buildResting(workspace.views, contacts, island.contacts, options.resting_velocity);
      report = solveRestingIsland(problem, options, workspace.answer);
      problem.scatterForces(workspace.answer, result.impulses);
    }
    report.contacts = std::move(island.contacts);
    result.islands.push_back(std::move(report));
  }
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    result.impulses[c].normal_velocity_after = normalVelocity(bodies, contacts[c]);
  }
  warnApproachingContacts(result.impulses, result.effective_masses, result.islands, options,
                          result.warnings);
  return result;
}

}  // namespace collision_response::core
