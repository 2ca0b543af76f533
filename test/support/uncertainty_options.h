// Options and error probes shared by the core uncertainty tests (test_uncertainty,
// test_geometry_uncertainty).
#pragma once

#include <cstddef>
#include <functional>
#include <string>

#include "collision_response/core/errors.h"
#include "collision_response/core/solver_options.h"
#include "collision_response/core/uncertainty.h"

namespace collision_response::testing {

/// Newton's law, the rest default.
inline core::SolverOptions newton() {
  core::SolverOptions options;
  options.law = core::ImpactLaw::kNewton;
  return options;
}

/// The sampled method with `samples` solves.
inline core::UncertaintyOptions sampled(std::size_t samples) {
  core::UncertaintyOptions options;
  options.method = core::UncertaintyMethod::kSampled;
  options.samples = samples;
  return options;
}

/// The linear method.
inline core::UncertaintyOptions linear() {
  core::UncertaintyOptions options;
  options.method = core::UncertaintyMethod::kLinear;
  return options;
}

/// The field an InvalidInput thrown by `call` names, "(no error)" if it throws none.
inline std::string errorField(const std::function<void()>& call) {
  try {
    call();
  } catch (const core::InvalidInput& e) {
    return e.field();
  }
  return "(no error)";
}

}  // namespace collision_response::testing
