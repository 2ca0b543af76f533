#pragma once

#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/contact_row.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/solver_options.h"

namespace collision_response::core {

/// Closed-form impulse for one isolated contact between bodies a and b under the given law. The
/// bodies are not changed: apply the result with row.space.applyImpulse(a, b, impulse.total(n)).
/// A separating or resting contact (u_n >= 0) gets a zero impulse.
///
/// Newton law, in contact space (u the pre-impact relative velocity, u_n = u.n, u_t = u - u_n n):
///   stick:  P = K^-1 (-(1 + e) u_n n - u_t), accepted if P.n >= 0 and |P_t| <= mu_s P.n;
///   slide:  P = P_n (n + mu_d d), d the unit tangential direction of the sticking impulse, and
///           P_n = -(1 + e) u_n / (n^T K (n + mu_d d)) so that u'_n = -e u_n still holds.
/// If that denominator is not positive (friction would drive the contact deeper: a Painleve-like
/// configuration), the sticking impulse is returned, flagged sticking, outside the cone.
/// Frictionless contacts take the frictionless impulse formula (docs/physics.md, "The frictionless
/// impulse formula") directly: P = -(1 + e) u_n / (n^T K n) n.
ContactImpulse solveSingleContact(const RigidBody& a, const RigidBody& b, const ContactRow& row,
                                  ImpactLaw law);

}  // namespace collision_response::core
