#pragma once

#include <collision_response/ContactUncertainty.h>
#include <collision_response/OutcomeDistribution.h>

#include <vector>

#include "collision_response/core/contact_point.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/solver_options.h"
#include "collision_response/core/uncertainty.h"
#include "collision_response/core/warning.h"
#include "collision_response/core/worker_pool.h"
#include "collision_response/ros/request_assembly.h"

namespace collision_response {

/// The outcome distribution of a request with robots (docs/uncertainty.md, "Robots"): the
/// request's `uncertainties` through core::computeBodyOutcomeDistribution() on copies of the body
/// models (`rigid` and the placed `robots`, at their pre-impact state and left as they are):
/// sampled, one copy per thread of `pool` (nullptr: one copy, on the calling thread; robot copies
/// share the robot's model and own their state); linear, one copy, differentiated once. Labels: the
/// rigid bodies' twists, each robot's unknowns (velocityLabels()), the impulses; joint_limit_labels
/// / joint_limit_probability: every robot joint with a finite URDF velocity limit. The core's
/// warnings are appended to `warnings`. Throws what computeBodyOutcomeDistribution() throws.
OutcomeDistribution robotOutcomeDistribution(
    const std::vector<ContactUncertainty>& uncertainties, const std::vector<core::RigidBody>& rigid,
    const std::vector<RequestRobot>& robots, const std::vector<core::ContactPoint>& points,
    const core::SolverOptions& options, const core::UncertaintyOptions& uncertainty,
    core::WorkerPool* pool, std::vector<core::Warning>& warnings);

}  // namespace collision_response
