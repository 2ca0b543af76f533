// The package's predictions of a cube landing for the real-tosses benchmark (docs/benchmarks.md,
// "Real tosses"), per impact law:
//   - "one impact": free flight to the first contact, one core::computeResponse() at the corners
//     touching then, free flight after (the table no longer seen): what one service call offers;
//   - "repeated impacts": the same call at every following impact, the motion between followed in
//     the harness (flight in closed form, each corner's crossing of the table found by a scan and
//     bisection): the method the measurements used before core::computeEpisode();
//   - "episode": core::computeEpisode() with a cube-against-plane core::GapQuery.
// Each with mu_s = mu_d (parameters e, mu) or both (e, mu_d, mu_s - mu_d).
#pragma once

#include <memory>
#include <string>

#include "collision_response/core/solver_options.h"
#include "landing_model.h"

namespace collision_response::bench {

std::unique_ptr<LandingModel> makeOneImpactLanding(const TossedCube& cube, core::ImpactLaw law,
                                                   bool split_friction);
std::unique_ptr<LandingModel> makeRepeatedImpactsLanding(const TossedCube& cube,
                                                         core::ImpactLaw law, bool split_friction);
/// How the landings a model of this file simulated since the last call ended, e.g. "160
/// kSeparated, 5 kSustainedContact" for the episode (EpisodeEnd), the number of impacts for the
/// repeated impacts; "" for other models and for one impact.
std::string landingEnds(LandingModel& model);

/// The episode (core::computeEpisode()) under `law`.
std::unique_ptr<LandingModel> makeEpisodeLanding(const TossedCube& cube, core::ImpactLaw law,
                                                 bool split_friction);

}  // namespace collision_response::bench
