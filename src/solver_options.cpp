#include "collision_response/solver_options.h"

namespace collision_response::core {

const char* toString(ImpactLaw law) {
  switch (law) {
    case ImpactLaw::kNewton:
      return "newton";
    case ImpactLaw::kSeedOnePass:
      return "seed_one_pass";
  }
  return "unknown";
}

const char* toString(SolverMethod method) {
  switch (method) {
    case SolverMethod::kAuto:
      return "auto";
    case SolverMethod::kIterative:
      return "iterative";
  }
  return "unknown";
}

bool fromString(const std::string& name, ImpactLaw& law) {
  for (const ImpactLaw candidate : {ImpactLaw::kNewton, ImpactLaw::kSeedOnePass}) {
    if (name == toString(candidate)) {
      law = candidate;
      return true;
    }
  }
  return false;
}

bool fromString(const std::string& name, SolverMethod& method) {
  for (const SolverMethod candidate : {SolverMethod::kAuto, SolverMethod::kIterative}) {
    if (name == toString(candidate)) {
      method = candidate;
      return true;
    }
  }
  return false;
}

}  // namespace collision_response::core
