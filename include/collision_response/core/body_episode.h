#pragma once

#include <Eigen/Core>
#include <vector>

#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/episode.h"
#include "collision_response/core/episode_body.h"
#include "collision_response/core/gap_query.h"
#include "collision_response/core/warning.h"

namespace collision_response::core {

/// A body of the geometry (core::GapQuery) as a part of an episode body: geometry body g is part
/// `part` of bodies[body].
struct EpisodePart {
  int body = 0;
  int part = 0;
};

/// One impact of an episode of general bodies.
struct BodyEpisodeImpact {
  double time = 0.0;  ///< from the start of the episode [s]
  /// Every touching contact (world; body indices into the episode's bodies, parts as
  /// EpisodeBody's, -1 never) and its impulse, same order.
  std::vector<ContactPoint> contacts;
  std::vector<ContactImpulse> impulses;
  /// Each body's velocity unknowns right after the impact (BodyModel::velocity(): (v, w) of a
  /// movable rigid body [m/s, rad/s], world; a robot's free joints' velocities [rad/s | m/s] in
  /// its unknowns' order; empty for a body without unknowns).
  std::vector<Eigen::VectorXd> velocities_after;
  /// Each body's whole state right after the impact, as EpisodeBody::saveState() gives it (a
  /// rigid body's RigidEpisodeBody::stateFrom() reads; a robot's joint positions then velocities,
  /// joint order, every joint).
  std::vector<Eigen::VectorXd> states_after;
};

struct BodyEpisodeResult {
  double end_time = 0.0;  ///< [s]
  EpisodeEnd end = EpisodeEnd::kSeparated;
  std::vector<BodyEpisodeImpact> impacts;  ///< in time order
  std::vector<BodyOutcome> outcomes;       ///< one per body
  /// kSustainedContact: the closed contacts and their resting forces (ContactImpulse::resting,
  /// normal_force [N], friction_force [N], sticking), same order.
  std::vector<ContactPoint> resting_contacts;
  std::vector<ContactImpulse> resting;
  /// Of each impact "impacts[k]." (a contact left approaching); "bodies[i]" for a body whose part
  /// starts deeper than the tolerance in another body.
  std::vector<Warning> warnings;
  int steps = 0;  ///< advancement steps taken (and undone), for diagnostics
};

/// An impact episode of general bodies (episode_body.h: rigid bodies, robots): from their states
/// now to the collision's end, as computeEpisode() (episode.h) follows rigid bodies, with what
/// differs for bodies that are not free rigid bodies (docs/physics.md, "Robots in episodes"):
/// - each body moves by its own EpisodeBody::advance() (a robot by its forward dynamics under its
///   torque model), the bodies changed in place: at the end they hold the state at end_time;
/// - the geometry's bodies are the parts (`parts[g]` is geometry body g), posed by
///   EpisodeBody::partPose();
/// - conservative advancement bounds each listed pair's closing by V s + A s^2 / 2 from the
///   parts' bounds (partSpeedBound(), partAccelerationBound()), pairs left out by the range with
///   the two fastest parts; a pair of convex parts (GapQuery::convex()) apart by more than the
///   tolerance that opens also by its gap's rate along the normal n of its smallest gap,
///   (u_n - W_a - W_b) s - (A_a + A_b) s^2 / 2 (u_n the parts' reference points' relative normal
///   velocity, W how fast turning moves a part's points towards the other: a link's from its
///   angular velocity and GapQuery::support(), a rigid body's V(r) - V(0)), whichever allows the
///   longer step, so that a receding pair takes long steps (docs/physics.md, "Receding pairs"); a
///   step after which a pair that was apart overlaps (gap < 0), or a touching one sinks below
///   -contact_tolerance, is undone and halved;
/// - impacts and resting forces by computeBodyResponse() on the bodies' models (contacts on
///   parts); a touch approaching within its resting threshold is solved plastic; inelastic
///   bounces are followed one by one until their rebound falls below the threshold (no
///   geometric-series closure);
/// - sustained contact: the touching contacts' resting forces hold, and no movable body they do
///   not hold can reach anything before the horizon; a held body that is at rest (every point
///   within the resting velocity) is kept still while others fly (its velocities set to 0), a held
///   body that moves flies and is caught by plastic touches.
/// Throws InvalidInput as computeEpisode() ("gravity", "horizon", "max_impacts",
/// "contact_tolerance"), "geometry" when it describes another number of bodies than `parts`, and
/// "parts[g]" for a part out of range.
BodyEpisodeResult computeBodyEpisode(const std::vector<EpisodeBody*>& bodies,
                                     const std::vector<EpisodePart>& parts,
                                     const GapQuery& geometry, const EpisodeOptions& options = {});

}  // namespace collision_response::core
