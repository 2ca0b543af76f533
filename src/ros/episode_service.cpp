// The episode services of CollisionResponseServer (~compute_episode, ~compute_episode_batch) and
// the ~episodes topic: the request checked and converted (episode_conversion.h), the bodies read
// as for ~compute (tf2, validation), their shapes as a detection::ShapeGaps, then
// core::computeEpisode(); with robots, their links' geometry added and core::computeBodyEpisode().
#include <collision_response/Episode.h>

#include <algorithm>
#include <chrono>
#include <optional>
#include <utility>
#include <vector>

#include "collision_response/core/body_episode.h"
#include "collision_response/core/episode.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/rigid_episode_body.h"
#include "collision_response/core/validation.h"
#include "collision_response/detection/shape_gaps.h"
#include "collision_response/robot/robot_episode_body.h"
#include "collision_response/ros/collision_response_server.h"
#include "collision_response/ros/episode_conversion.h"
#include "collision_response/ros/message_conversion.h"

namespace collision_response {

std::optional<core::InvalidInput> CollisionResponseServer::solveEpisode(
    ComputeEpisode::Request& request, EpisodeResult& result) {
  std::optional<core::InvalidInput> field_error;
  result = EpisodeResult();
  std::vector<std::string> warnings;
  if (request.header.frame_id.empty()) {
    request.header.frame_id = parameters_.default_frame;
    warnings.push_back("header.frame_id: empty, taken as ~default_frame '" +
                       parameters_.default_frame + "'");
  }
  const auto begin = std::chrono::steady_clock::now();
  try {
    // What an episode cannot follow, and its own options, before any work on the bodies.
    checkEpisodeRequest(request);
    const Defaults defaults_now = defaults();
    const core::SolverOptions solver = fromMsg(request.options, defaults_now.options);
    const core::EpisodeOptions options =
        episodeOptionsFromMsg(request, solver, defaults_now.contact_tolerance);
    // The bodies as ~compute reads them: sizes, tf2, every value checked.
    const ComputeResponse::Request shared = sharedRequest(std::move(request));
    request.header = shared.header;  // kept for the caller (the published answer's header)
    core::Scene scene = toScene(shared);
    const core::SceneValidator validator(scene, solver, parameters_.limits);
    if (!shared.robots.empty()) {
      solveRobotEpisode(shared, scene, options, defaults_now.contact_tolerance, warnings, result);
      return field_error;
    }
    std::size_t shapes = 0, vertices = 0, triangles = 0;
    for (const BodyState& body : shared.bodies) countGeometry(body, shapes, vertices, triangles);
    core::checkGeometrySize(shapes, vertices, triangles, parameters_.limits);
    detection::DetectionInput input =
        detectionInputFromMsg(shared.bodies, shared.detection, defaults_now.contact_tolerance);
    input.options.max_contacts_per_pair = parameters_.max_contacts_per_pair;

    const auto start = std::chrono::steady_clock::now();
    const detection::ShapeGaps geometry(scene.bodies, input, parameters_.materials,
                                        parameters_.limits);
    const core::EpisodeResult episode = core::computeEpisode(scene.bodies, geometry, options);
    const double solve_time =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

    result = toMsg(episode, shared.header.frame_id);
    result.solve_time = solve_time;
    warnings.insert(warnings.end(), result.warnings.begin(), result.warnings.end());
    result.warnings = std::move(warnings);
    return field_error;
  } catch (const core::InvalidInput& e) {
    field_error = e;
    result.message = e.what();
    ROS_DEBUG("collision_response: rejected episode: %s", result.message.c_str());
  } catch (const core::SolverTimeout& e) {
    result.message = e.what();
    result.solve_time =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
    ROS_WARN("collision_response: episode: %s", e.what());
  } catch (const std::exception& e) {
    result.message = std::string("internal error: ") + e.what();
    ROS_ERROR("collision_response: episode: %s", result.message.c_str());
  }
  result.success = false;
  return field_error;
}

void CollisionResponseServer::solveRobotEpisode(const ComputeResponse::Request& shared,
                                                const core::Scene& scene,
                                                const core::EpisodeOptions& options,
                                                double contact_tolerance,
                                                std::vector<std::string>& warnings,
                                                EpisodeResult& result) {
  // The robots at their state, as ~compute places them (listed ones only: an episode has no
  // contacts to name others).
  std::vector<RequestRobot> robots = requestRobots(shared, scene.bodies, robots_);
  placeRobots(robots, shared.header, tf_buffer_, tf_timeout_, ros::Time::now(),
              parameters_.joint_state_timeout, warnings);
  for (const RequestRobot& robot : robots) {
    // One gravity moves every body: a robot's own (for ~compute's resting contacts) must agree.
    const Eigen::Vector3d own = toEigen(robot.message.gravity);
    if (!own.isZero(0.0) && (own - options.gravity).norm() > 1e-9 * options.gravity.norm()) {
      throw core::InvalidInput(
          robot.field + ".gravity",
          "differs from the episode's gravity: leave it zero (the episode's is "
          "used) or give the same vector");
    }
  }
  const LinkBodies links = linkBodies(robots);
  std::size_t shapes = links.shapes, vertices = links.vertices, triangles = links.triangles;
  for (const BodyState& body : shared.bodies) countGeometry(body, shapes, vertices, triangles);
  core::checkGeometrySize(shapes, vertices, triangles, parameters_.limits);
  detection::DetectionInput input =
      detectionInputFromMsg(shared.bodies, shared.detection, contact_tolerance);
  input.options.max_contacts_per_pair = parameters_.max_contacts_per_pair;
  input.collision_groups.assign(scene.bodies.size(), -1);
  for (const detection::BodyGeometry* geometry : links.geometry) {
    input.geometry.push_back(*geometry);
    input.materials.emplace_back();  // the request's detection coefficients
  }
  input.collision_groups.insert(input.collision_groups.end(), links.groups.begin(),
                                links.groups.end());

  const auto start = std::chrono::steady_clock::now();
  // The episode's bodies: the rigid bodies, then one per robot; its geometry's: the rigid bodies,
  // then the links with collision geometry (their robot and link kept by index).
  const int rigid_count = static_cast<int>(scene.bodies.size());
  std::vector<core::RigidEpisodeBody> rigid;
  rigid.reserve(scene.bodies.size());
  for (const core::BodyState& body : scene.bodies) rigid.emplace_back(body);
  std::vector<robot::RobotEpisodeBody> moving;
  moving.reserve(robots.size());
  for (RequestRobot& robot : robots) {
    try {
      moving.emplace_back(std::move(*robot.model));
    } catch (const core::InvalidInput& e) {
      throw e.prefixed(robot.field);
    }
  }
  std::vector<core::EpisodeBody*> bodies;
  for (core::RigidEpisodeBody& body : rigid) bodies.push_back(&body);
  for (robot::RobotEpisodeBody& body : moving) bodies.push_back(&body);
  std::vector<core::EpisodePart> parts;
  std::vector<core::BodyState> part_states = scene.bodies;
  for (int i = 0; i < rigid_count; ++i) parts.push_back({i, 0});
  const RobotLinkIds link_ids = robotLinkIds(robots);
  for (std::size_t k = 0; k < links.bodies.size(); ++k) {
    const std::pair<int, int>& robot_link = link_ids.robot_link[links.link_ids[k]];
    parts.push_back({rigid_count + robot_link.first, robot_link.second});
    part_states.push_back(links.bodies[k]);
  }
  const detection::ShapeGaps geometry(part_states, input, parameters_.materials,
                                      parameters_.limits);
  const core::BodyEpisodeResult episode =
      core::computeBodyEpisode(bodies, parts, geometry, options);
  const double solve_time =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  std::vector<core::BodyState> bodies_end;
  for (const core::RigidEpisodeBody& body : rigid) bodies_end.push_back(body.state());
  std::vector<EpisodeRobotAnswer> answers;
  for (std::size_t r = 0; r < robots.size(); ++r)
    answers.push_back({robots[r].message.name, &moving[r].robot(), robots[r].base_pose});
  result = toMsg(episode, scene.bodies, bodies_end, answers, shared.header);
  result.solve_time = solve_time;
  warnings.insert(warnings.end(), result.warnings.begin(), result.warnings.end());
  result.warnings = std::move(warnings);
}

bool CollisionResponseServer::computeEpisode(ComputeEpisode::Request& request,
                                             ComputeEpisode::Response& response) {
  EpisodeResult result;
  solveEpisode(request, result);
  recordCalls(1, 1, result.success ? 0 : 1, result.solve_time, result.solve_time);
  if (result.success && episodes_.getNumSubscribers() > 0) {
    Episode published;
    published.header = request.header;
    published.result = result;
    episodes_.publish(published);
  }
  moveInto(std::move(result), response);
  return true;
}

bool CollisionResponseServer::computeEpisodeBatch(ComputeEpisodeBatch::Request& request,
                                                  ComputeEpisodeBatch::Response& response) {
  response.success = false;
  response.solve_time = 0.0;
  if (refuseOversizedBatch(request.scenes.size(), response.message)) return true;
  // Independent episodes across the batch pool (~threads), each by solveEpisode() as a single
  // request, into its own result.
  response.results.resize(request.scenes.size());
  batch_pool_.parallelFor(request.scenes.size(), [&](std::size_t i) {
    ComputeEpisode::Request single = episodeRequest(std::move(request.scenes[i]), request.header);
    EpisodeResult& result = response.results[i];
    const std::optional<core::InvalidInput> field_error = solveEpisode(single, result);
    if (!result.success) {
      // "scenes[i].horizon: ..." for a field, "scenes[i]: ..." for anything else.
      const std::string scene_field = "scenes[" + std::to_string(i) + "]";
      result.message = field_error ? field_error->prefixed(scene_field).what()
                                   : scene_field + ": " + result.message;
    }
  });
  std::size_t failures = 0;
  double max_solve_time = 0.0;
  for (const EpisodeResult& result : response.results) {
    failures += result.success ? 0 : 1;
    response.solve_time += result.solve_time;
    max_solve_time = std::max(max_solve_time, result.solve_time);
  }
  response.success = true;
  recordCalls(1, request.scenes.size(), failures, response.solve_time, max_solve_time);
  return true;
}

}  // namespace collision_response
