#pragma once

#include <vector>

#include "collision_response/core/body_state.h"
#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/contact_row.h"
#include "collision_response/core/island_solver.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/solver_options.h"

namespace collision_response::core {

/// The force-based Coulomb model (docs/physics.md, "Resting contacts") for an island in which no
/// contact approaches: each contact with |u_n| <= options.resting_velocity is resting, and gets the
/// contact force F (+F on b, -F on a) that the bodies' external wrenches call for:
///   F_n >= 0, a'_n >= 0, F_n a'_n = 0 (a the relative acceleration at the point, including the
///   centripetal terms w x (w x r));
///   a contact without slip sticks (a'_t = 0) if that needs |F_t| <= mu_s F_n, otherwise it starts
///   to slide with |F_t| = mu_d F_n; a contact already slipping (|u_t| > resting velocity) gets
///   F_t = -mu_d F_n u_t / |u_t| (dynamic friction against the slip).
/// It is the plastic Newton problem of the impact solvers on accelerations instead of velocities:
/// one resting contact is solved in closed form, several by the iterative solver. Contacts that
/// separate (u_n > resting velocity) get nothing. Writes resting, normal_force, friction_force and
/// sticking of the island's resting contacts; bodies are not changed.
IslandStats solveRestingIsland(const std::vector<BodyState>& states,
                               const std::vector<RigidBody>& bodies,
                               const std::vector<ContactRow>& rows, const std::vector<int>& island,
                               const SolverOptions& options, std::vector<ContactImpulse>& impulses);

}  // namespace collision_response::core
