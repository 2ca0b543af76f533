#include "collision_response/core/body_response.h"

#include <cmath>
#include <limits>
#include <numeric>
#include <string>

#include "collision_response/core/contact_problem.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/island_solver.h"

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
    if (contact.body_a == contact.body_b) {
      throw InvalidInput(field(c, "body_b"), "a contact of a body with itself");
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

int findRoot(std::vector<int>& parent, int i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
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

  // Islands: contacts joined through bodies with velocity unknowns (union-find over bodies).
  std::vector<int> parent(bodies.size());
  std::iota(parent.begin(), parent.end(), 0);
  const auto movable = [&](int b) { return bodies[b]->velocityCount() > 0; };
  for (const ContactPoint& contact : contacts) {
    if (movable(contact.body_a) && movable(contact.body_b)) {
      parent[findRoot(parent, contact.body_a)] = findRoot(parent, contact.body_b);
    }
  }
  std::vector<int> island_of_root(bodies.size(), -1);
  std::vector<std::vector<int>> islands;
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    const int body = movable(contacts[c].body_a) ? contacts[c].body_a : contacts[c].body_b;
    const int root = findRoot(parent, body);
    if (island_of_root[root] < 0) {
      island_of_root[root] = static_cast<int>(islands.size());
      islands.emplace_back();
    }
    islands[island_of_root[root]].push_back(static_cast<int>(c));
  }

  const std::vector<const BodyModel*> views(bodies.begin(), bodies.end());
  ContactProblem problem;
  std::vector<ContactImpulse> answer;
  for (const std::vector<int>& island : islands) {
    problem.buildImpact(views, contacts, island);
    for (std::size_t i = 0; i < problem.size(); ++i) {
      const double w = problem.contact(i).normalDelassus();
      if (w > 0.0) result.effective_masses[problem.contact(i).source] = 1.0 / w;
    }
    bool approaching = false;
    for (const int c : island) approaching |= result.impulses[c].normal_velocity_before < 0.0;
    SolveReport report;
    if (approaching) {
      report = solveIsland(problem, options, answer);
      problem.addVelocityChangesTo(bodies);
      problem.scatterImpulses(answer, result.impulses);
    }
    report.contacts = island;
    result.islands.push_back(std::move(report));
  }
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    result.impulses[c].normal_velocity_after = normalVelocity(bodies, contacts[c]);
  }
  return result;
}

}  // namespace collision_response::core
