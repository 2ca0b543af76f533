#pragma once

#include <cstddef>

#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/contact_row.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/solver_options.h"

namespace collision_response::core {

/// Work done by one call of integrateSingleContact().
struct IntegrationStats {
  std::size_t steps = 0;     ///< Runge-Kutta steps attempted (accepted and rejected)
  std::size_t segments = 0;  ///< pieces of constant contact mode (slip, stick, resumed slip)
  /// Sum of the accepted local error estimates, relative to the impulse scale |u| / (n^T K n).
  double error_estimate = 0.0;
  double compression_impulse = 0.0;  ///< p_c, the normal impulse at maximum compression [N s]
  double compression_work = 0.0;     ///< W_c = integral of u_n dp over [0, p_c] [J], <= 0
  /// The integration hit its segment or step budget (or a contact that cannot end compression):
  /// the rest of the impact was replaced by the perfectly plastic sticking impulse -K^-1 u.
  bool fallback = false;
};

/// Impulse for one isolated contact under the Poisson or Stronge restitution law with Coulomb
/// friction, integrated along the impact in impulse space (Routh's method, docs/physics.md,
/// "Frictional impact in impulse space"). Same output contract as solveSingleContact(): total
/// impulse P = normal_impulse n + friction_impulse, +P on b and -P on a; u_n' = u_n + n^T K P; a
/// separating or resting contact (u_n >= 0) gets zero impulse; the bodies are not changed. Laws
/// other than kPoisson and kStronge are forwarded to solveSingleContact().
///
/// The normal impulse p = P_n is the time-like variable, u(p) the relative contact velocity,
/// s = u_t / |u_t| the slip direction:
///   sliding:  dP/dp = n - mu_d s, du/dp = K (n - mu_d s);
///   sticking (u_t = 0, allowed while |K_tt^-1 K_tn| <= mu_s): dP_t/dp = -K_tt^-1 K_tn;
///   compression ends at u_n(p_c) = 0 with work W_c = integral_0^p_c u_n dp (< 0);
///   Poisson ends at p = (1 + e) p_c, Stronge when integral_p_c^p u_n dp = -e^2 W_c.
/// Segments with a constant slip direction (planar and central impacts, sticking, slip resumed
/// after a stop) are solved in closed form; a rotating 3D slip direction is integrated with an
/// adaptive Dormand-Prince 5(4) method to `tolerance` (local error relative to the impulse scale).
/// Under kStronge the kinetic energy never increases and the contact separates (u_n' >= 0).
ContactImpulse integrateSingleContact(const RigidBody& a, const RigidBody& b, const ContactRow& row,
                                      ImpactLaw law, double tolerance,
                                      IntegrationStats* stats = nullptr);

}  // namespace collision_response::core
