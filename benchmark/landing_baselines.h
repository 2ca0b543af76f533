// The baselines of the real-tosses benchmark (docs/benchmarks.md, "Real tosses"): models that
// change the cube's velocities at its first contact by a fixed rule, with free flight before and
// after (cube_flight.h). None sees the table after the first contact.
#pragma once

#include <memory>

#include "landing_model.h"

namespace collision_response::bench {

/// "no change": the landing changes nothing; the cube flies on ballistically (through the table),
/// so its velocities at any time are those of the pre-impact flight. No parameters.
std::unique_ptr<LandingModel> makeNoChangeLanding(const TossedCube& cube);

/// "bounce rule": at the first contact v' = (vx, vy, -e vz), w' = w. Parameter: e in [0, 1].
std::unique_ptr<LandingModel> makeBounceRuleLanding(const TossedCube& cube);

/// "3-factor scaling": at the first contact v' = (a_t vx, a_t vy, -a_n vz), w' = a_w w.
/// Parameters: a_n in [0, 1], a_t in [-1, 1], a_w in [-2, 3] (landings spin the cube up).
std::unique_ptr<LandingModel> makeScalingLanding(const TossedCube& cube);

}  // namespace collision_response::bench
