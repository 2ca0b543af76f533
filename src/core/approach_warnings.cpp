#include "collision_response/core/approach_warnings.h"

#include <cmath>
#include <cstdio>
#include <string>

namespace collision_response::core {
namespace {

// Why contact c may be left approaching, as far as the answer tells.
std::string cause(std::size_t c, const std::vector<double>& effective_masses,
                  const std::vector<SolveReport>& islands, const SolverOptions& options) {
  if (c < effective_masses.size() && std::isinf(effective_masses[c])) {
    return "no impulse along the normal can move it (both sides immovable along the normal: "
           "mass 0, a fixed base or locked joints)";
  }
  for (const SolveReport& island : islands) {
    for (const int contact : island.contacts) {
      if (contact != static_cast<int>(c)) continue;
      if (!island.converged) return "the " + island.methodName() + " solve did not converge";
      if (island.method == SolvedBy::kSequential || options.law == ImpactLaw::kSeedOnePass) {
        return "the seed_one_pass law resolves its contacts one at a time, and a later "
               "contact's impulse can make an earlier one approach again";
      }
      return "solved by " + island.methodName();
    }
  }
  return "no island solved it";
}

}  // namespace

void warnApproachingContacts(const std::vector<ContactImpulse>& impulses,
                             const std::vector<double>& effective_masses,
                             const std::vector<SolveReport>& islands, const SolverOptions& options,
                             std::vector<Warning>& warnings) {
  for (std::size_t c = 0; c < impulses.size(); ++c) {
    const double after = impulses[c].normal_velocity_after;
    if (!(after < -options.resting_velocity)) continue;
    char speeds[96];
    std::snprintf(speeds, sizeof speeds,
                  "still approaching at %.3g m/s after the answer (%.3g m/s before)", after,
                  impulses[c].normal_velocity_before);
    warnings.push_back({"contacts[" + std::to_string(c) + "]",
                        std::string(speeds) + ": " + cause(c, effective_masses, islands, options),
                        Warning::Kind::kLeftApproaching});
  }
}

}  // namespace collision_response::core
