#pragma once

#include <vector>

#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/contact_row.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/solver_options.h"

namespace collision_response::core {

struct IterativeStats {
  std::size_t iterations = 0;
  double residual = 0.0;  ///< largest impulse change of the last iteration / largest impulse
  bool converged = false;
};

/// Newton law for simultaneous contacts by projected Gauss-Seidel on accumulated impulses
/// (sequential impulses), over the rows listed in `island`. At convergence each contact's
/// accumulated impulse P satisfies: P_n >= 0, u'_n >= -e u_n, P_n (u'_n + e u_n) = 0, and Coulomb
/// friction: sticking (u'_t = 0) where that needs |P_t| <= mu_s P_n, otherwise sliding with
/// |P_t| = mu_d P_n (the tangential impulse projected radially onto the cone). Static and dynamic:
/// sweeps run on the static cones to convergence; contacts that slide on theirs then move to the
/// dynamic cone and the sweeps continue, until no contact moves (the exact solver's rule).
/// Applies the impulses to `bodies` and writes the impulse of each listed row into `impulses`.
/// If the sweeps diverge (an accumulated impulse overflows: no solution exists), nothing is
/// applied, the impulses are zero (friction only: no friction, the fixed normal impulses) and the
/// result is not converged.
///
/// Friction only: with `fixed_normal_impulses` (one per listed row, >= 0, already applied to the
/// bodies) the normal rows are not solved; each row's friction is bounded by mu times its fixed
/// normal impulse, and the sweeps find the tangential impulses alone (the restitution phase of the
/// two-phase scheme). At convergence that is the least kinetic energy over the cones, never more
/// than without friction. Reported normal impulses are the fixed ones.
IterativeStats solveIterative(std::vector<RigidBody>& bodies, const std::vector<ContactRow>& rows,
                              const std::vector<int>& island, const SolverOptions& options,
                              std::vector<ContactImpulse>& impulses,
                              const std::vector<double>* fixed_normal_impulses = nullptr);

}  // namespace collision_response::core
