#pragma once

#include <string>
#include <vector>

#include "collision_response/core/contact_response.h"
#include "collision_response/core/scene.h"
#include "collision_response/core/solver_options.h"

namespace collision_response::core {

struct ContactPoint;
class BodyModel;
struct RigidBody;

/// The answer of computeResponse(): the per-contact and per-island answer every request shares
/// (contact_response.h: impulses in Scene::contacts order, effective masses, islands with
/// SolveReport::contacts indexing Scene::contacts, warnings) and the bodies' states.
/// Warnings here: a movable-looking body with mass 0 (a velocity or an inertia tensor but no
/// mass: it is treated as immovable), a contact separating faster than options.resting_velocity
/// that gets no impulse (a normal that points from b to a leaves approaching bodies untouched),
/// then every contact the answer leaves approaching faster than options.resting_velocity.
struct CollisionResult : ContactResponse {
  std::vector<BodyState> bodies;       ///< post-impact states, same order as Scene::bodies
  double kinetic_energy_before = 0.0;  ///< of the movable bodies [J]
  double kinetic_energy_after = 0.0;   ///< [J]
};

/// Validates the scene (throws InvalidInput naming the field) and computes the post-impact states
/// through the one island pipeline (solveIslands(), solve_islands.h): islands of coupled contacts
/// are solved separately (solveIsland() says how); an island with no approaching contact gets no
/// impulse, and its resting contacts get the forces of the force-based Coulomb model
/// (solveRestingIsland(), from the bodies' wrenches); one without either costs nothing.
CollisionResult computeResponse(const Scene& scene, const SolverOptions& options = {},
                                const RequestLimits& limits = {});

/// computeResponse() for a scene already validated (validate(), or a SceneValidator that checked
/// every contact): contact_bodies is its result. Nothing is validated again; the caller answers
/// for the scene being the one that was checked.
CollisionResult computeValidatedResponse(const Scene& scene,
                                         const std::vector<std::pair<int, int>>& contact_bodies,
                                         const SolverOptions& options = {});

/// The island pipeline on free rigid bodies: `bodies` made from `states` (makeRigidBodies()),
/// `models` pointing at them, `points` solved (solveIslands(), the resting contacts reading each
/// body's free acceleration under its wrench); the velocities after the impact in `bodies`, the
/// impulses, reports and warnings in `response`. `bodies` and `models` are the caller's storage
/// (kept per thread by computeValidatedResponse() and by an episode).
void solveRigidIslands(const std::vector<BodyState>& states,
                       const std::vector<ContactPoint>& points, const SolverOptions& options,
                       std::vector<RigidBody>& bodies, std::vector<BodyModel*>& models,
                       ContactResponse& response);

/// Appends to `warnings` one kInput warning per body of a request that is valid but usually a
/// mistake: an immovable body (mass 0) given an inertia tensor or a velocity (field
/// "bodies[i].inertia"). computeResponse() places them before its other warnings; an episode names
/// them with its first impact.
void addBodyWarnings(const std::vector<BodyState>& bodies, std::vector<Warning>& warnings);

/// The solvers' contacts of a validated scene (contact_bodies from validate()): one per
/// Scene::contacts entry, same order, the normal normalised; `points` is cleared first (its
/// capacity is kept, for per-thread storage).
void makeContactPoints(const Scene& scene, const std::vector<std::pair<int, int>>& contact_bodies,
                       std::vector<ContactPoint>& points);

}  // namespace collision_response::core
