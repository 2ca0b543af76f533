#include "collision_response/core/solve_report.h"

namespace collision_response::core {

const char* toString(SolvedBy method) {
  switch (method) {
    case SolvedBy::kNone:
      return "none";
    case SolvedBy::kClosedForm:
      return "closed_form";
    case SolvedBy::kImpulseSpace:
      return "impulse_space";
    case SolvedBy::kSequential:
      return "sequential";
    case SolvedBy::kExact:
      return "exact";
    case SolvedBy::kIterative:
      return "iterative";
    case SolvedBy::kExactThenIterative:
      return "exact_then_iterative";
    case SolvedBy::kTwoPhaseExact:
      return "two_phase_exact";
    case SolvedBy::kTwoPhaseIterative:
      return "two_phase_iterative";
    case SolvedBy::kRestingClosedForm:
      return "resting_closed_form";
    case SolvedBy::kRestingIterative:
      return "resting_iterative";
    case SolvedBy::kSimultaneousImpulseSpace:
      return "simultaneous_impulse_space";
  }
  return "unknown";
}

}  // namespace collision_response::core
