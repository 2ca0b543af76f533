#pragma once

#include <Eigen/Core>
#include <cstddef>

#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/contact_problem.h"
#include "collision_response/core/problem_contact.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/solver_options.h"

namespace collision_response::core {

/// The three paths of solveSingleContact(), each out of line on its own: the caller's one call
/// reaches the path it needs, and the frictionless form does not share a stack frame (nor the
/// register spills) with the frictional one. Each returns a zero impulse when u_n >= 0.
namespace single_contact_paths {
ContactImpulse frictionlessNewton(const ProblemContact& contact, const Eigen::Vector3d& u);
ContactImpulse frictionalNewton(const ProblemContact& contact, const Eigen::Vector3d& u);
ContactImpulse seedOnePass(const ProblemContact& contact, const Eigen::Vector3d& u);
}  // namespace single_contact_paths

/// Closed-form impulse for one isolated contact under the given law, from the problem's entry of
/// the contact (K = contact.delassus, n, e, mu_s, mu_d) and its relative velocity u before the
/// impulse [m/s] (docs/physics.md, "Newton restitution with Coulomb friction"). Nothing is
/// applied: the caller applies impulse.total(n) (+P on b, -P on a). A separating or resting
/// contact (u_n >= 0) gets a zero impulse. Under any law but kSeedOnePass this is Newton's:
///   stick:  P = K^-1 (-(1 + e) u_n n - u_t), accepted if P.n >= 0 and |P_t| <= mu_s P.n;
///   slide:  P = P_n (n + mu_d d), d the unit tangential direction of the sticking impulse, and
///           P_n = -(1 + e) u_n / (n^T K (n + mu_d d)) so that u'_n = -e u_n still holds.
/// If that denominator is not positive (friction would drive the contact deeper: a Painleve-like
/// configuration), the sticking impulse is returned, flagged sticking, outside the cone.
/// Frictionless contacts take the frictionless impulse formula (docs/physics.md, "The frictionless
/// impulse formula") directly: P = -(1 + e) u_n / (n^T K n) n. kSeedOnePass: the textbook
/// two-pass procedure (docs/physics.md, "The textbook two-pass procedure and its pitfalls").
///
/// Singular K (bodies with fewer freedoms than the contact's 3 directions; det K at most
/// kSingularRelative trace(K)^3, least_norm.h), on a separate path:
///   - n^T K n = 0 (no impulse can move the contact along n): zero impulse, u'_n = u_n;
///   - stick: P = K^+ (-(1 + e) u_n n - u_t), the least-norm impulse, accepted only if it reaches
///     that velocity (the target may lie outside the range of K: a rail cannot let the contact
///     slip along every tangent) and lies in the static cone;
///   - otherwise the slide above along d (impulse fixed by the law, so unique), or, when it has
///     no direction or no positive denominator, the frictionless impulse P_n n.
///   - kSeedOnePass: the friction pass is skipped along a tangent t with t^T K t = 0 (no impulse
///     along t changes the velocity: the least-norm friction impulse is 0).

inline ContactImpulse solveSingleContact(const ProblemContact& contact, const Eigen::Vector3d& u,
                                         ImpactLaw law) {
  if (law == ImpactLaw::kSeedOnePass) return single_contact_paths::seedOnePass(contact, u);
  return contact.frictionless() ? single_contact_paths::frictionlessNewton(contact, u)
                                : single_contact_paths::frictionalNewton(contact, u);
}

/// Contact i of the problem at its current relative velocity (problem.relativeMotion(i)).
inline ContactImpulse solveSingleContact(const ContactProblem& problem, std::size_t i,
                                         ImpactLaw law) {
  return solveSingleContact(problem.contact(i), problem.relativeMotion(i), law);
}

/// Two free rigid bodies a and b (contact.body_a/body_b unused): the problem entry of the contact
/// alone (ContactProblem::rigidImpactContact()), solved as above. The bodies are not changed.
inline ContactImpulse solveSingleContact(const RigidBody& a, const RigidBody& b,
                                         const ContactPoint& contact, ImpactLaw law) {
  const ProblemContact entry = ContactProblem::rigidImpactContact(a, b, contact);
  return solveSingleContact(entry, entry.free_velocity, law);
}

}  // namespace collision_response::core
