#include "collision_response/core/solver_options.h"

namespace collision_response::core {

const char* toString(ImpactLaw law) {
  switch (law) {
    case ImpactLaw::kNewton:
      return "newton";
    case ImpactLaw::kSeedOnePass:
      return "seed_one_pass";
    case ImpactLaw::kPoisson:
      return "poisson";
    case ImpactLaw::kStronge:
      return "stronge";
  }
  return "unknown";
}

const char* toString(SolverMethod method) {
  switch (method) {
    case SolverMethod::kAuto:
      return "auto";
    case SolverMethod::kIterative:
      return "iterative";
    case SolverMethod::kExact:
      return "exact";
  }
  return "unknown";
}

bool fromString(const std::string& name, ImpactLaw& law) {
  for (const ImpactLaw candidate :
       {ImpactLaw::kNewton, ImpactLaw::kSeedOnePass, ImpactLaw::kPoisson, ImpactLaw::kStronge}) {
    if (name == toString(candidate)) {
      law = candidate;
      return true;
    }
  }
  return false;
}

bool fromString(const std::string& name, SolverMethod& method) {
  for (const SolverMethod candidate :
       {SolverMethod::kAuto, SolverMethod::kIterative, SolverMethod::kExact}) {
    if (name == toString(candidate)) {
      method = candidate;
      return true;
    }
  }
  return false;
}

}  // namespace collision_response::core
