#include "collision_response/ros/episode_conversion.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "collision_response/core/errors.h"
#include "collision_response/ros/message_conversion.h"

namespace collision_response {

void checkEpisodeRequest(const ComputeEpisode::Request& request) {
  if (request.options.derivatives) {
    throw core::InvalidInput("options.derivatives",
                             "episodes do not differentiate their impacts: ask ~compute for one "
                             "impact with derivatives");
  }
  if (request.options.uncertainty != SolverOptions::UNCERTAINTY_NONE) {
    throw core::InvalidInput("options.uncertainty",
                             "episodes do not propagate uncertain coefficients: ask ~compute for "
                             "one impact with uncertainties");
  }
  if (!request.robots.empty()) {
    throw core::InvalidInput("robots", "episodes do not follow robots yet (" +
                                           std::to_string(request.robots.size()) +
                                           " given): ask ~compute for one impact instead");
  }
  if (!request.contacts.empty()) {
    throw core::InvalidInput("contacts", "must be empty (" +
                                             std::to_string(request.contacts.size()) +
                                             " given): an episode finds its contacts from the "
                                             "bodies' shapes, at the moments they touch");
  }
  switch (request.detection.mode) {
    case DetectionOptions::MODE_AUTO:
    case DetectionOptions::MODE_ALWAYS:
      break;
    case DetectionOptions::MODE_NEVER:
      throw core::InvalidInput("detection.mode",
                               "MODE_NEVER: an episode finds its contacts from the shapes (use "
                               "MODE_AUTO or MODE_ALWAYS)");
    default:
      throw core::InvalidInput("detection.mode", "unknown value " +
                                                     std::to_string(request.detection.mode) +
                                                     " (MODE_AUTO 0, MODE_ALWAYS 1, MODE_NEVER 2)");
  }
  for (std::size_t i = 0; i < request.bodies.size(); ++i) {
    if (!hasGeometry(request.bodies[i])) {
      throw core::InvalidInput("bodies[" + std::to_string(i) + "]",
                               "has no shapes (primitives, meshes or planes): an episode finds "
                               "the contacts of '" +
                                   request.bodies[i].id + "' from them");
    }
  }
}

core::EpisodeOptions episodeOptionsFromMsg(const ComputeEpisode::Request& request,
                                           const core::SolverOptions& solver,
                                           double default_tolerance) {
  core::EpisodeOptions options;
  // Copies: computeEpisode() checks the values and names them ("gravity", "horizon",
  // "max_impacts"). Only what an int cannot hold is refused here (never wrapped, never clamped).
  options.gravity = toEigen(request.gravity);
  options.horizon = request.horizon;
  if (request.max_impacts > static_cast<uint32_t>(std::numeric_limits<int>::max())) {
    throw core::InvalidInput("max_impacts", "must lie in [1, " +
                                                std::to_string(std::numeric_limits<int>::max()) +
                                                "] (" + std::to_string(request.max_impacts) + ")");
  }
  options.max_impacts = static_cast<int>(request.max_impacts);
  // The tolerance is the request's detection.contact_tolerance (0: the node's
  // ~contact_tolerance), checked here so that an error names the field the client sets.
  const double given = request.detection.contact_tolerance;
  options.contact_tolerance = given != 0.0 ? given : default_tolerance;
  if (!std::isfinite(options.contact_tolerance) || !(options.contact_tolerance > 0.0) ||
      options.contact_tolerance > 1.0) {
    throw core::InvalidInput(
        "detection.contact_tolerance",
        given != 0.0 ? "an episode needs a tolerance in (0, 1] m (" + std::to_string(given) + ")"
                     : "is 0 here and the node's ~contact_tolerance is " +
                           std::to_string(default_tolerance) +
                           " m: an episode needs a tolerance in (0, 1] m");
  }
  options.solver = solver;
  return options;
}

ComputeResponse::Request sharedRequest(ComputeEpisode::Request&& request) {
  ComputeResponse::Request shared;
  shared.header = std::move(request.header);
  shared.bodies = std::move(request.bodies);
  shared.contacts = std::move(request.contacts);
  shared.options = request.options;
  shared.detection = request.detection;
  shared.robots = std::move(request.robots);
  return shared;
}

ComputeEpisode::Request episodeRequest(EpisodeScene&& scene, const std_msgs::Header& batch_header) {
  ComputeEpisode::Request request;
  request.header = scene.header.frame_id.empty() ? batch_header : std::move(scene.header);
  request.bodies = std::move(scene.bodies);
  request.contacts = std::move(scene.contacts);
  request.options = scene.options;
  request.detection = scene.detection;
  request.robots = std::move(scene.robots);
  request.gravity = scene.gravity;
  request.horizon = scene.horizon;
  request.max_impacts = scene.max_impacts;
  return request;
}

const char* endReasonName(core::EpisodeEnd end) {
  switch (end) {
    case core::EpisodeEnd::kSeparated:
      return "separated";
    case core::EpisodeEnd::kSustainedContact:
      return "sustained_contact";
    case core::EpisodeEnd::kHorizon:
      return "horizon";
    case core::EpisodeEnd::kImpactCap:
      return "impact_cap";
    case core::EpisodeEnd::kTimeBudget:
      return "time_budget";
  }
  return "unknown";
}

const char* outcomeName(core::BodyOutcome outcome) {
  switch (outcome) {
    case core::BodyOutcome::kSeparated:
      return "separated";
    case core::BodyOutcome::kSliding:
      return "sliding";
    case core::BodyOutcome::kRolling:
      return "rolling";
    case core::BodyOutcome::kSticking:
      return "sticking";
    case core::BodyOutcome::kCapped:
      return "capped";
  }
  return "unknown";
}

EpisodeResult toMsg(const core::EpisodeResult& result, const std::string& frame_id) {
  EpisodeResult msg;
  msg.success = true;
  msg.bodies.reserve(result.bodies.size());
  for (const core::BodyState& body : result.bodies) msg.bodies.push_back(toMsg(body, frame_id));
  msg.impacts.reserve(result.impacts.size());
  for (const core::EpisodeImpact& impact : result.impacts) {
    EpisodeImpact out;
    out.time = impact.time;
    out.contacts.reserve(impact.contacts.size());
    for (const core::Contact& contact : impact.contacts) out.contacts.push_back(toMsg(contact));
    out.impulses.reserve(impact.impulses.size());
    for (const core::ContactImpulse& impulse : impact.impulses)
      out.impulses.push_back(toMsg(impulse));
    out.bodies.reserve(impact.bodies_after.size());
    for (const core::BodyState& body : impact.bodies_after)
      out.bodies.push_back(toMsg(body, frame_id));
    msg.impacts.push_back(std::move(out));
  }
  msg.accumulated_impacts = static_cast<uint32_t>(std::max(0, result.accumulated_impacts));
  msg.outcomes.reserve(result.outcomes.size());
  for (const core::BodyOutcome outcome : result.outcomes)
    msg.outcomes.emplace_back(outcomeName(outcome));
  msg.end_reason = endReasonName(result.end);
  msg.end_time = result.end_time;
  msg.resting_contacts.reserve(result.resting_contacts.size());
  for (const core::Contact& contact : result.resting_contacts)
    msg.resting_contacts.push_back(toMsg(contact));
  msg.resting_forces.reserve(result.resting.size());
  for (const core::ContactImpulse& force : result.resting)
    msg.resting_forces.push_back(toMsg(force));
  const std::size_t accelerations =
      std::min(result.linear_accelerations.size(), result.angular_accelerations.size());
  msg.accelerations.resize(accelerations);
  for (std::size_t i = 0; i < accelerations; ++i) {
    msg.accelerations[i].linear = toVector3(result.linear_accelerations[i]);
    msg.accelerations[i].angular = toVector3(result.angular_accelerations[i]);
  }
  msg.warnings.reserve(result.warnings.size());
  for (const core::Warning& warning : result.warnings) msg.warnings.push_back(warning.text());
  return msg;
}

void moveInto(EpisodeResult&& result, ComputeEpisode::Response& response) {
  response.success = result.success;
  response.message = std::move(result.message);
  response.warnings = std::move(result.warnings);
  response.bodies = std::move(result.bodies);
  response.impacts = std::move(result.impacts);
  response.accumulated_impacts = result.accumulated_impacts;
  response.outcomes = std::move(result.outcomes);
  response.end_reason = std::move(result.end_reason);
  response.end_time = result.end_time;
  response.resting_contacts = std::move(result.resting_contacts);
  response.resting_forces = std::move(result.resting_forces);
  response.accelerations = std::move(result.accelerations);
  response.solve_time = result.solve_time;
}

}  // namespace collision_response
