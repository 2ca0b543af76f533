#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "collision_response/core/body_state.h"
#include "collision_response/core/contact.h"
#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/gap_query.h"
#include "collision_response/core/solver_options.h"
#include "collision_response/core/warning.h"

namespace collision_response::core {

/// What an episode follows and when it stops (docs/physics.md, "Impact episodes").
struct EpisodeOptions {
  /// Uniform gravity, world [m/s^2]; finite. Free flight is ballistic under it; resting contacts
  /// are analysed under the bodies' weights m g (plus their own force / torque).
  Eigen::Vector3d gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  /// Longest time followed [s], > 0: an episode with a pair still touching at t = horizon ends
  /// there (EpisodeEnd::kHorizon); separated bodies that will not touch again before it end the
  /// episode at once (kSeparated), as do bodies that fly apart over the last step and touch
  /// nothing at the horizon (kSeparated at the horizon).
  double horizon = 1.0;
  /// Most impacts followed, >= 1; the next one ends the episode (EpisodeEnd::kImpactCap).
  int max_impacts = 100;
  /// Contact tolerance [m], in (0, 1] (option_ranges::kContactTolerance, as detection's): a pair
  /// whose gap is at most this is touching. The contacts of
  /// one impact are all those touching at its time (a near-flat face lands on all its corners at
  /// once, whatever their order within the tolerance); the first time of contact is found to
  /// within it (the gap of the first contact is in [0, contact_tolerance] at the impact when its
  /// pair comes from apart; a pair already touching, e.g. pivoting on one corner, may let another
  /// of its points reach -contact_tolerance before it is seen). Rebounds lower than it are not
  /// followed as flights: sqrt(2 g_n contact_tolerance) is the resting threshold of a contact
  /// (docs/physics.md, "Impact episodes").
  double contact_tolerance = 1e-4;
  /// The impact law, solver, resting velocity and the time budget of the whole episode [s]
  /// (options.time_budget; past it, the episode ends with kTimeBudget and its state then).
  SolverOptions solver;
};

/// One impact of an episode.
struct EpisodeImpact {
  double time = 0.0;  ///< from the start of the episode [s]
  /// The contacts of the impact (every touching contact of every pair, world frame; body ids as
  /// in the bodies given) and their impulses, in the same order. A touch approaching slower than
  /// its resting threshold is solved plastic: its contacts are listed with restitution 0.
  std::vector<Contact> contacts;
  std::vector<ContactImpulse> impulses;
  /// Every body's state right after the impact (poses at `time`; velocities after).
  std::vector<BodyState> bodies_after;
};

/// Why an episode ended.
enum class EpisodeEnd {
  kSeparated,         ///< every contact separated, and no pair touches again before the horizon
  kSustainedContact,  ///< contacts stay closed: the resting analysis (EpisodeResult::resting)
  kHorizon,           ///< a pair still touching at t = horizon (or an impact there)
  kImpactCap,         ///< max_impacts reached
  kTimeBudget,        ///< solver.time_budget ran out
};

/// How one body ends the episode.
enum class BodyOutcome {
  kSeparated,  ///< in free flight (or never touched), touching nothing at the end
  kSliding,    ///< in sustained contact, at least one of its contacts slipping
  kRolling,    ///< in sustained contact, no contact slipping, but turning (|w| > 0)
  kSticking,   ///< in sustained contact, no contact slipping and not turning
  kCapped,     ///< the episode ended on its cap, horizon or budget with the body in contact
};

struct EpisodeResult {
  std::vector<BodyState> bodies;  ///< states at end_time, same order as given
  double end_time = 0.0;          ///< [s] from the start
  EpisodeEnd end = EpisodeEnd::kSeparated;
  std::vector<EpisodeImpact> impacts;  ///< in time order
  /// Impacts an accumulation point closed (inelastic bouncing summed as a geometric series:
  /// docs/physics.md, "Impact episodes"), not listed one by one in `impacts`. At most INT_MAX:
  /// with solver.resting_velocity = 0 no rebound ever falls below it, and the count (infinite) is
  /// given as INT_MAX.
  int accumulated_impacts = 0;
  std::vector<BodyOutcome> outcomes;  ///< one per body
  /// kSustainedContact: the closed contacts and their forces under gravity and the bodies'
  /// wrenches (ContactImpulse::resting, normal_force, friction_force, sticking), same order.
  std::vector<Contact> resting_contacts;
  std::vector<ContactImpulse> resting;
  /// kSustainedContact: every body's accelerations under the resting forces, world: centre of
  /// mass [m/s^2] and angular [rad/s^2] (zero for immovable bodies).
  std::vector<Eigen::Vector3d> linear_accelerations;
  std::vector<Eigen::Vector3d> angular_accelerations;
  /// Of every impact, the field prefixed "impacts[k]." (a contact left approaching); warnings about
  /// the bodies given once; separating contacts of an impact get none.
  std::vector<Warning> warnings;
};

/// Follows the collision of `bodies` (validated as for computeResponse(); immovable bodies keep
/// their velocities) from their states at t = 0 to its end: free flight under gravity, the first
/// time of contact of any pair by conservative advancement on geometry's gaps (never missed),
/// each impact under options.solver, accumulation of inelastic bounces closed, then sustained
/// contact's resting analysis. Throws InvalidInput naming the field ("gravity", "horizon",
/// "max_impacts", "contact_tolerance", "bodies[i]..." ; "geometry" when it describes another number
/// of bodies). Thread safety: calls on different threads are independent; the working lists of
/// an episode are kept per thread and reused by the thread's next episode (their storage stays
/// with the thread, sized by its largest episode), and an episode started on a thread while
/// another runs there (from a GapQuery) takes lists of its own.
EpisodeResult computeEpisode(const std::vector<BodyState>& bodies, const GapQuery& geometry,
                             const EpisodeOptions& options = {});

const char* toString(EpisodeEnd end);
const char* toString(BodyOutcome outcome);

}  // namespace collision_response::core
