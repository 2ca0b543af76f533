#include "collision_response/core/island_solver.h"

#include <algorithm>
#include <cmath>

#include "collision_response/core/errors.h"
#include "collision_response/core/exact_solver.h"
#include "collision_response/core/impulse_space_integrator.h"
#include "collision_response/core/iterative_solver.h"
#include "collision_response/core/simultaneous_impact.h"
#include "collision_response/core/single_contact.h"

namespace collision_response::core {
namespace {

// True if a contact approaches faster than round-off of the largest contact speed.
bool approachingBeyondRoundOff(const ContactProblem& problem) {
  double speed = 0.0, slowest = 0.0;
  for (std::size_t i = 0; i < problem.size(); ++i) {
    const Eigen::Vector3d u = problem.relativeMotion(i);
    speed = std::max(speed, u.norm());
    slowest = std::min(slowest, u.dot(problem.contact(i).normal));
  }
  return slowest < -1e-12 * speed;
}

// One contact at a time, in order, each at its current relative velocity: the closed form, the
// impulse-space integration, or (several contacts, one-pass law) the sequential law.
SolveReport solveContactByContact(ContactProblem& problem, const SolverOptions& options,
                                  std::vector<ContactImpulse>& impulses) {
  const bool energetic = options.law == ImpactLaw::kPoisson || options.law == ImpactLaw::kStronge;
  SolveReport report;
  for (std::size_t i = 0; i < problem.size(); ++i) {
    if (energetic) {
      ImpulseSpaceDetail detail;
      impulses[i] =
          integrateSingleContact(problem, i, options.law, options.integration_tolerance, &detail);
      report.method = SolvedBy::kImpulseSpace;
      report.iterations = detail.steps + detail.segments;
      report.residual = detail.error_estimate;
      report.impulse_space = detail;
    } else {
      impulses[i] = solveSingleContact(problem, i, options.law);
      report.method = problem.size() == 1 ? SolvedBy::kClosedForm : SolvedBy::kSequential;
      report.iterations = problem.size();
    }
    problem.applyImpulse(i, impulses[i].total(problem.contact(i).normal));
  }
  return report;
}

// Newton law on the problem with the exact or the iterative solver.
SolveReport solveNewton(SolverMethod method, ContactProblem& problem, const SolverOptions& options,
                        std::vector<ContactImpulse>& impulses) {
  if (method != SolverMethod::kExact) return solveIterative(problem, options, impulses);
  SolveReport report = solveExact(problem, options, impulses);
  if (!report.converged && options.method == SolverMethod::kAuto) {
    // No complementarity solution (a jammed island; the exact solver applied nothing): under the
    // automatic choice the iterative solver gives its best effort, reported as not converged.
    report = solveIterative(problem, options, impulses);
    report.method = SolvedBy::kExactThenIterative;
  }
  return report;
}

// The two-phase Poisson / energetic scheme of solveIsland()'s documentation, in three phases on
// one plastic problem. Kinetic energies are changes since the start of the solve
// (ContactProblem::kineticEnergyChange()).
class TwoPhase {
 public:
  // Relative to the Stronge bound e_max^2 D_c: an excess of round-off.
  static constexpr double kEnergyRoundOff = 1e-12;

  TwoPhase(SolverMethod method, ContactProblem& problem, const SolverOptions& options)
      : method_(method), problem_(problem), options_(options), restitution_(problem.size()) {
    for (std::size_t i = 0; i < problem.size(); ++i) {
      restitution_[i] = problem.contact(i).restitution;
      e_max_ = std::max(e_max_, restitution_[i]);
    }
    problem_.makePlastic();
  }

  /// 1. Compression: the plastic problem with friction; D_c the energy it dissipates.
  SolveReport compression() {
    const SolveReport report = solveNewton(method_, problem_, options_, compression_);
    dissipated_ = std::max(-problem_.kineticEnergyChange(), 0.0);
    return report;
  }

  /// 2. Restitution: normal impulses R_i = s e_i P_c,i, and friction through the phase: with the
  /// R_i fixed, each contact sticks if that needs |T_i| <= mu_s R_i, else slides with mu_d R_i
  /// (Coulomb integrated over the phase; solveIterative() with fixed normal impulses). Stronge: s
  /// is lowered from 1 if the phase would release more than e_max^2 D_c.
  SolveReport restitution() {
    double linear = 0.0;  // R.u_c at s = 1
    for (std::size_t i = 0; i < problem_.size(); ++i) {
      const double u_n = problem_.contact(i).normal.dot(problem_.relativeMotion(i));
      linear += restitution_[i] * compression_[i].normal_impulse * u_n;
    }
    compressed_ = problem_.state();
    const double energy_compressed = problem_.kineticEnergyChange();
    SolveReport friction = restitutionPhase(1.0);
    if (options_.law == ImpactLaw::kStronge) {
      // Stronge: the phase may release at most e_max^2 D_c. If it releases more at s = 1 (friction
      // included), the R_i are scaled down together: alone they release s linear + s^2 q, so the
      // s of that quadratic is within the bound (friction, least energy over its cones with T = 0
      // feasible, can only lower the energy), and the largest s within it with friction lies
      // between that s and 1. It is taken, so that s tends to 1 as the excess at s = 1 does: a
      // contact struck along its normal that sticks releases exactly e^2 D_c at s = 1, and
      // round-off used to choose between s = 1 and the quadratic's s there. An excess of
      // round-off (1e-12 of the bound) keeps s = 1.
      const double allowed = e_max_ * e_max_ * dissipated_;
      const double excess = problem_.kineticEnergyChange() - energy_compressed - allowed;
      if (excess > kEnergyRoundOff * allowed) {
        problem_.restore(compressed_);
        applyNormal(1.0);
        const double q = problem_.kineticEnergyChange() - energy_compressed - linear;
        problem_.restore(compressed_);
        double low =
            q > 0.0 ? (-linear + std::sqrt(linear * linear + 4.0 * q * allowed)) / (2.0 * q) : 0.0;
        low = std::clamp(low, 0.0, 1.0);
        restitutionPhase(low);
        const double excess_low = problem_.kineticEnergyChange() - energy_compressed - allowed;
        scale_ = largestScaleWithin(low, excess_low, excess, energy_compressed, allowed);
        problem_.restore(compressed_);
        friction = restitutionPhase(scale_);
      }
    }
    return friction;
  }

  /// 3. Clean-up: no contact may end approaching.
  SolveReport cleanUp() {
    SolveReport report = solveNewton(method_, problem_, options_, cleanup_);
    // Unequal e_i on coupled contacts can leave the restitution phase with contact velocities far
    // above the final ones, and the clean-up's round-off is relative to them. One more plastic
    // solve from its result removes what is left approaching, relative to the final velocities.
    if (report.converged && approachingBeyondRoundOff(problem_)) {
      std::vector<ContactImpulse> polish;
      const SolveReport again = solveNewton(method_, problem_, options_, polish);
      for (std::size_t i = 0; i < problem_.size(); ++i) {
        cleanup_[i].normal_impulse += polish[i].normal_impulse;
        cleanup_[i].friction_impulse += polish[i].friction_impulse;
      }
      report.iterations += again.iterations;
      report.residual = again.residual;
      report.converged = again.converged;
    }
    return report;
  }

  /// The total impulse of each contact over the phases, and whether it ends without slip.
  void writeImpulses(std::vector<ContactImpulse>& impulses) const {
    impulses.resize(problem_.size());
    for (std::size_t i = 0; i < problem_.size(); ++i) {
      const ProblemContact& c = problem_.contact(i);
      ContactImpulse& impulse = impulses[i];
      impulse.normal_impulse = (1.0 + scale_ * restitution_[i]) * compression_[i].normal_impulse +
                               cleanup_[i].normal_impulse;
      impulse.friction_impulse = compression_[i].friction_impulse +
                                 restitution_phase_[i].friction_impulse +
                                 cleanup_[i].friction_impulse;
      // Sticking: no slip left at the end.
      const Eigen::Vector3d u = problem_.relativeMotion(i);
      const double slip = (u - u.dot(c.normal) * c.normal).norm();
      impulse.sticking = !c.frictionless() && impulse.normal_impulse > 0.0 &&
                         slip <= 1e-9 * std::max(u.norm(), 1e-300);
    }
  }

 private:
  void applyNormal(double scale) {
    for (std::size_t i = 0; i < problem_.size(); ++i) {
      restitution_normal_[i] = scale * restitution_[i] * compression_[i].normal_impulse;
      problem_.applyImpulse(i, restitution_normal_[i] * problem_.contact(i).normal);
    }
  }

  // The largest s in [low, 1] whose restitution phase, friction included, releases at most
  // `allowed`: f(s) = released - allowed, f(low) = f_low <= 0 < f(1) = f_high; Illinois regula
  // falsi until the bracket is 1e-12 wide or f(low) is within kEnergyRoundOff of the bound.
  double largestScaleWithin(double low, double f_low, double f_high, double energy_compressed,
                            double allowed) {
    if (!(f_low <= 0.0)) return low;
    double high = 1.0;
    int side = 0;
    for (int k = 0; k < 60 && high - low > 1e-12; ++k) {
      const double s = std::clamp(high - f_high * (high - low) / (f_high - f_low), low, high);
      problem_.restore(compressed_);
      restitutionPhase(s);
      const double f = problem_.kineticEnergyChange() - energy_compressed - allowed;
      if (f <= 0.0) {
        low = s;
        f_low = f;
        if (side == -1) f_high *= 0.5;
        side = -1;
      } else {
        high = s;
        f_high = f;
        if (side == 1) f_low *= 0.5;
        side = 1;
      }
      if (f <= 0.0 && f >= -kEnergyRoundOff * allowed) break;
    }
    return low;
  }

  SolveReport restitutionPhase(double scale) {
    restitution_normal_.assign(problem_.size(), 0.0);
    applyNormal(scale);
    restitution_phase_.assign(problem_.size(), ContactImpulse{});
    for (std::size_t i = 0; i < problem_.size(); ++i) {
      if (!problem_.contact(i).frictionless() && restitution_normal_[i] > 0.0) {
        return solveIterative(problem_, options_, restitution_phase_, &restitution_normal_);
      }
    }
    SolveReport none;
    none.iterations = 0;
    return none;
  }

  SolverMethod method_;
  ContactProblem& problem_;
  const SolverOptions& options_;
  std::vector<double> restitution_;  // e_i, read before the problem was made plastic
  double e_max_ = 0.0;
  double dissipated_ = 0.0;  // D_c [J]
  double scale_ = 1.0;       // s
  ContactProblem::State compressed_;
  std::vector<double> restitution_normal_;
  std::vector<ContactImpulse> compression_, restitution_phase_, cleanup_;
};

SolveReport solveTwoPhase(SolverMethod method, ContactProblem& problem,
                          const SolverOptions& options, std::vector<ContactImpulse>& impulses) {
  TwoPhase scheme(method, problem, options);
  const SolveReport first = scheme.compression();
  const SolveReport friction = scheme.restitution();
  const SolveReport third = scheme.cleanUp();
  scheme.writeImpulses(impulses);
  SolveReport report;
  report.method =
      method == SolverMethod::kExact ? SolvedBy::kTwoPhaseExact : SolvedBy::kTwoPhaseIterative;
  report.iterations = first.iterations + friction.iterations + third.iterations;
  report.residual = std::max({first.residual, friction.residual, third.residual});
  report.converged = first.converged && friction.converged && third.converged;
  return report;
}

}  // namespace

SolveReport solveIsland(ContactProblem& problem, const SolverOptions& options,
                        std::vector<ContactImpulse>& impulses) {
  impulses.resize(problem.size());
  const bool energetic = options.law == ImpactLaw::kPoisson || options.law == ImpactLaw::kStronge;
  if (options.law == ImpactLaw::kSeedOnePass ||
      (problem.size() == 1 && options.method == SolverMethod::kAuto)) {
    return solveContactByContact(problem, options, impulses);
  }
  if (options.method == SolverMethod::kExact && problem.size() > kExactSolverContactLimit) {
    throw InvalidInput("options.solver", "the exact solver takes islands of at most " +
                                             std::to_string(kExactSolverContactLimit) +
                                             " contacts; this one has " +
                                             std::to_string(problem.size()) +
                                             ": use the iterative or the automatic solver");
  }
  const SolverMethod method = options.method != SolverMethod::kAuto ? options.method
                              : problem.size() <= kExactSolverMaxContacts
                                  ? SolverMethod::kExact
                                  : SolverMethod::kIterative;
  if (energetic && options.simultaneous_impulse_space && options.method == SolverMethod::kAuto &&
      problem.size() <= kSimultaneousMaxContacts) {
    const SolveReport simultaneous =
        solveSimultaneousImpulseSpace(problem, options, impulses, /*plastic_rest=*/false);
    if (!simultaneous.impulse_space || !simultaneous.impulse_space->fallback) return simultaneous;
    // Not finished within its step budget (contacts jammed so that a compression ends only
    // asymptotically); nothing was applied: the two-phase scheme from the start.
    SolveReport two_phase = solveTwoPhase(method, problem, options, impulses);
    two_phase.iterations += simultaneous.iterations;
    return two_phase;
  }
  return energetic ? solveTwoPhase(method, problem, options, impulses)
                   : solveNewton(method, problem, options, impulses);
}

SolveReport solveIsland(std::vector<RigidBody>& bodies, const std::vector<ContactPoint>& contacts,
                        const std::vector<int>& island, const SolverOptions& options,
                        std::vector<ContactImpulse>& impulses) {
  ContactProblem problem;
  problem.buildImpact(bodies, contacts, island);
  std::vector<ContactImpulse> local;
  SolveReport report = solveIsland(problem, options, local);
  problem.addVelocityChangesTo(bodies);
  for (std::size_t i = 0; i < island.size(); ++i) {
    ContactImpulse& out = impulses[island[i]];
    out.normal_impulse = local[i].normal_impulse;
    out.friction_impulse = local[i].friction_impulse;
    out.sticking = local[i].sticking;
  }
  report.contacts = island;
  return report;
}

}  // namespace collision_response::core
