#include "collision_response/core/solve_report.h"

namespace collision_response::core {

const char* toString(SolveMethod method) {
  switch (method) {
    case SolveMethod::kNone:
      return "none";
    case SolveMethod::kClosedForm:
      return "closed_form";
    case SolveMethod::kImpulseSpace:
      return "impulse_space";
    case SolveMethod::kSequential:
      return "sequential";
    case SolveMethod::kExact:
      return "exact";
    case SolveMethod::kIterative:
      return "iterative";
    case SolveMethod::kExactThenIterative:
      return "exact_then_iterative";
    case SolveMethod::kTwoPhaseExact:
      return "two_phase_exact";
    case SolveMethod::kTwoPhaseIterative:
      return "two_phase_iterative";
    case SolveMethod::kRestingClosedForm:
      return "resting_closed_form";
    case SolveMethod::kRestingIterative:
      return "resting_iterative";
    case SolveMethod::kSimultaneousImpulseSpace:
      return "simultaneous_impulse_space";
  }
  return "unknown";
}

}  // namespace collision_response::core
