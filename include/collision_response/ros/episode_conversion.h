#pragma once

// Conversions between the episode messages (srv/ComputeEpisode, msg/EpisodeScene, EpisodeResult,
// EpisodeImpact) and core::computeEpisode()'s types (core/episode.h). The server's episode path
// (episode_service.cpp) is built from these; they need no ROS master.

#include <collision_response/ComputeEpisode.h>
#include <collision_response/ComputeResponse.h>
#include <collision_response/EpisodeResult.h>
#include <collision_response/EpisodeScene.h>
#include <std_msgs/Header.h>

#include <string>

#include <Eigen/Geometry>
#include <vector>

#include "collision_response/core/body_episode.h"
#include "collision_response/core/episode.h"
#include "collision_response/core/solver_options.h"
#include "collision_response/robot/articulated_body.h"

namespace collision_response {

/// Refuses what an episode cannot follow, before any work: derivatives ("options.derivatives":
/// only ~compute differentiates an impact), given contacts ("contacts": an episode finds its
/// contacts from the shapes), detection.mode MODE_NEVER or an unknown mode ("detection.mode"), a
/// body without shapes
/// ("bodies[i]"). Throws core::InvalidInput naming the field.
void checkEpisodeRequest(const ComputeEpisode::Request& request);

/// The episode's options: gravity [m/s^2] (request frame), horizon [s], max_impacts, the contact
/// tolerance (the request's detection.contact_tolerance, 0 = `default_tolerance`) and `solver` (the
/// request's options over the node's defaults). Copies: core::computeEpisode() checks the values
/// and names them ("gravity", "horizon", "max_impacts"); only a max_impacts beyond what an int
/// holds throws core::InvalidInput ("max_impacts") here. Nothing is clamped.
core::EpisodeOptions episodeOptionsFromMsg(const ComputeEpisode::Request& request,
                                           const core::SolverOptions& solver,
                                           double default_tolerance);

/// The fields an episode request shares with a ComputeResponse request (header, bodies, contacts,
/// options, detection, robots), moved out of `request`: the server reads the bodies (tf, checks,
/// shapes) as it does for ~compute.
ComputeResponse::Request sharedRequest(ComputeEpisode::Request&& request);

/// A batch's scene as a single request (moved out of `scene`); a scene with an empty
/// header.frame_id takes `batch_header`.
ComputeEpisode::Request episodeRequest(EpisodeScene&& scene, const std_msgs::Header& batch_header);

/// The END_* / OUTCOME_* strings of EpisodeResult.msg.
const char* endReasonName(core::EpisodeEnd end);
const char* outcomeName(core::BodyOutcome outcome);

/// The answer (success true, message empty, solve_time 0 for the caller to set): bodies, impacts
/// (their contacts, impulses and bodies), outcomes, end reason and time, accumulated impacts, the
/// resting contacts and forces, accelerations, warnings; states expressed in `frame_id`.
EpisodeResult toMsg(const core::EpisodeResult& result, const std::string& frame_id);

/// A robot of an episode as its answer names it: its request name, its body at the end of the
/// episode (joint names, link names, state) and its base pose (request frame).
struct EpisodeRobotAnswer {
  std::string name;
  const robot::ArticulatedBody* body = nullptr;
  Eigen::Isometry3d base_pose = Eigen::Isometry3d::Identity();
};
/// The answer of an episode with robots (core::computeBodyEpisode() over the request's rigid
/// bodies, then one body per robot, in order): `bodies` the rigid bodies as given (ids and mass
/// properties), `bodies_end` at end_time; contacts name a rigid body by its id and a robot's link
/// "<robot>/<link>"; each impact's rigid bodies from its states_after, its robots' joint positions
/// at the impact and velocities after it; the robots' end states and outcomes in `robots`;
/// accelerations empty. States in header.frame_id.
EpisodeResult toMsg(const core::BodyEpisodeResult& result,
                    const std::vector<core::BodyState>& bodies,
                    const std::vector<core::BodyState>& bodies_end,
                    const std::vector<EpisodeRobotAnswer>& robots, const std_msgs::Header& header);
/// The same fields, moved into the service's response.
void moveInto(EpisodeResult&& result, ComputeEpisode::Response& response);

}  // namespace collision_response
