#include "collision_response/ros/episode_conversion.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "collision_response/core/errors.h"
#include "collision_response/core/rigid_episode_body.h"
#include "collision_response/ros/message_conversion.h"

namespace collision_response {

void checkEpisodeRequest(const ComputeEpisode::Request& request) {
  if (request.options.derivatives) {
    throw core::InvalidInput("options.derivatives",
                             "episodes do not differentiate their impacts: ask ~compute for one "
                             "impact with derivatives");
  }
  if (request.options.joint_position_derivatives) {
    throw core::InvalidInput("options.joint_position_derivatives",
                             "episodes do not differentiate their impacts: ask ~compute for one "
                             "impact with derivatives");
  }
  if (request.options.uncertainty != SolverOptions::UNCERTAINTY_NONE) {
    throw core::InvalidInput("options.uncertainty",
                             "episodes do not propagate uncertain coefficients: ask ~compute for "
                             "one impact with uncertainties");
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

namespace {

sensor_msgs::JointState jointState(const robot::ArticulatedBody& body, const Eigen::VectorXd& q,
                                   const Eigen::VectorXd& qdot, const std_msgs::Header& header) {
  sensor_msgs::JointState out;
  out.header = header;
  out.name = body.jointNames();
  out.position.assign(q.data(), q.data() + q.size());
  out.velocity.assign(qdot.data(), qdot.data() + qdot.size());
  return out;
}

}  // namespace

EpisodeResult toMsg(const core::BodyEpisodeResult& result,
                    const std::vector<core::BodyState>& bodies,
                    const std::vector<core::BodyState>& bodies_end,
                    const std::vector<EpisodeRobotAnswer>& robots, const std_msgs::Header& header) {
  const std::string& frame_id = header.frame_id;
  const std::size_t rigid = bodies.size();
  const auto idOf = [&](int body, int part) {
    if (body < static_cast<int>(rigid)) return bodies[body].id;
    const EpisodeRobotAnswer& robot = robots[body - rigid];
    return robot.name + "/" + robot.body->linkName(part < 0 ? robot.body->defaultLink() : part);
  };
  const auto contactOf = [&](const core::ContactPoint& point) {
    core::Contact contact;
    contact.body_a = idOf(point.body_a, point.part_a);
    contact.body_b = idOf(point.body_b, point.part_b);
    contact.point = point.point;
    contact.normal = point.normal;
    contact.restitution = point.restitution;
    contact.static_friction = point.static_friction;
    contact.dynamic_friction = point.dynamic_friction;
    return toMsg(contact);
  };
  EpisodeResult msg;
  msg.success = true;
  for (const core::BodyState& body : bodies_end) msg.bodies.push_back(toMsg(body, frame_id));
  for (std::size_t r = 0; r < robots.size(); ++r) {
    const robot::ArticulatedBody& body = *robots[r].body;
    EpisodeRobot out;
    out.name = robots[r].name;
    out.joint_state = jointState(body, body.jointPositions(), body.jointVelocities(), header);
    const Eigen::Quaterniond q(robots[r].base_pose.linear());
    out.base_pose.position.x = robots[r].base_pose.translation().x();
    out.base_pose.position.y = robots[r].base_pose.translation().y();
    out.base_pose.position.z = robots[r].base_pose.translation().z();
    out.base_pose.orientation.x = q.x();
    out.base_pose.orientation.y = q.y();
    out.base_pose.orientation.z = q.z();
    out.base_pose.orientation.w = q.w();
    out.kinetic_energy = body.kineticEnergy();
    out.outcome = rigid + r < result.outcomes.size() ? outcomeName(result.outcomes[rigid + r])
                                                     : EpisodeResult::OUTCOME_SEPARATED;
    msg.robots.push_back(std::move(out));
  }
  for (const core::BodyEpisodeImpact& impact : result.impacts) {
    EpisodeImpact out;
    out.time = impact.time;
    for (const core::ContactPoint& point : impact.contacts)
      out.contacts.push_back(contactOf(point));
    for (const core::ContactImpulse& impulse : impact.impulses)
      out.impulses.push_back(toMsg(impulse));
    for (std::size_t i = 0; i < rigid; ++i) {
      out.bodies.push_back(
          toMsg(core::RigidEpisodeBody::stateFrom(bodies[i], impact.states_after[i]), frame_id));
    }
    for (std::size_t r = 0; r < robots.size(); ++r) {
      const Eigen::VectorXd& state = impact.states_after[rigid + r];
      const Eigen::Index n = state.size() / 2;
      out.robots.push_back(jointState(*robots[r].body, state.head(n), state.tail(n), header));
    }
    msg.impacts.push_back(std::move(out));
  }
  for (std::size_t i = 0; i < rigid && i < result.outcomes.size(); ++i)
    msg.outcomes.emplace_back(outcomeName(result.outcomes[i]));
  msg.end_reason = endReasonName(result.end);
  msg.end_time = result.end_time;
  for (const core::ContactPoint& point : result.resting_contacts)
    msg.resting_contacts.push_back(contactOf(point));
  for (const core::ContactImpulse& force : result.resting)
    msg.resting_forces.push_back(toMsg(force));
  for (const core::Warning& warning : result.warnings) msg.warnings.push_back(warning.text());
  return msg;
}

void moveInto(EpisodeResult&& result, ComputeEpisode::Response& response) {
  response.success = result.success;
  response.message = std::move(result.message);
  response.warnings = std::move(result.warnings);
  response.bodies = std::move(result.bodies);
  response.robots = std::move(result.robots);
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
