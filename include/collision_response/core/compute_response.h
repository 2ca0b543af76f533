#pragma once

#include <string>
#include <vector>

#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/scene.h"
#include "collision_response/core/solve_report.h"
#include "collision_response/core/solver_options.h"
#include "collision_response/core/warning.h"

namespace collision_response::core {

struct CollisionResult {
  std::vector<BodyState> bodies;         ///< post-impact states, same order as Scene::bodies
  std::vector<ContactImpulse> impulses;  ///< one per contact, same order as Scene::contacts
  double kinetic_energy_before = 0.0;    ///< of the movable bodies [J]
  double kinetic_energy_after = 0.0;     ///< [J]
  /// How each island was solved: its contacts (indices into Scene::contacts), the method
  /// (SolveMethod::kNone if nothing approaches and nothing rests; resting islands
  /// kRestingClosedForm / kRestingIterative), iterations, residual, convergence.
  std::vector<SolveReport> islands;
  /// Valid input that is usually a mistake, answered as given (see warning.h): a movable-looking
  /// body with mass 0 (a velocity or an inertia tensor but no mass: it is treated as immovable),
  /// and a contact separating faster than options.resting_velocity that gets no impulse (a normal
  /// that points from b to a leaves approaching bodies untouched), then every contact the answer
  /// leaves approaching faster than options.resting_velocity (approach_warnings.h).
  std::vector<Warning> warnings;
};

/// Validates the scene (throws InvalidInput naming the field) and computes the post-impact states.
/// Islands of coupled contacts are solved separately (solveIsland() says how); an island with no
/// approaching contact gets no impulse, and its resting contacts get the forces of the
/// force-based Coulomb model (solveRestingIsland()); one without either costs nothing.
CollisionResult computeResponse(const Scene& scene, const SolverOptions& options = {},
                                const RequestLimits& limits = {});

/// computeResponse() for a scene already validated (validate(), or a SceneValidator that checked
/// every contact): contact_bodies is its result. Nothing is validated again; the caller answers
/// for the scene being the one that was checked.
CollisionResult computeValidatedResponse(const Scene& scene,
                                         const std::vector<std::pair<int, int>>& contact_bodies,
                                         const SolverOptions& options = {});

}  // namespace collision_response::core
