#include "collision_response/core/iterative_solver.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>

#include "collision_response/core/friction_disk.h"
#include "collision_response/core/least_norm.h"

namespace collision_response::core {
namespace {

// Per-contact data fixed for the whole solve, and the accumulated impulse.
struct ContactState {
  double inverse_k_nn = 0.0;  // 1 / (n^T K n); 0 if n^T K n = 0 (the normal direction is skipped)
  Eigen::Matrix2d k_tt = Eigen::Matrix2d::Zero();  // T^T K T [1/kg], T = [t1 t2]
  bool singular = false;                           // det K = 0 (least_norm.h)
  double P_n = 0.0;                                // accumulated normal impulse
  Eigen::Vector2d P_t = Eigen::Vector2d::Zero();   // accumulated tangential impulse, (t1, t2)
  double mu = 0.0;  // cone of the current pass: mu_s until the contact is found sliding, then mu_d
  bool sliding = false;  // the last sweep had to project onto the cone
};

// Set-up: inverse blocks, the starting cones, the fixed normal impulses.
std::vector<ContactState> setUp(const ContactProblem& problem,
                                const std::vector<double>* fixed_normal_impulses) {
  std::vector<ContactState> state(problem.size());
  for (std::size_t i = 0; i < problem.size(); ++i) {
    const ProblemContact& c = problem.contact(i);
    ContactState& s = state[i];
    const Eigen::Matrix3d& K = c.delassus;
    const double trace = K.trace();
    const double k_nn = c.normal.dot(K * c.normal);
    s.inverse_k_nn = k_nn > kSingularRelative * trace ? 1.0 / k_nn : 0.0;
    s.singular = !(K.determinant() > kSingularRelative * trace * trace * trace);
    s.mu = c.static_friction;
    if (fixed_normal_impulses) s.P_n = (*fixed_normal_impulses)[i];
    if (!c.frictionless()) {
      const Eigen::Vector3d& t1 = c.tangent1;
      const Eigen::Vector3d& t2 = c.tangent2;
      s.k_tt << t1.dot(K * t1), t1.dot(K * t2), t2.dot(K * t1), t2.dot(K * t2);
    }
  }
  return state;
}

// One Gauss-Seidel sweep over the contacts; returns the largest impulse change and (through
// largest_impulse) the largest accumulated impulse.
double sweep(ContactProblem& problem, std::vector<ContactState>& state, bool friction_only,
             double& largest_impulse) {
  double largest_change = 0.0;
  largest_impulse = 0.0;
  for (std::size_t i = 0; i < problem.size(); ++i) {
    const ProblemContact& c = problem.contact(i);
    ContactState& s = state[i];

    // Normal row: drive u_n to its target, keep the accumulated impulse compressive.
    double change = 0.0;
    if (!friction_only) {
      const double u_n = c.normal.dot(problem.relativeMotion(i));
      const double P_n = std::max(s.P_n - (u_n - problem.targetNormal(i)) * s.inverse_k_nn, 0.0);
      const double dP_n = P_n - s.P_n;
      s.P_n = P_n;
      problem.applyImpulse(i, dP_n * c.normal);
      change = std::abs(dP_n);
    }
    const double P_n = s.P_n;

    // Tangential block: the contact's own friction disk with its own K_tt (maximal dissipation,
    // friction_disk.h): stick if the sticking impulse lies in the cone, otherwise friction on the
    // cone exactly opposite to the slip it leaves (docs/physics.md, "The iterative solver").
    if (!c.frictionless()) {
      const Eigen::Vector3d u = problem.relativeMotion(i);
      // The tangential motion without this contact's own accumulated tangential impulse.
      const Eigen::Vector2d u0 =
          Eigen::Vector2d(u.dot(c.tangent1), u.dot(c.tangent2)) - s.k_tt * s.P_t;
      const bool fixed_slip = !c.slip_direction.isZero(0.0);
      Eigen::Vector2d P_t;
      if (fixed_slip) {  // friction fixed against an existing slip
        s.sliding = true;
        P_t = -c.dynamic_friction * P_n *
              Eigen::Vector2d(c.slip_direction.dot(c.tangent1), c.slip_direction.dot(c.tangent2));
      } else {
        bool sticking = true;
        P_t = solveFrictionDisk(s.k_tt, u0, s.mu * P_n, sticking);
        s.sliding = !sticking;
      }
      const Eigen::Vector2d dP_t = P_t - s.P_t;
      s.P_t = P_t;
      problem.applyImpulse(i, dP_t.x() * c.tangent1 + dP_t.y() * c.tangent2);
      change = std::max(change, dP_t.norm());
    }
    largest_change = std::max(largest_change, change);
    largest_impulse = std::max(largest_impulse, std::hypot(s.P_n, s.P_t.norm()));
  }
  return largest_change;
}

// A contact slides if its tangential motion at convergence exceeds this fraction of the island's
// largest relative motion before the solve (the exact solver's kSlipTolerance).
constexpr double kSlipTolerance = 1e-9;

// The largest |u| of the problem's contacts as they are now (before the solve: the scale of
// kSlipTolerance).
double largestMotion(const ContactProblem& problem) {
  double largest = 0.0;
  for (std::size_t i = 0; i < problem.size(); ++i) {
    largest = std::max(largest, problem.relativeMotion(i).norm());
  }
  return largest;
}

// Converged on the current cones: contacts that still slip on their static cone move to the
// dynamic one (docs/physics.md, "Static friction first"). A contact whose friction only reached the
// rim of its static disk but whose slip is gone (|u'_t| <= kSlipTolerance * reference) sticks at
// its limit and stays on mu_s: static friction holds it. True if any moved.
bool switchStaticToDynamic(const ContactProblem& problem, std::vector<ContactState>& state,
                           double reference) {
  bool moved = false;
  for (std::size_t i = 0; i < problem.size(); ++i) {
    const ProblemContact& c = problem.contact(i);
    ContactState& s = state[i];
    if (!s.sliding || s.mu == c.dynamic_friction) continue;
    const Eigen::Vector3d u = problem.relativeMotion(i);
    if ((u - u.dot(c.normal) * c.normal).norm() > kSlipTolerance * reference) {
      s.mu = c.dynamic_friction;
      moved = true;
    }
  }
  return moved;
}

// A contact with a singular block: its impulse projected onto the range of W_ii (the same
// velocities, the least norm for its block), if that stays compressive and in the cone.
void projectOntoRange(ContactProblem& problem, std::size_t i, ContactState& s) {
  const ProblemContact& c = problem.contact(i);
  const Eigen::Vector3d P = s.P_n * c.normal + s.P_t.x() * c.tangent1 + s.P_t.y() * c.tangent2;
  const Eigen::Vector3d projected = symmetricPseudoInverse(c.delassus) * (c.delassus * P);
  const double P_n = projected.dot(c.normal);
  const Eigen::Vector2d P_t(projected.dot(c.tangent1), projected.dot(c.tangent2));
  if (!(P_n >= 0.0) || P_t.norm() > s.mu * P_n * (1.0 + 1e-12)) return;
  if (c.frictionless() && P_t.norm() > 1e-12 * P_n) return;  // must stay along n
  problem.applyImpulse(i, projected - P);  // in the null space of W: velocities unchanged
  s.P_n = P_n;
  s.P_t = c.frictionless() ? Eigen::Vector2d::Zero() : P_t;
}

// Write-back: each contact's impulse and sticking flag.
void writeImpulses(const ContactProblem& problem, const std::vector<ContactState>& state,
                   std::vector<ContactImpulse>& impulses) {
  impulses.resize(problem.size());
  for (std::size_t i = 0; i < problem.size(); ++i) {
    const ProblemContact& c = problem.contact(i);
    const ContactState& s = state[i];
    ContactImpulse& impulse = impulses[i];
    impulse.normal_impulse = s.P_n;
    impulse.friction_impulse = s.P_t.x() * c.tangent1 + s.P_t.y() * c.tangent2;
    impulse.sticking = !c.frictionless() && s.P_n > 0.0 && !s.sliding;
  }
}

}  // namespace

SolveReport solveIterative(ContactProblem& problem, const SolverOptions& options,
                           std::vector<ContactImpulse>& impulses,
                           const std::vector<double>* fixed_normal_impulses) {
  const bool friction_only = fixed_normal_impulses != nullptr;
  std::vector<ContactState> state = setUp(problem, fixed_normal_impulses);
  const ContactProblem::State initial = problem.state();  // to restore if the sweeps diverge
  const double reference = largestMotion(problem);        // the scale of a slip

  SolveReport report;
  report.method = SolvedBy::kIterative;
  report.converged = false;
  std::size_t& sweeps = report.iterations;
  for (sweeps = 1; sweeps <= options.max_iterations; ++sweeps) {
    if (sweeps % 16 == 0) options.deadline.check("the iterative solver");
    double largest_impulse = 0.0;
    const double largest_change = sweep(problem, state, friction_only, largest_impulse);
    if (!std::isfinite(largest_impulse) || !std::isfinite(largest_change)) {
      // Diverged (no solution: e.g. a squeeze that cannot bounce, or sliding friction that makes a
      // contact's effective mass negative, Painleve's case): apply nothing, report not converged.
      // (Friction only: the fixed normal impulses were applied before, and stay.)
      problem.restore(initial);
      for (std::size_t i = 0; i < state.size(); ++i) {
        state[i].P_n = friction_only ? (*fixed_normal_impulses)[i] : 0.0;
        state[i].P_t.setZero();
        state[i].sliding = false;
      }
      break;
    }
    report.residual = largest_impulse > 0.0 ? largest_change / largest_impulse : largest_change;
    if (report.residual <= options.tolerance && !switchStaticToDynamic(problem, state, reference)) {
      report.converged = true;
      break;
    }
  }
  sweeps = std::min(sweeps, options.max_iterations);

  if (report.converged && !friction_only) {
    for (std::size_t i = 0; i < problem.size(); ++i) {
      if (state[i].singular && problem.contact(i).slip_direction.isZero(0.0)) {
        projectOntoRange(problem, i, state[i]);
      }
    }
  }
  writeImpulses(problem, state, impulses);
  return report;
}

SolveReport solveIterative(std::vector<RigidBody>& bodies,
                           const std::vector<ContactPoint>& contacts,
                           const std::vector<int>& island, const SolverOptions& options,
                           std::vector<ContactImpulse>& impulses) {
  return solveRigidIsland(bodies, contacts, island, impulses,
                          [&](ContactProblem& problem, std::vector<ContactImpulse>& solved) {
                            return solveIterative(problem, options, solved);
                          });
}

}  // namespace collision_response::core
