#pragma once

#include <cstddef>
#include <vector>

#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/contact_problem.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/solve_report.h"
#include "collision_response/core/solver_options.h"

namespace collision_response::core {

/// Largest island that SolverMethod::kAuto sends to the exact (pivoting) solver; larger ones
/// iterate.
constexpr std::size_t kExactSolverMaxContacts = 12;
/// Largest Poisson / Stronge island that SolverMethod::kAuto integrates simultaneously in impulse
/// space when SolverOptions::simultaneous_impulse_space is set (the default; simultaneous_impact.h;
/// each step costs a small complementarity problem, O(contacts^3)); larger ones, explicit
/// kExact / kIterative, and islands it cannot finish within its step budget take the two-phase
/// scheme.
constexpr std::size_t kSimultaneousMaxContacts = kExactSolverMaxContacts;
/// Largest island the exact solver takes when asked for explicitly (its dense tableau grows as the
/// square of the contacts); larger ones are an InvalidInput on "options.solver".
constexpr std::size_t kExactSolverContactLimit = 128;

/// Solves one island's impact problem (contact_problem.h, built once by the caller) under
/// options.law, applying the impulses to the problem (ContactProblem::applyImpulse(); the caller
/// adds its velocity changes to the bodies) and writing impulses[i]'s normal and friction parts
/// and sticking flag for problem contact i (resized to the problem; normal_velocity_before/after
/// are the caller's). The report's method is one of kClosedForm, kImpulseSpace, kSequential,
/// kExact, kIterative, kExactThenIterative, kTwoPhaseExact, kTwoPhaseIterative,
/// kSimultaneousImpulseSpace.
///
/// One contact (SolverMethod::kAuto): Newton in closed form; Poisson and Stronge by impulse-space
/// integration. Several contacts: Newton by the exact or the iterative solver; Poisson and Stronge,
/// under kAuto up to kSimultaneousMaxContacts contacts and if options.simultaneous_impulse_space
/// is set (the default), by the simultaneous impulse-space integration
/// (solveSimultaneousImpulseSpace(), kSimultaneousImpulseSpace; if it does not finish within its
/// step budget, nothing of it is applied and the two-phase scheme below solves the island);
/// otherwise by a two-phase scheme built on the same solvers:
///   1. compression: the plastic problem (e = 0) with Coulomb friction: no contact approaches and
///      friction opposes the final slip, so kinetic energy drops by D_c >= 0;
///   2. restitution: normal impulses R_i = e_i P_c,i at every contact (Poisson). For Stronge they
///      are scaled down together, if needed, so that the energy they release is at most
///      e_max^2 D_c. Friction acts through this phase too: with the R_i fixed, the tangential
///      impulses T_i stick each contact where that needs |T_i| <= mu_s R_i, else slide with
///      mu_d R_i (solveIterative() with fixed normal impulses: least energy over the cones);
///   3. a second plastic solve, so that no contact ends approaching, with friction.
/// Phase 2's normal impulses release 1/2 R^T A R (R.u_c = 0 by complementarity), its friction and
/// phases 1 and 3 dissipate, so with Stronge kinetic energy never increases; for frictionless
/// contacts with a common e phase 2 needs no scaling and Poisson and Stronge coincide. The answer
/// of simultaneous laws is not unique in general (Newton's cradle): this is the simultaneous one.
/// The one-pass law (the textbook two-pass procedure, docs/physics.md, "The textbook two-pass
/// procedure and its pitfalls") takes its contacts one at a time, in request order. The two-phase
/// scheme makes the problem plastic (ContactProblem::makePlastic()) after reading its e_i.
/// Singular W: each solver's rule (single_contact.h, impulse_space_integrator.h, exact_solver.h,
/// iterative_solver.h); the two-phase scheme adds nothing that divides by W.
SolveReport solveIsland(ContactProblem& problem, const SolverOptions& options,
                        std::vector<ContactImpulse>& impulses);

/// Convenience for free rigid bodies: builds the impact problem of the contacts listed in
/// `island`, solves it, adds the velocity changes to `bodies` and writes impulses[island[i]]
/// (normal and friction parts, sticking). report.contacts = island.
SolveReport solveIsland(std::vector<RigidBody>& bodies, const std::vector<ContactPoint>& contacts,
                        const std::vector<int>& island, const SolverOptions& options,
                        std::vector<ContactImpulse>& impulses);

}  // namespace collision_response::core
