// ODE (libode-dev, double precision) as a peer: the same contacts as contact joints.
#pragma once

#include "peer_run.h"

namespace collision_response::bench {

enum class OdeStepper {
  kStep,       ///< dWorldStep: Dantzig LCP
  kQuickStep,  ///< dWorldQuickStep: projected Gauss-Seidel (SOR, ODE's default w = 1.3)
};

struct OdeConfig {
  OdeStepper stepper = OdeStepper::kStep;
  int iterations = 20;  ///< dWorldSetQuickStepNumIterations (QuickStep only)
};

/// Builds an ODE world (zero gravity, ERP 0, CFM 0, gyroscopic term off, no auto-disable) with
/// the scene's bodies and one contact joint per contact (depth 0, our point and normal,
/// dContactBounce with bounce_vel 0, dContactApprox1 so friction is mu_d x the normal impulse on
/// two directions: ODE has a single coefficient), then times the step alone, `repetitions` times
/// from the same state (joints re-created before each step, untimed).
PeerRun runOde(const core::Scene& scene, const OdeConfig& config, int repetitions);

}  // namespace collision_response::bench
