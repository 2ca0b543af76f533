#include "collision_response/core/resting_contact.h"

#include <algorithm>
#include <cmath>

#include "collision_response/core/iterative_solver.h"
#include "collision_response/core/single_contact.h"

namespace collision_response::core {
namespace {

// A contact sticks if its tangential relative acceleration is at most this fraction of the
// island's largest free relative acceleration (the iterative solver's slip tolerance).
constexpr double kStickTolerance = 1e-9;

// One resting contact in closed form: sticking or starting to slide by the Newton closed form
// with e = 0, or sliding along an existing slip with F = f_n (n - mu_d s) and a'_n = 0.
SolveReport restingClosedForm(ContactProblem& problem, ContactImpulse& force) {
  SolveReport report;
  report.method = SolveMethod::kRestingClosedForm;
  report.iterations = 1;
  const ProblemContact& c = problem.contact(0);
  const Eigen::Vector3d acceleration = problem.relativeMotion(0);
  if (c.slip_direction.isZero(0.0)) {
    force = solveSingleContact(c, acceleration, ImpactLaw::kNewton);
  } else {
    const Eigen::Vector3d direction = c.normal - c.dynamic_friction * c.slip_direction;
    const double a_n = c.normal.dot(acceleration);
    const double denominator = c.normal.dot(c.delassus * direction);
    if (a_n < 0.0 && denominator > 0.0) {
      const double f_n = -a_n / denominator;
      force.normal_impulse = f_n;
      force.friction_impulse = -c.dynamic_friction * f_n * c.slip_direction;
    } else if (a_n < 0.0) {
      report.converged = false;  // Painleve: no consistent sliding force exists
    }
  }
  problem.applyImpulse(0, force.total(c.normal));
  return report;
}

}  // namespace

SolveReport solveRestingIsland(ContactProblem& problem, const SolverOptions& options,
                               std::vector<ContactImpulse>& forces) {
  SolveReport report;
  forces.assign(problem.size(), ContactImpulse{});
  if (problem.empty()) return report;
  // The scale of a slip: the island's largest free relative acceleration (before any force).
  double reference = 0.0;
  for (std::size_t i = 0; i < problem.size(); ++i) {
    reference = std::max(reference, problem.relativeMotion(i).norm());
  }
  // The solvers answer in ContactImpulse's impulse fields, which hold forces [N] here.
  std::vector<ContactImpulse> answer(problem.size());
  if (problem.size() == 1) {
    report = restingClosedForm(problem, answer[0]);
  } else {
    report = solveIterative(problem, options, answer);
    report.method = SolveMethod::kRestingIterative;
  }
  for (std::size_t i = 0; i < problem.size(); ++i) {
    const ProblemContact& c = problem.contact(i);
    ContactImpulse& out = forces[i];
    out.resting = true;
    out.normal_force = answer[i].normal_impulse;
    out.friction_force = answer[i].friction_impulse;
    // Sticking: no slip now, not separating, and no tangential relative acceleration left (a
    // touching contact that carries no force but does not slip, e.g. an unloaded corner of a
    // stuck box, sticks too), to kStickTolerance of the island's largest free acceleration.
    const Eigen::Vector3d a = problem.relativeMotion(i);
    const double a_n = a.dot(c.normal);
    const Eigen::Vector3d a_t = a - a_n * c.normal;
    const double tolerance = kStickTolerance * std::max(reference, 1e-300);
    out.sticking = c.slip_direction.isZero(0.0) && !c.frictionless() && a_n <= tolerance &&
                   a_t.norm() <= tolerance;
  }
  return report;
}

}  // namespace collision_response::core
