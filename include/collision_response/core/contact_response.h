#pragma once

#include <vector>

#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/solve_report.h"
#include "collision_response/core/warning.h"

namespace collision_response::core {

/// What every response request answers per contact and per island (solveIslands(), the one
/// pipeline): the part that computeResponse()'s CollisionResult (rigid bodies of a Scene) and
/// computeBodyResponse()'s BodyResponse (bodies behind BodyModel: robots, rigid bodies) share.
struct ContactResponse {
  /// One per contact, in the contacts' order: normal and friction impulse [N s] (+ on body_b),
  /// resting forces [N], sticking, the normal velocity before and after [m/s] (contact_impulse.h).
  std::vector<ContactImpulse> impulses;
  /// Effective mass of each contact along its normal, 1 / (n^T W_ii n) [kg]; infinity when no
  /// impulse along n moves the contact (both sides immovable along n: locked joints, a fixed base).
  std::vector<double> effective_masses;
  /// How each island of coupled contacts was solved: its contacts (SolveReport::contacts, indices
  /// into the contacts), the method (SolvedBy::kNone if nothing approaches and nothing rests,
  /// or nothing can move; resting islands kRestingClosedForm / kRestingIterative), iterations,
  /// residual, convergence.
  std::vector<SolveReport> islands;
  /// Valid input that is usually a mistake, answered as given (warning.h); always the contacts the
  /// answer leaves approaching (approach_warnings.h), after any the request's kind adds.
  std::vector<Warning> warnings;
};

}  // namespace collision_response::core
