#pragma once

#include <vector>

#include "collision_response/core/body_model.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/contact_response.h"
#include "collision_response/core/solver_options.h"

namespace collision_response::core {

/// The answer of computeBodyResponse(): the per-contact and per-island answer every request shares
/// (contact_response.h: impulses, effective masses, islands, warnings; indices into `contacts`).
/// Warnings here: the contacts the answer leaves approaching (approach_warnings.h), in contact
/// order.
struct BodyResponse : ContactResponse {};

/// The impact response of general bodies (body_model.h: free rigid bodies, robots, any model with
/// velocity unknowns) at the given contacts (body indices into `bodies`, parts for multi-part
/// bodies), through the one island pipeline (solveIslands(), solve_islands.h): islands of
/// contacts coupled through bodies with unknowns are built into contact problems
/// (ContactProblem::buildImpact()) and solved by solveIsland() under `options`; the velocity
/// changes are added to the bodies. An island without an approaching contact gets
/// no impulse; its resting contacts (|u_n| <= options.resting_velocity) get the contact forces of
/// the force-based Coulomb model (solveRestingIsland(), ContactProblem::buildResting()) from each
/// body's BodyModel::partPointFreeAcceleration(): a rigid body's after setFreeAcceleration(), a
/// robot's from its loads (ArticulatedBody::setLoads()). Throws
/// InvalidInput naming "contacts[i].<field>" for a body index out of range, a contact of a part
/// with itself (two parts of one body, such as two links of a robot, may touch: the contact's W
/// then has the cross terms of its two Jacobians), a point or normal that is not finite, a normal
/// that is zero or not of unit length within kUnitTolerance (validation.h; within it the normal
/// is normalised, as a Scene's is) or coefficients out of range (validateContactPoints()).
BodyResponse computeBodyResponse(const std::vector<BodyModel*>& bodies,
                                 const std::vector<ContactPoint>& contacts,
                                 const SolverOptions& options = {});

}  // namespace collision_response::core
