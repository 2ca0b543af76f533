#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace collision_response::core {

/// How an island (or one solver call) was solved: the report's answer, not the option that asks
/// for a solver (SolverMethod, solver_options.h). toString() gives the names of the response's
/// IslandReport.method.
enum class SolvedBy {
  kNone,                ///< "none": nothing approaching and nothing resting
  kClosedForm,          ///< "closed_form": one contact, Newton (or one-pass) closed form
  kImpulseSpace,        ///< "impulse_space": one contact, Poisson / Stronge integrated
  kSequential,          ///< "sequential": the one-pass law, contact by contact
  kExact,               ///< "exact": Lemke / all-sticking solve (exact_solver.h)
  kIterative,           ///< "iterative": projected Gauss-Seidel (iterative_solver.h)
  kExactThenIterative,  ///< "exact_then_iterative": automatic, the exact solver found nothing
  kTwoPhaseExact,       ///< "two_phase_exact": Poisson / Stronge, several contacts, exact phases
  kTwoPhaseIterative,   ///< "two_phase_iterative": the same with iterative phases
  kRestingClosedForm,   ///< "resting_closed_form": one resting contact, contact forces
  kRestingIterative,    ///< "resting_iterative": several resting contacts, contact forces
  /// "simultaneous_impulse_space": Poisson / Stronge, several contacts integrated together in
  /// impulse space (simultaneous_impact.h)
  kSimultaneousImpulseSpace,
};

/// The former name of SolvedBy (until 2026-11), kept for code written against it.
using SolveMethod [[deprecated("renamed SolvedBy: the report's method, not SolverMethod")]] =
    SolvedBy;

const char* toString(SolvedBy method);

/// Detail of an impulse-space integration (integrateSingleContact()).
struct ImpulseSpaceDetail {
  std::size_t steps = 0;     ///< Taylor steps of a turning slip (each one expansion)
  std::size_t segments = 0;  ///< pieces of constant contact mode (slip, stick, resumed slip)
  /// Sum of the steps' truncation estimates, relative to the impulse scale J (docs/physics.md).
  double error_estimate = 0.0;
  double compression_impulse = 0.0;  ///< p_c, the normal impulse at maximum compression [N s]
  double compression_work = 0.0;     ///< W_c = integral of u_n dp over [0, p_c] [J], <= 0
  /// Order of the power series that took the slip to its stop in closed form (stick_approach.h),
  /// 0 if the slip was not finished that way.
  std::size_t series_order = 0;
  /// The integration hit its segment or step budget (or a contact that cannot end compression):
  /// the rest of the impact was replaced by the perfectly plastic sticking impulse -K^+ u.
  bool fallback = false;
};

/// What one solve did, for every solver and for each island of computeResponse().
struct SolveReport {
  SolvedBy method = SolvedBy::kNone;
  /// The contacts solved: indices into the caller's contact list (Scene::contacts for
  /// computeResponse()).
  std::vector<int> contacts;
  /// Pivots (exact), sweeps (iterative), integration steps + segments (impulse space), contacts
  /// (closed forms), summed over the phases of a two-phase solve.
  std::size_t iterations = 0;
  /// The method's own measure of its error (0 for closed forms): exact, the largest
  /// complementarity violation relative to the largest pre-impact |u|; iterative, the largest
  /// impulse change of the last sweep relative to the largest impulse; impulse space, the summed
  /// local error estimates.
  double residual = 0.0;
  bool converged = true;
  /// Impulse-space integration only.
  std::optional<ImpulseSpaceDetail> impulse_space;

  /// toString(method), the response's IslandReport.method.
  std::string methodName() const { return toString(method); }
};

}  // namespace collision_response::core
