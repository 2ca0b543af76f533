#pragma once

#include <functional>
#include <vector>

#include "collision_response/core/body_model.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/contact_response.h"
#include "collision_response/core/solver_options.h"

namespace collision_response::core {

/// The one island pipeline behind every response request (computeResponse() for a Scene of rigid
/// bodies, computeBodyResponse() for robots and rigid bodies behind BodyModel): the contacts
/// (validated: validateContactPoints() or a SceneValidator) are split into islands coupled through
/// bodies with velocity unknowns (findIslands()); per island one contact problem
/// (ContactProblem::buildImpact(), the effective masses from its W_ii) solved by solveIsland()
/// under `options` when some contact approaches, the velocity changes added to the bodies;
/// otherwise the resting problem (ContactProblem::buildResting()) solved by solveRestingIsland()
/// from the bodies' BodyModel::partPointFreeAcceleration(); an island whose bodies have no
/// unknowns gets nothing. Free rigid bodies take the problem's closed-form path (asRigidBody()).
///
/// Fills result.impulses (u_n before and after, impulses or resting forces), effective_masses and
/// islands, and appends the approach warnings (warnApproachingContacts()) to result.warnings.
/// options.time_budget starts counting here. `prepare_resting`, if set, is called once before the
/// first resting problem is built (a caller whose bodies learn their free accelerations only then,
/// such as the Scene's rigid bodies from their wrenches). The problem and answer storage is reused
/// per thread.
void solveIslands(const std::vector<BodyModel*>& bodies, const std::vector<ContactPoint>& contacts,
                  const SolverOptions& options, ContactResponse& result,
                  const std::function<void()>& prepare_resting = {});

}  // namespace collision_response::core
