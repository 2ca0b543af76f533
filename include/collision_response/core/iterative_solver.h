#pragma once

#include <vector>

#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/contact_problem.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/solve_report.h"
#include "collision_response/core/solver_options.h"

namespace collision_response::core {

/// Newton law for simultaneous contacts by projected Gauss-Seidel on accumulated impulses
/// (sequential impulses, docs/physics.md, "The iterative solver"), on the contact problem alone:
/// each contact's diagonal block W_ii, its target normal motion, and the problem's map from
/// impulses to the bodies' velocity unknowns (a sweep is O(contacts), W is never formed). At
/// convergence each contact's accumulated impulse P satisfies: P_n >= 0, u'_n >= target,
/// P_n (u'_n - target) = 0, and Coulomb friction: sticking (u'_t = 0) where that needs
/// |P_t| <= mu_s P_n, otherwise sliding with |P_t| = mu_d P_n exactly opposite to the slip u'_t
/// (each contact's friction solved on its own disk with its own K_tt, maximal dissipation:
/// solveFrictionDisk(), friction_disk.h). Static and dynamic: sweeps run on the static cones to
/// convergence; contacts that still slip on theirs (|u'_t| above 1e-9 of the problem's largest
/// |u| before the solve; reaching the rim of the disk with the slip gone is sticking at the limit)
/// then move to the dynamic cone and the sweeps continue, until no contact moves (the exact
/// solver's rule). A resting problem
/// (ProblemLevel::kAcceleration) is solved the same way on accelerations and forces, a contact with
/// a slip_direction getting the friction -mu_d F_n along it.
///
/// Applies the impulses to the problem (ContactProblem::applyImpulse()) and writes impulses[i]
/// (normal_impulse, friction_impulse, sticking) for problem contact i (resized to the problem).
/// If the sweeps diverge (an accumulated impulse overflows: no solution exists), the problem is
/// restored, the impulses are zero (friction only: no friction, the fixed normal impulses) and
/// the report is not converged. Report: method kIterative, iterations = sweeps, residual = the
/// largest impulse change of the last sweep relative to the largest impulse.
///
/// Friction only: with `fixed_normal_impulses` (one per problem contact, >= 0, already applied to
/// the problem) the normal rows are not solved; each contact's friction is bounded by mu times
/// its fixed normal impulse, and the sweeps find the tangential impulses alone (the restitution
/// phase of the two-phase scheme). At convergence that is the least kinetic energy over the
/// cones, never more than without friction. Reported normal impulses are the fixed ones.
///
/// Singular W (bodies with fewer freedoms): a contact with n^T W_ii n = 0 gets no normal update
/// (no impulse moves it along n: the direction is skipped); a singular K_tt is inverted as a
/// pseudo-inverse (least_norm.h), so the sticking tangential update is the least-norm one. At the
/// end the impulse of a contact with a singular W_ii is projected onto the range of W_ii (its
/// component in the null space of W_ii changes no velocity anywhere: J_i^T maps it to 0) when the
/// projected impulse still satisfies P_n >= 0 and the cone (not in friction-only or fixed-slip
/// mode): each contact's impulse is then least-norm for its own block. Redundant contacts (a null
/// space of W spanning several contacts, e.g. 1000 points under one box) are not split least-norm:
/// that is the exact solver's all-sticking solve.
SolveReport solveIterative(ContactProblem& problem, const SolverOptions& options,
                           std::vector<ContactImpulse>& impulses,
                           const std::vector<double>* fixed_normal_impulses = nullptr);

/// Convenience for free rigid bodies: builds the impact problem of the contacts listed in
/// `island`, solves it, adds the velocity changes to `bodies` and writes impulses[island[i]].
SolveReport solveIterative(std::vector<RigidBody>& bodies,
                           const std::vector<ContactPoint>& contacts,
                           const std::vector<int>& island, const SolverOptions& options,
                           std::vector<ContactImpulse>& impulses);

}  // namespace collision_response::core
