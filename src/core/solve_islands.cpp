#include "collision_response/core/solve_islands.h"

#include <limits>
#include <utility>

#include "collision_response/core/approach_warnings.h"
#include "collision_response/core/contact_problem.h"
#include "collision_response/core/island_solver.h"
#include "collision_response/core/islands.h"
#include "collision_response/core/resting_contact.h"
#include "collision_response/core/rigid_body.h"

namespace collision_response::core {
namespace {

// The bodies as the pipeline asks for them: each one's velocity unknowns and its free rigid body
// (asRigidBody(), the closed forms), asked once per body and call instead of once per contact side.
struct BodyViews {
  std::vector<const BodyModel*> models;
  std::vector<const RigidBody*> rigid;
  std::vector<int> unknowns;

  void assign(const std::vector<BodyModel*>& bodies) {
    models.assign(bodies.begin(), bodies.end());
    rigid.resize(bodies.size());
    unknowns.resize(bodies.size());
    for (std::size_t i = 0; i < bodies.size(); ++i) {
      rigid[i] = bodies[i]->asRigidBody();
      unknowns[i] =
          rigid[i] != nullptr ? (rigid[i]->movable() ? 6 : 0) : bodies[i]->velocityCount();
    }
  }
  // World velocity of the material point at p of `part` of body i [m/s].
  Eigen::Vector3d pointVelocity(int i, int part, const Eigen::Vector3d& p) const {
    if (const RigidBody* body = rigid[i]) return body->pointVelocity(p - body->com);
    return models[i]->partPointVelocity(part, p);
  }
  double normalVelocity(const ContactPoint& contact) const {
    return contact.normal.dot(pointVelocity(contact.body_b, contact.part_b, contact.point) -
                              pointVelocity(contact.body_a, contact.part_a, contact.point));
  }
};

// One problem per island, its storage reused across islands and calls on this thread (a
// single-contact call then allocates nothing for it).
struct Workspace {
  BodyViews views;
  std::vector<std::pair<int, int>> contact_bodies;
  ContactProblem problem;
  std::vector<ContactImpulse> answer;
};

// The thread's workspace, looked up once per call: GCC recomputes a thread_local's address
// (__tls_get_addr in a shared library) at each use rather than keep it across calls; a reference
// returned from a function that is not inlined is an ordinary pointer.
[[gnu::noinline]] Workspace& threadWorkspace() {
  thread_local Workspace workspace;
  return workspace;
}

}  // namespace

void solveIslands(const std::vector<BodyModel*>& bodies, const std::vector<ContactPoint>& contacts,
                  const SolverOptions& requested, ContactResponse& result,
                  const std::function<void()>& prepare_resting) {
  SolverOptions options = requested;
  options.deadline = Deadline::in(requested.time_budget);

  Workspace& workspace = threadWorkspace();
  const BodyViews& views = workspace.views;
  workspace.views.assign(bodies);
  result.impulses.resize(contacts.size());
  result.effective_masses.assign(contacts.size(), std::numeric_limits<double>::infinity());
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    result.impulses[c].normal_velocity_before = views.normalVelocity(contacts[c]);
  }
  workspace.contact_bodies.clear();
  for (const ContactPoint& contact : contacts) {
    workspace.contact_bodies.emplace_back(contact.body_a, contact.body_b);
  }
  ContactProblem& problem = workspace.problem;
  bool resting_prepared = false;
  std::vector<Island> islands = findIslands(views.unknowns, workspace.contact_bodies);
  result.islands.reserve(result.islands.size() + islands.size());
  for (Island& island : islands) {
    // An island between bodies without velocity unknowns (a fixed-base robot with every joint
    // locked, immovable bodies): nothing can move, no impulse and no force (effective masses
    // infinite); the solvers need at least one unknown.
    bool movable = false;
    bool approaching = false;
    for (const int c : island.contacts) {
      movable = movable || views.unknowns[contacts[c].body_a] > 0 ||
                views.unknowns[contacts[c].body_b] > 0;
      approaching |= result.impulses[c].normal_velocity_before < 0.0;
    }
    SolveReport report;
    if (movable) {
      problem.buildImpact(views.models, contacts, island.contacts);
      for (std::size_t i = 0; i < problem.size(); ++i) {
        const double w = problem.contact(i).normalDelassus();
        if (w > 0.0) result.effective_masses[problem.contact(i).source] = 1.0 / w;
      }
      if (approaching) {
        report = solveIsland(problem, options, workspace.answer);
        problem.addVelocityChangesTo(bodies);
        problem.scatterImpulses(workspace.answer, result.impulses);
      } else {
        if (!resting_prepared && prepare_resting) prepare_resting();
        resting_prepared = true;
        problem.buildResting(views.models, contacts, island.contacts, options.resting_velocity);
        report = solveRestingIsland(problem, options, workspace.answer);
        problem.scatterForces(workspace.answer, result.impulses);
      }
    }
    report.contacts = std::move(island.contacts);
    result.islands.push_back(std::move(report));
  }
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    result.impulses[c].normal_velocity_after = views.normalVelocity(contacts[c]);
  }
  warnApproachingContacts(result.impulses, result.effective_masses, result.islands, options,
                          result.warnings);
}

}  // namespace collision_response::core
