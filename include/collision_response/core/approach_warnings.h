#pragma once

#include <vector>

#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/solve_report.h"
#include "collision_response/core/solver_options.h"
#include "collision_response/core/warning.h"

namespace collision_response::core {

/// Appends a Warning (kind kLeftApproaching, field "contacts[i]") for every contact that the answer
/// leaves approaching: ContactImpulse::normal_velocity_after below -options.resting_velocity [m/s]
/// (faster than the speed the caller counts as at rest). The bodies would interpenetrate there;
/// the answer is still the one the law and solver give. The reason says by how much and, where it
/// can tell, why: no impulse along the normal can move the contact (effective_masses[i] infinite:
/// immovable bodies, locked joints, a fixed base), the one-pass law (contact by contact by
/// design), or an island the solver did not converge on. `effective_masses` may be empty (not
/// known); `islands`: the answer's reports (SolveReport::contacts index the contacts).
void warnApproachingContacts(const std::vector<ContactImpulse>& impulses,
                             const std::vector<double>& effective_masses,
                             const std::vector<SolveReport>& islands, const SolverOptions& options,
                             std::vector<Warning>& warnings);

}  // namespace collision_response::core
