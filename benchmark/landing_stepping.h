// How a peer engine steps a cube landing (landing_bullet, landing_ode, landing_mujoco): the split
// of the asked duration into fixed steps, and the checks of simulate()'s inputs.
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "landing_model.h"

namespace collision_response::bench {

/// `full` steps of the engine's fixed step, then one step of `rest` [s] (0: none), so that the
/// engine ends exactly at the asked time (the harness asks for camera frame times, 1/148 s apart,
/// which are no multiple of 1 ms).
struct StepPlan {
  long full = 0;
  double rest = 0.0;  ///< [s], in [0, step)
};

inline StepPlan planSteps(double duration, double step) {
  if (!std::isfinite(duration) || duration < 0.0)
    throw std::invalid_argument("duration: must be finite and >= 0 [s], got " +
                                std::to_string(duration));
  StepPlan plan;
  plan.full = static_cast<long>(std::floor(duration / step));
  plan.rest = duration - static_cast<double>(plan.full) * step;
  if (plan.rest >= step * (1.0 - 1e-9)) {  // duration an exact multiple, floor rounded down
    ++plan.full;
    plan.rest = 0.0;
  }
  if (plan.rest < step * 1e-9) plan.rest = 0.0;  // rounding noise, not a step
  return plan;
}

/// The engine's fixed step [s], checked (constructor argument of every peer).
inline double checkedStep(double step) {
  if (!std::isfinite(step) || step <= 0.0 || step > 0.01)
    throw std::invalid_argument("step: must be in (0, 0.01] s, got " + std::to_string(step));
  return step;
}

/// Throws std::invalid_argument naming the field if `values` does not match `parameters` in count,
/// or a value is not finite or below `minimum` (the parameters' physical domain, not the fit's
/// search box: the harness may step outside the box, never into nonsense), or the state is not
/// finite.
inline void checkInputs(const std::string& model, const std::vector<LandingParameter>& parameters,
                        const std::vector<double>& values, const std::vector<double>& minimum,
                        const CubeState& before) {
  if (values.size() != parameters.size())
    throw std::invalid_argument(model + ": values: expected " + std::to_string(parameters.size()) +
                                " (one per parameter), got " + std::to_string(values.size()));
  for (std::size_t i = 0; i < values.size(); ++i)
    if (!std::isfinite(values[i]) || values[i] < minimum[i])
      throw std::invalid_argument(model + ": " + parameters[i].name +
                                  ": must be finite and >= " + std::to_string(minimum[i]) +
                                  ", got " + std::to_string(values[i]));
  if (!before.position.allFinite() || !before.orientation.coeffs().allFinite() ||
      !before.linear_velocity.allFinite() || !before.angular_velocity.allFinite())
    throw std::invalid_argument(model + ": before: state not finite");
  if (std::abs(before.orientation.norm() - 1.0) > 1e-6)
    throw std::invalid_argument(model + ": before.orientation: not a unit quaternion");
}

}  // namespace collision_response::bench
