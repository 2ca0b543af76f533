#pragma once

#include <vector>

#include "collision_response/core/body_model.h"
#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/solve_report.h"
#include "collision_response/core/solver_options.h"
#include "collision_response/core/warning.h"

namespace collision_response::core {

/// The answer of computeBodyResponse(), per contact and per island.
struct BodyResponse {
  /// One per contact, in order: impulses (+total() on b), sticking, u_n before and after [m/s].
  std::vector<ContactImpulse> impulses;
  /// Effective mass of each contact along its normal, 1 / (n^T W_ii n) [kg]; infinity when no
  /// impulse along n moves the contact (both sides immovable along n).
  std::vector<double> effective_masses;
  /// How each island of coupled contacts was solved (SolveReport::contacts: indices into contacts).
  std::vector<SolveReport> islands;
  /// Contacts the answer leaves approaching (approach_warnings.h), in contact order.
  std::vector<Warning> warnings;
};

/// The impact response of general bodies (body_model.h: free rigid bodies, robots, any model with
/// velocity unknowns) at the given contacts (body indices into `bodies`, parts for multi-part
/// bodies): islands of contacts coupled through bodies with unknowns are built into contact
/// problems (ContactProblem::buildImpact()) and solved by solveIsland() under `options`; the
/// velocity changes are added to the bodies. An island without an approaching contact gets
/// no impulse; its resting contacts (|u_n| <= options.resting_velocity) get the contact forces of
/// the force-based Coulomb model (solveRestingIsland(), ContactProblem::buildResting()) from each
/// body's BodyModel::partPointFreeAcceleration(): a rigid body's after setFreeAcceleration(), a
/// robot's from its loads (ArticulatedBody::setLoads()). Throws
/// InvalidInput naming "contacts[i].<field>" for a body index out of range, a contact of a part
/// with itself (two parts of one body, such as two links of a robot, may touch: the contact's W
/// then has the cross terms of its two Jacobians), a normal that is not unit length (1e-6) or
/// coefficients out of range.
BodyResponse computeBodyResponse(const std::vector<BodyModel*>& bodies,
                                 const std::vector<ContactPoint>& contacts,
                                 const SolverOptions& options = {});

}  // namespace collision_response::core
