#pragma once

#include <collision_response/ContactUncertainty.h>
#include <collision_response/OutcomeDistribution.h>
#include <collision_response/SolverOptions.h>

#include <vector>

#include "collision_response/core/uncertainty.h"

namespace collision_response {

/// The request's `uncertainties` (ContactUncertainty.msg) for computeOutcomeDistribution().
/// Throws core::InvalidInput naming "uncertainties[k].<coefficient>.type" for an unknown type.
std::vector<core::ContactUncertainty> fromMsg(const std::vector<ContactUncertainty>& msgs);

/// options.uncertainty and options.uncertainty_samples (0: the core's default). Throws
/// core::InvalidInput naming "options.uncertainty" for an unknown method.
core::UncertaintyOptions uncertaintyOptions(const SolverOptions& msg);

OutcomeDistribution toMsg(const core::OutcomeDistribution& outcome);

}  // namespace collision_response
