// The peer engines of the real-tosses benchmark that this build has (CMake target landing_peers;
// each engine is optional: HAVE_LANDING_BULLET, HAVE_LANDING_ODE, HAVE_LANDING_MUJOCO say which
// are in, and are set on whatever links landing_peers).
#pragma once

#include <memory>
#include <vector>

#include "landing_model.h"

namespace collision_response::bench {

/// One model per available engine (Bullet, ODE, MuJoCo, in this order), each stepping at `step`
/// [s] (in (0, 0.01]; 1e-3 is the benchmark's).
std::vector<std::unique_ptr<LandingModel>> makeLandingPeers(double step = 1e-3);

}  // namespace collision_response::bench
