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

/// Number D of tangent directions of the friction pyramid: d_k = cos(2 pi k / D) t1 +
/// sin(2 pi k / D) t2, k = 0..D-1, with t1 along the contact's slip before the solve when it
/// slides (t2 = n x t1), otherwise (t1, t2) from tangentBasis(n).
constexpr int kPyramidDirections = 8;

/// The pyramid is inscribed in the Coulomb cone: every friction impulse it allows has
/// |P_t| <= mu P_n, and a saturated (sliding) one has |P_t| >= cos(pi / D) mu P_n (0.924 for D =
/// 8), equality along a direction d_k.
double pyramidFactor();

/// Newton law for simultaneous contacts, solved exactly by Lemke's method (lcp.h), on the contact
/// problem alone (contact_problem.h): its contacts' frames, coefficients, free velocities and
/// targets, and the full Delassus operator of the island from its blocks (diagonal W_ii and the
/// coupled W_ij); the body-space all-sticking variant reads the problem's per-body data (free
/// rigid bodies). Same contract as solveIterative(), so either can be used.
///
/// Symbols (docs/physics.md, "Symbols and conventions" and "Several simultaneous contacts"):
/// u the pre-impact relative velocity of a contact, u_n = u.n, u' after; the target normal
/// velocity is -e u_n for an approaching contact (u_n < 0), 0 otherwise. J maps
/// the bodies' velocities to the contact velocities along n (and d_1..d_D), W = diag(I3 / m,
/// Iw^-1) over the movable bodies, and the Delassus matrix A = J W J^T changes u' = u + A P (its
/// 3x3 diagonal blocks are the contacts' K; shared bodies give the cross terms).
///
/// Frictionless rows: the normal LCP
///   P_n >= 0,  u'_n + e u_n >= 0,  complementary,
/// with A built from the normals only. A is positive semi-definite, so Lemke finds a solution
/// whenever one exists (it may not with e > 0: a body wedged between two walls cannot bounce off
/// one of them); singular A (redundant contacts, e.g. 8 points on a face) is handled by the
/// lexicographic pivoting. P need not be unique then, but u' is.
///
/// Frictional rows (Stewart and Trinkle 1996, Anitescu and Potra 1997), with the pyramid above:
/// variables P_n, beta_1..D >= 0 (friction impulse P_t = sum_k beta_k d_k) and lambda >= 0 (the
/// slip speed), with
///   P_n    complementary to  u'_n + e u_n            >= 0
///   beta_k complementary to  lambda + d_k . u'_t      >= 0
///   lambda complementary to  mu P_n - sum_k beta_k    >= 0.
/// This matrix is copositive but not positive semi-definite. For copositive M, Lemke's method
/// ends on a ray only if some z >= 0 with M z >= 0, z^T M z = 0 has q^T z < 0 (Cottle, Pang and
/// Stone, sec. 4.4; the argument of Anitescu and Potra); here that needs impulses inside the
/// pyramids with zero net effect on every body (bodies jammed against each other) loading a
/// contact with a restitution target (none occurred in 5000 random scenes of 2-5 bodies and up to
/// 13 contacts tried during development).
/// Static and dynamic friction: all contacts start with mu_s; every contact that comes out sliding
/// (|u'_t| > 0, equivalently lambda > 0) switches to mu_d and the problem is solved again, until no
/// contact still on mu_s slides (at most one more solve per contact, usually one). `sticking` is
/// set for a frictional contact with P_n > 0 that ends without slip.
///
/// First, one linear solve: if the impulses that give every contact its target normal velocity
/// without slip (least-norm, A being singular for redundant contacts; solved in the bodies'
/// velocity unknowns when the contacts outnumber them) are compressive and inside the static
/// Coulomb cones, they are the answer (every contact active and sticking; the cone, not the
/// pyramid, bounds them), with no pivot: a box landing flat, a row of touching bodies struck at
/// one end. Otherwise Lemke; small islands (at most kModeSolverMaxUnknowns frame unknowns) first
/// try their modes in closed form (mode_solver.h), each round's answer then being Lemke's where the
/// round's LCP has one solution, and Lemke runs only if no mode fits. When the all-sticking
/// impulses miss the targets because no rigid motion reaches them together (a face's 4 corners
/// with different restitutions), the modes start with one contact separating, those the
/// least-squares motion carries away fastest from their targets first. Where Coulomb friction
/// admits several answers, this sticking one is the one given.
///
/// On success the impulses are applied to the problem (ContactProblem::applyImpulse()) and
/// impulses[i] (normal_impulse, friction_impulse, sticking) is written for problem contact i
/// (resized to the problem; normal velocities are left to the caller). If an LCP is not solved,
/// or its answer violates the conditions above by more than 1e-3 of the island's largest
/// pre-impact |u| (round-off of extreme mass ratios stays below 2e-5), zero impulses are written
/// and applied, and the report is not converged. Report: method kExact, iterations = Lemke pivots
/// plus modes checked, summed over the solves (0 for the all-sticking answer), residual = the
/// largest complementarity violation from the final velocities, relative to the largest pre-impact
/// |u|. Of `options` only the deadline is used (the law is Newton's, the restitution is in the
/// problem's targets; the pivot cap is lcp.h's default, 50 (n + 1) for n unknowns: 1 per
/// frictionless contact, D + 2 per frictional one).
///
/// Singular W (redundant contacts, or bodies with fewer freedoms than their contacts' directions):
/// the all-sticking answer is the least-norm one (complete orthogonal decomposition of the
/// Delassus matrix, or the body-space solve, whose P = J y lies in the range of J), taken only if
/// it reaches every target; Lemke's lexicographic pivoting does not cycle on a singular A, and its
/// answer is one LCP solution among the impulses giving the same velocities, not necessarily the
/// least-norm one. No division by a pivot of W is made outside these decompositions.
SolveReport solveExact(ContactProblem& problem, const SolverOptions& options,
                       std::vector<ContactImpulse>& impulses);

/// Convenience for free rigid bodies: builds the impact problem of the contacts listed in
/// `island`, solves it, adds the velocity changes to `bodies` and writes impulses[island[i]].
SolveReport solveExact(std::vector<RigidBody>& bodies, const std::vector<ContactPoint>& contacts,
                       const std::vector<int>& island, const SolverOptions& options,
                       std::vector<ContactImpulse>& impulses);

}  // namespace collision_response::core
