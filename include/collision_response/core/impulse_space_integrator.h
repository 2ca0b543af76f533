#pragma once

#include <Eigen/Core>
#include <cstddef>

#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/contact_problem.h"
#include "collision_response/core/problem_contact.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/solve_report.h"
#include "collision_response/core/solver_options.h"

namespace collision_response::core {

/// Impulse for one isolated contact under the Poisson or Stronge restitution law with Coulomb
/// friction, integrated along the impact in impulse space (Routh's method, docs/physics.md,
/// "Frictional impact in impulse space"), from the problem's entry of the contact
/// (K = contact.delassus, frame t1, t2, n, coefficients) and its relative velocity u before the
/// impact [m/s]. Same output contract as solveSingleContact(): total impulse
/// P = normal_impulse n + friction_impulse, +P on b and -P on a; u_n' = u_n + n^T K P; a
/// separating or resting contact (u_n >= 0) gets zero impulse; nothing is applied. Laws other
/// than kPoisson and kStronge are forwarded to solveSingleContact(). `detail`, if given, receives
/// the integration's steps, segments, error estimate, p_c, W_c and fallback flag.
///
/// The normal impulse p = P_n is the time-like variable, u(p) the relative contact velocity,
/// s = u_t / |u_t| the slip direction:
///   sliding:  dP/dp = n - mu_d s, du/dp = K (n - mu_d s);
///   sticking (u_t = 0, allowed while |K_tt^-1 K_tn| <= mu_s): dP_t/dp = -K_tt^-1 K_tn;
///   compression ends at u_n(p_c) = 0 with work W_c = integral_0^p_c u_n dp (< 0);
///   Poisson ends at p = (1 + e) p_c, Stronge when integral_p_c^p u_n dp = -e^2 W_c.
/// Segments with a constant slip direction (planar and central impacts, sticking, slip resumed
/// after a stop) are solved in closed form; a rotating 3D slip direction is followed in adaptive
/// Taylor steps (slip_taylor.h) to `tolerance` (local error relative to the impulse scale).
/// Under kStronge the kinetic energy never increases and the contact separates (u_n' >= 0).
///
/// Singular K (least_norm.h's threshold): n^T K n = 0 gives a zero impulse (u_n' = u_n: nothing
/// can push the contact). A singular K_tt: the sticking rate is the least-norm -K_tt^+ K_tn, and
/// the contact sticks only if that holds the slip at zero (K_tn in the range of K_tt) and lies in
/// the static cone, otherwise slip resumes along the direction of resumeDirection() (well defined
/// for singular K_tt). While sliding, friction is Coulomb's, mu_d p against the slip, also along
/// directions in which the bodies cannot move (an immovable guide takes it; the law fixes it).
/// The fallback's plastic impulse is the least-norm -K^+ u.
ContactImpulse integrateSingleContact(const ProblemContact& contact, const Eigen::Vector3d& u,
                                      ImpactLaw law, double tolerance,
                                      ImpulseSpaceDetail* detail = nullptr);

/// Contact i of the problem at its current relative velocity.
inline ContactImpulse integrateSingleContact(const ContactProblem& problem, std::size_t i,
                                             ImpactLaw law, double tolerance,
                                             ImpulseSpaceDetail* detail = nullptr) {
  return integrateSingleContact(problem.contact(i), problem.relativeMotion(i), law, tolerance,
                                detail);
}

/// Two free rigid bodies a and b: the problem entry of the contact alone, integrated as above.
inline ContactImpulse integrateSingleContact(const RigidBody& a, const RigidBody& b,
                                             const ContactPoint& contact, ImpactLaw law,
                                             double tolerance,
                                             ImpulseSpaceDetail* detail = nullptr) {
  const ProblemContact entry = ContactProblem::rigidImpactContact(a, b, contact);
  return integrateSingleContact(entry, entry.free_velocity, law, tolerance, detail);
}

}  // namespace collision_response::core
