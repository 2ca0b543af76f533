// The episode services of CollisionResponseServer (~compute_episode, ~compute_episode_batch) and
// the ~episodes topic: the request checked and converted (episode_conversion.h), the bodies read
// as for ~compute (tf2, validation), their shapes as a detection::ShapeGaps, then
// core::computeEpisode().
#include <collision_response/Episode.h>

#include <algorithm>
#include <chrono>
#include <optional>
#include <utility>
#include <vector>

#include "collision_response/core/episode.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/validation.h"
#include "collision_response/detection/shape_gaps.h"
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
