// Simbody (libsimbody-dev) as a peer: the same contacts as unilateral point-on-plane contacts,
// resolved by one step of its SemiExplicitEulerTimeStepper with the PLUS or PGS impulse solver.
#pragma once

#include "peer_run.h"

namespace collision_response::bench {

enum class SimbodySolver {
  kPlus,  ///< PLUSImpulseSolver: Newton iterations on sliding intervals whose slip direction
          ///< turns at most 30 degrees each
  kPgs,   ///< PGSImpulseSolver: projected Gauss-Seidel (SOR 1.2)
};

enum class SimbodyRestitution {
  kPoisson,  ///< compression impulse, then e times it applied as a known expansion impulse
  kNewton,   ///< target u'_n = -e u_n in one solve
};

struct SimbodyConfig {
  SimbodySolver solver = SimbodySolver::kPlus;
  SimbodyRestitution restitution = SimbodyRestitution::kPoisson;
  /// ImpulseSolver::setMaxIterations: PLUS's Newton iterations per sliding interval (its default
  /// 20), PGS's sweeps (its default 100). 0: the solver's default.
  int iterations = 0;
  /// ImpulseSolver::setConvergenceTol (PLUS default 1e-10, PGS 1e-6); negative: the default, 0: run
  /// every iteration asked for.
  double tolerance = -1.0;
  /// SemiExplicitEulerTimeStepper::setConstraintTolerance [m, m/s] (Simbody's default 1e-3): the
  /// proximity of a contact, the normal speed below which it is not impacting, and twice it the
  /// capture speed (no restitution below it) and the slip speed below which PLUS takes a contact
  /// as rolling.
  double constraint_tolerance = 1e-10;
  /// [s] wall time allowed for the whole run (all repetitions), in a child process; beyond it the
  /// run is abandoned (PLUS can take ever shorter sliding intervals without end).
  double time_limit = 10.0;
};

/// Builds a MultibodySystem without forces (no gravity): a MobilizedBody::Free per movable body
/// (body frame at its centre of mass, our mass, inertia, pose and velocity), immovable bodies
/// welded to Ground (they must be at rest), and one unilateral contact per contact: a
/// PointPlaneContact (PointPlaneFrictionlessContact if mu_s = mu_d = 0) with the plane on body a
/// through our point with our normal, the follower point on body b, COR e, mu_s, mu_d, no viscous
/// friction. Then one SemiExplicitEulerTimeStepper step of 1e-12 s (simultaneous impact, no
/// position projection, the configuration's constraint tolerance; capture, minimum-COR and
/// rolling speeds twice that tolerance; mu_s only at zero slip), timed alone, `repetitions` times
/// from the same state (stepper re-initialised before each, untimed), in a child process with a
/// time limit (runIsolated). Simbody picks mu_s or mu_d once from the slip before the impact. It
/// does not report the impulses (they stay inside the stepper): `impulses` is left empty.
/// Debian's build traces every step on standard output (it is built without NDEBUG): standard
/// output goes to /dev/null meanwhile, and the times include writing that trace. A scene Simbody
/// rejects (an inertia violating the triangle inequality, an immovable body in motion) or a run
/// past the time limit returns no velocities and the reason in `note`.
PeerRun runSimbody(const core::Scene& scene, const SimbodyConfig& config, int repetitions);

}  // namespace collision_response::bench
