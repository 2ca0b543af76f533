#pragma once

#include <vector>

#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/contact_problem.h"
#include "collision_response/core/solve_report.h"
#include "collision_response/core/solver_options.h"

namespace collision_response::core {

/// The force-based Coulomb model (docs/physics.md, "Resting contacts") for an island in which no
/// contact approaches, on its resting problem (ContactProblem::buildResting(), level
/// kAcceleration: the free relative accelerations of the contact points under the bodies' wrenches
/// alone, with the centripetal terms w x (w x r), in ProblemContact::free_acceleration). Each
/// contact gets the contact force F (+F on b, -F on a) that the wrenches call for:
///   F_n >= 0, a'_n >= 0, F_n a'_n = 0 (a the relative acceleration at the point);
///   a contact without slip sticks (a'_t = 0) if that needs |F_t| <= mu_s F_n, otherwise it starts
///   to slide with |F_t| = mu_d F_n opposite to the slip acceleration it leaves (several contacts:
///   the iterative solver's friction disk, friction_disk.h); a contact already slipping
///   (ProblemContact::slip_direction) gets F_t = -mu_d F_n along it (dynamic friction against the
///   slip).
/// It is the plastic Newton problem of the impact solvers on accelerations instead of velocities,
/// with the same Delassus operator: one resting contact is solved in closed form
/// (solveSingleContact(), whose singular-W rule applies). Several: static friction first
/// (docs/physics.md, "Static friction first"): if no contact slips already, the all-stick problem
/// on the mu_s cones (min F.a + F^T W F / 2 over the cones, block Gauss-Seidel with
/// solveFrictionCone()) is solved, and its answer kept if it is stuck (every loaded contact left
/// with a' = 0, every unloaded one touching without slip or separating, to 1e-9 of the island's
/// largest free relative acceleration): some split of the forces within the static cones holds
/// the island (the sweeps stop after 32 if noStuckAnswer(), stick_certificate.h, proves that no
/// stuck answer exists). Otherwise the iterative solver (its singular-W rule applies), whose
/// contacts move to mu_d only if they still slip on their static cone; a contact whose slip was
/// below the resting velocity (ProblemContact::slow_slip) is posed sliding along it first (no
/// stuck answer: it does slip, and Coulomb's law at u_t != 0 puts -mu_d F_n against it).
/// `sticking`: no slip, not separating and a'_t = 0 to that tolerance. Writes forces[i] (resting,
/// normal_force, friction_force, sticking) for problem contact i (resized to the problem); the
/// forces are applied to the problem's accelerations, never to the bodies. Report:
/// kRestingClosedForm or kRestingIterative (kNone if empty); a sliding single contact whose force
/// cannot keep a'_n = 0 (Painleve) is not converged.
SolveReport solveRestingIsland(ContactProblem& problem, const SolverOptions& options,
                               std::vector<ContactImpulse>& forces);

}  // namespace collision_response::core
