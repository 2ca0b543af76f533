#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/contact_problem.h"
#include "collision_response/core/solve_report.h"
#include "collision_response/core/solver_options.h"

namespace collision_response::core {

/// Poisson or Stronge impact of all the contacts of an island integrated together in impulse space
/// (docs/physics.md, "Simultaneous impulse-space integration"). Each contact has its own
/// compression and restitution phases and its own slip, stick and slip resumption (mu_d while
/// sliding, mu_s only once stopped). options.simultaneous_sharing shares the normal impulse
/// increments among the active contacts:
///  - kVelocityConsistent: rates are the impulses still needed per unit of a fictitious time; the
///    compressing contacts take the plastic complementarity rates (W seen through the current
///    friction, least norm on redundant contacts) that bring their normal velocities to 0 together
///    at t = 1; a restituting contact takes its remaining Poisson impulse (1 + e) p_c - P_n
///    (Stronge: the same, then its remaining work over u_n). A step goes to the next event in one
///    piece.
///  - kSpring: equal linear contact stiffnesses (Liu, Zhao and Brogliato's distribution with
///    eta = 1): contact i's rate is proportional to its compression delta_i = -integral of u_n,i in
///    a fictitious time, unloading along k / e_i^2; fixed steps.
///
/// Ends: a contact's compression when its u_n reaches 0 (p_c, W_c its own); its restitution at
/// P_n = (1 + e) p_c (Poisson) or when its work reaches -e^2 W_c (Stronge). A finished contact that
/// approaches again starts a new compression. One contact: integrateSingleContact(). Applies the
/// impulses to the problem and writes impulses[i] (normal and friction parts, sticking), like
/// solveIsland(). Laws other than Poisson and Stronge: std::invalid_argument.
///
/// Past a step budget (report.converged = false, impulse_space->fallback = true): with
/// `plastic_rest`, the rest is a plastic exact solve with friction, so that no contact ends
/// approaching; without, nothing is applied and impulses are not written (solveIsland() then
/// solves the island by the two-phase scheme from the start).
SolveReport solveSimultaneousImpulseSpace(ContactProblem& problem, const SolverOptions& options,
                                          std::vector<ContactImpulse>& impulses,
                                          bool plastic_rest = true);

/// The derivatives of solveSimultaneousImpulseSpace()'s impulses (docs/physics.md, "Derivatives
/// through the simultaneous integration"): the same integration run on dual numbers, so that every
/// step, event time and rate is differentiated as computed (the final impulse through the
/// integration and its event conditions), with the branches the solve takes. They are the
/// derivatives of the answer's own piece: one-sided where a perturbation would change the sequence
/// of events (`switches` names the ones met within kSwitchTolerance-like margins), and of the
/// discretised map (the turning slip's steps). Gradient directions go through the scheme eight
/// at a time.
struct SimultaneousImpulseDerivatives {
  /// 3m x 3m (empty unless asked): dP/du, P the contacts' impulses stacked (world, on body b)
  /// [N s], u their pre-impact relative velocities (world, v_b - v_a) [m/s].
  Eigen::MatrixXd dP_du;
  /// 3m x 3m: dP/dtheta, theta per contact (e, mu_s, mu_d); columns not asked for are 0, and so
  /// are mu_s's (it only decides branches: which contacts stay stuck).
  Eigen::MatrixXd dP_dtheta;
  Eigen::VectorXd impulses;           ///< 3m: P of the dual run (the solve's, to round-off)
  std::vector<std::string> switches;  ///< per contact: the switches met (empty: none)
};

/// On `problem` as the solve found it (before any impulse), under options.law (Poisson, Stronge)
/// and options.simultaneous_sharing. `velocities`: compute dP/du; `coefficients` (3m, empty: all)
/// which coefficient columns. False (the caller differences) for one contact or more than
/// kSimultaneousMaxContacts, an integration that does not finish within its step budget or
/// options.deadline, a frictionless contact's friction columns (friction enters only once mu > 0),
/// the restitution column of a contact with e = 0 (e enters nowhere there), or rates from Lemke's
/// method with a weakly active contact (a vertex of a set of answers, which can change with the
/// inputs).
bool differentiateSimultaneousImpulseSpace(const ContactProblem& problem,
                                           const SolverOptions& options, bool velocities,
                                           const std::vector<bool>& coefficients,
                                           SimultaneousImpulseDerivatives& out);

}  // namespace collision_response::core
