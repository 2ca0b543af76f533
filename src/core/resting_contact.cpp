#include "collision_response/core/resting_contact.h"

#include <algorithm>
#include <cmath>

#include "collision_response/core/friction_disk.h"
#include "collision_response/core/iterative_solver.h"
#include "collision_response/core/single_contact.h"
#include "collision_response/core/stick_certificate.h"

namespace collision_response::core {
namespace {

// A contact sticks if its tangential relative acceleration is at most this fraction of the
// island's largest free relative acceleration (the iterative solver's slip tolerance).
constexpr double kStickTolerance = 1e-9;

// The all-stick sweep after which, still not converged, the solve asks noStuckAnswer() once
// (a solve that converges sooner pays nothing for it).
constexpr std::size_t kCertificateSweep = 32;

// One resting contact in closed form: sticking or starting to slide by the Newton closed form
// with e = 0, or sliding along an existing slip with F = f_n (n - mu_d s) and a'_n = 0.
SolveReport restingClosedForm(ContactProblem& problem, ContactImpulse& force) {
  SolveReport report;
  report.method = SolvedBy::kRestingClosedForm;
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

// Step 1 of docs/physics.md, "Static friction first": the all-stick problem on the static cones,
// as the convex problem min F^T a + F^T W F / 2 over |F_t| <= mu_s F_n (a the free accelerations),
// by block Gauss-Seidel, each contact's block solved exactly (solveFrictionCone()). Its minimizers
// all leave the same accelerations a' = a + W F, and a stuck answer (F in the cones, a' = 0 where
// F != 0, a'_n >= 0 elsewhere with a'_n >= mu_s |a'_t|) is one of them when one exists: so the
// stuck answer exists iff the minimizer found is one. It is accepted (forces written to `answer`,
// applied to the problem, true returned) only if it converged and is stuck; otherwise the problem
// is restored and false returned. Only for islands without a contact already slipping.
bool solveAllStick(ContactProblem& problem, const SolverOptions& options, double reference,
                   std::vector<ContactImpulse>& answer, SolveReport& report) {
  const std::size_t size = problem.size();
  for (std::size_t i = 0; i < size; ++i) {
    if (!problem.contact(i).slip_direction.isZero(0.0)) return false;
  }
  const ContactProblem::State initial = problem.state();
  const double tolerance = kStickTolerance * reference;
  std::vector<Eigen::Vector3d> F(size, Eigen::Vector3d::Zero());
  // Each block's frame and pseudo-inverse once (the sweeps change only its right-hand side).
  std::vector<FrictionConeBlock> blocks(size);
  for (std::size_t i = 0; i < size; ++i) {
    const ProblemContact& c = problem.contact(i);
    blocks[i] =
        prepareFrictionCone(c.delassus, c.normal, c.tangent1, c.tangent2, c.static_friction);
  }
  bool converged = false;
  std::size_t& sweeps = report.iterations;
  for (sweeps = 1; sweeps <= options.max_iterations; ++sweeps) {
    if (sweeps % 16 == 0) options.deadline.check("the resting all-stick solve");
    double largest_change = 0.0, largest_force = 0.0;
    for (std::size_t i = 0; i < size; ++i) {
      const ProblemContact& c = problem.contact(i);
      const Eigen::Vector3d b = problem.relativeMotion(i) - c.delassus * F[i];
      const Eigen::Vector3d next = solveFrictionCone(blocks[i], b);
      problem.applyImpulse(i, next - F[i]);
      largest_change = std::max(largest_change, (next - F[i]).norm());
      largest_force = std::max(largest_force, next.norm());
      F[i] = next;
    }
    if (!std::isfinite(largest_change)) break;
    report.residual = largest_force > 0.0 ? largest_change / largest_force : largest_change;
    if (report.residual <= options.tolerance) {
      converged = true;
      break;
    }
    if (sweeps == kCertificateSweep) {
      // Proven without a stuck answer: the sweeps could only fail the test below (docs/physics.md,
      // "No stuck answer"); stop here with the same outcome.
      std::vector<Eigen::Vector3d> free(size);
      const ContactProblem::State now = problem.state();
      problem.restore(initial);
      for (std::size_t i = 0; i < size; ++i) free[i] = problem.relativeMotion(i);
      if (noStuckAnswer(problem, free, tolerance)) return false;
      problem.restore(now);
    }
  }
  sweeps = std::min(sweeps, options.max_iterations);
  // Stuck? Every loaded contact stopped, every unloaded one touching without slip or separating.
  bool stuck = converged;
  for (std::size_t i = 0; stuck && i < size; ++i) {
    const ProblemContact& c = problem.contact(i);
    const Eigen::Vector3d a = problem.relativeMotion(i);
    const double a_n = a.dot(c.normal);
    const double a_t = (a - a_n * c.normal).norm();
    const bool loaded = F[i].dot(c.normal) > 0.0;
    stuck =
        a_n >= -tolerance && (loaded ? a.norm() <= tolerance : a_n > tolerance || a_t <= tolerance);
  }
  if (!stuck) {
    problem.restore(initial);
    return false;
  }
  for (std::size_t i = 0; i < size; ++i) {
    const ProblemContact& c = problem.contact(i);
    answer[i].normal_impulse = F[i].dot(c.normal);
    answer[i].friction_impulse = F[i] - answer[i].normal_impulse * c.normal;
  }
  report.converged = true;
  return true;
}

// No stuck answer (docs/physics.md, "Slow slips"): a contact whose slip was too slow to count
// (|u_t| within the resting velocity) may no longer count as not slipping, since not slipping is
// what the island cannot do. It slips at u_t != 0, and Coulomb's law at any nonzero slip puts its
// friction at -mu_d F_n along u_t / |u_t| (maximal dissipation: against the slip). Without this the
// contacts of a block turning slowly on a table have no slip of their own but the centripetal
// w^2 r that no force cancels; friction then opposes that acceleration (radially outward, at right
// angles to the corners' motion, dissipating nothing) and the sweeps chase its direction to their
// cap. Contacts with u_t = 0 exactly keep their disk.
void poseSlowSlips(ContactProblem& problem) {
  for (std::size_t i = 0; i < problem.size(); ++i) {
    const ProblemContact& c = problem.contact(i);
    if (c.slip_direction.isZero(0.0) && !c.slow_slip.isZero(0.0)) {
      problem.setSlipDirection(i, c.slow_slip.normalized());
    }
  }
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
    // Static friction first (docs/physics.md): the all-stick answer if one exists, otherwise the
    // sweeps on Coulomb's law, static cones first, sliding contacts moved to mu_d.
    SolveReport stick;
    if (!solveAllStick(problem, options, reference, answer, stick)) {
      poseSlowSlips(problem);
      report = solveIterative(problem, options, answer);
      report.iterations += stick.iterations;
    } else {
      report = stick;
    }
    report.method = SolvedBy::kRestingIterative;
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
