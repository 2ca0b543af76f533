#pragma once

#include <collision_response/ComputeBatch.h>
#include <collision_response/ComputeEpisode.h>
#include <collision_response/ComputeEpisodeBatch.h>
#include <collision_response/ComputeResponse.h>
#include <collision_response/EpisodeResult.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <vector>

#include "collision_response/core/episode.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/scene.h"
#include "collision_response/core/solver_options.h"
#include "collision_response/core/validation.h"
#include "collision_response/core/worker_pool.h"
#include "collision_response/detection/contact_detector.h"
#include "collision_response/detection/detect_contacts.h"
#include "collision_response/detection/materials.h"
#include "collision_response/ros/request_assembly.h"
#include "collision_response/ros/response_markers.h"
#include "collision_response/ros/served_robot.h"
#include "collision_response/ros/server_monitoring.h"
#include "collision_response/ros/server_parameters.h"

namespace collision_response {

/// The ROS face of the core library: serves ~compute and ~compute_batch, publishes every successful
/// ~compute answer on ~responses (and on ~markers for RViz, if subscribed), serves the episodes
/// (~compute_episode, ~compute_episode_batch; answers on ~episodes), and transforms bodies given in
/// other frames into the request frame with tf2. Used by collision_response_node and by
/// the nodelet collision_response/CollisionResponseNodelet.
///
/// Parameters (private namespace, read once here): ServerParameters (server_parameters.h).
/// law, solver, multi_contact, tolerance, max_iterations, integration_tolerance and
/// contact_tolerance can be changed at run time with dynamic_reconfigure (cfg/Solver.cfg);
/// diagnostics (call rate, failures, solver time) go to /diagnostics at 1 Hz.
///
/// The server keeps the callbacks; a request is assembled by the functions of request_assembly.h
/// (tf2, robots, link bodies, contact placement) and monitored by ServerMonitoring
/// (server_monitoring.h: dynamic_reconfigure, call records, diagnostics).
///
/// Thread-safe: the callbacks may run concurrently (a multi-threaded spinner, or a nodelet's MT
/// node handles).
class CollisionResponseServer {
 public:
  /// Reads the parameters (loadServerParameters()); throws core::InvalidInput naming a bad one.
  CollisionResponseServer(ros::NodeHandle node, ros::NodeHandle private_node);

  /// The parameters as read at start-up (dynamic_reconfigure changes the solver defaults later).
  const ServerParameters& parameters() const { return parameters_; }

  /// The service callback: always answers (returns true); failures are success = false with a
  /// message naming the field.
  bool compute(ComputeResponse::Request& request, ComputeResponse::Response& response);

  /// The ~compute_batch callback: every scene solved independently, results in order; a bad scene
  /// gets success = false and does not affect the others. Batch results are not published on
  /// ~responses or ~markers. Always answers (returns true).
  bool computeBatch(ComputeBatch::Request& request, ComputeBatch::Response& response);

  /// The ~compute_episode callback (episode_service.cpp): the collision followed from the request's
  /// states to its end (core::computeEpisode() on the bodies' shapes); publishes every successful
  /// answer on ~episodes. Always answers (returns true); bad input is success = false with a
  /// message naming the field.
  bool computeEpisode(ComputeEpisode::Request& request, ComputeEpisode::Response& response);

  /// The ~compute_episode_batch callback: every scene followed independently across the batch pool,
  /// results in order; a bad scene gets success = false ("scenes[i]...") and does not affect the
  /// others. Not published on ~episodes. Always answers (returns true).
  bool computeEpisodeBatch(ComputeEpisodeBatch::Request& request,
                           ComputeEpisodeBatch::Response& response);

  ~CollisionResponseServer();

 private:
  /// One scene: fills `response` (success false with a message on bad input); publishes nothing.
  /// An empty request.header.frame_id is set to ~default_frame (with a warning in the response).
  /// Returns the error of a request rejected for one of its values (named as in the request), so
  /// that a batch can name it in the batch.
  /// `link_frames` (if not null) receives, per contact on a robot's link, that link's frame for
  /// the markers (response_markers.h). `sampling_pool` spreads options.uncertainty's samples
  /// (nullptr: on the calling thread, as a batch's scenes do).
  std::optional<core::InvalidInput> solve(ComputeResponse::Request& request,
                                          ComputeResponse::Response& response,
                                          core::WorkerPool* sampling_pool,
                                          std::vector<ContactLinkFrame>* link_frames = nullptr);
  /// One episode: fills `result` (success false with a message on bad input); publishes nothing.
  /// An empty request.header.frame_id is set to ~default_frame (with a warning). Returns the error
  /// of a request rejected for one of its values, for a batch to name it. Reads (moves) the
  /// request's bodies.
  std::optional<core::InvalidInput> solveEpisode(ComputeEpisode::Request& request,
                                                 EpisodeResult& result);
  /// The episode of a request with robots (episode_service.cpp): the robots placed at their state
  /// (tf2, joint states, torque model), their links' collision geometry beside the bodies' shapes,
  /// core::computeBodyEpisode(); fills `result` and its solve_time.
  void solveRobotEpisode(const ComputeResponse::Request& shared, const core::Scene& scene,
                         const core::EpisodeOptions& options, double contact_tolerance,
                         std::vector<std::string>& warnings, EpisodeResult& result);
  /// The part of solve() for requests of rigid bodies alone: the given contacts checked, contacts
  /// detected (wantsDetection(), within `contact_tolerance` [m]) and checked, then
  /// core::computeValidatedResponse(); fills the answer (request frame) but not its success.
  // The outcome distribution of options.uncertainty (linear or sampled) over the request's
  // uncertainties, samples spread on `sampling_pool` (nullptr: this thread); a warning if
  // uncertainties come without a method.
  void solveUncertainty(const ComputeResponse::Request& request,
                        ComputeResponse::Response& response, const core::Scene& scene,
                        const core::SolverOptions& options, core::WorkerPool* sampling_pool);
  void solveRigid(const ComputeResponse::Request& request, ComputeResponse::Response& response,
                  core::Scene& scene, core::SceneValidator& validator,
                  const core::SolverOptions& options, double contact_tolerance,
                  core::WorkerPool* sampling_pool);
  /// The part of solve() for requests with robots (request.robots, or contacts naming
  /// "<robot>/<link>"): rigid bodies and robots as general body models (core::computeBodyResponse).
  /// `scene` holds the request's validated bodies and given contacts; `validator` has checked them.
  void solveWithRobots(const ComputeResponse::Request& request, ComputeResponse::Response& response,
                       core::Scene& scene, core::SceneValidator& validator,
                       const core::SolverOptions& options, core::WorkerPool* sampling_pool,
                       std::vector<ContactLinkFrame>* link_frames);
  /// The rigid bodies and the placed robots (placeRobots()) solved together by
  /// core::computeBodyResponse() on `points` (the contacts placed on the models); fills the
  /// answer's bodies, impulses, islands, effective masses, warnings, robots, energies [J] and
  /// solve_time [s]; with options.uncertainty (linear or sampled) and uncertainties,
  /// outcome_distribution (robotOutcomeDistribution(), samples spread on `sampling_pool`; linear:
  /// one solve).
  void solveBodyModels(const ComputeResponse::Request& request, ComputeResponse::Response& response,
                       core::Scene& scene, std::vector<RequestRobot>& robots,
                       const std::vector<core::ContactPoint>& points,
                       const core::SolverOptions& options, core::WorkerPool* sampling_pool);
  /// Detection for a request with robots: contacts from the bodies' shapes and the robots' links,
  /// added to the answer's detected contacts and to scene.contacts, then checked by `validator`.
  void detectWithLinks(const ComputeResponse::Request& request, ComputeResponse::Response& response,
                       core::Scene& scene, core::SceneValidator& validator,
                       const std::vector<RequestRobot>& robots, const core::SolverOptions& options);
  /// ~robots: each model from its URDF parameter, and a subscriber to its joint-state topic.
  void loadRobots(ros::NodeHandle& node);
  /// The request defaults (parameters, dynamic_reconfigure; ServerMonitoring::defaults()).
  using Defaults = SolverDefaults;
  Defaults defaults() const { return monitoring_->defaults(); }
  static ServerParameters readParameters(const ros::NodeHandle& private_node);
  /// A batch of `scenes` beyond ~max_batch_scenes: true, `message` naming the field, and the call
  /// recorded as one refused call; false otherwise.
  bool refuseOversizedBatch(std::size_t scenes, std::string& message);
  /// ServerMonitoring::recordCalls().
  void recordCalls(std::size_t calls, std::size_t scenes, std::size_t failures, double solve_time,
                   double max_solve_time) {
    monitoring_->recordCalls(calls, scenes, failures, solve_time, max_solve_time);
  }

  /// Request to core scene in the request frame (sceneInRequestFrame(): tf2 look-ups for bodies in
  /// other frames).
  core::Scene toScene(const ComputeResponse::Request& request) const {
    return sceneInRequestFrame(request, tf_buffer_, tf_timeout_, parameters_.limits);
  }
  /// Contacts from the bodies' shapes in `scene` (validated, request frame) and the robots' links
  /// (if any), with a detector of the pool, within the contact limit and options.time_budget.
  detection::DetectedContacts detect(const ComputeResponse::Request& request,
                                     const core::Scene& scene, const core::SolverOptions& options,
                                     double contact_tolerance, const LinkBodies* links = nullptr);

  /// Detectors keep FCL objects between calls but are not thread-safe: each request borrows one.
  std::unique_ptr<detection::ContactDetector> acquireDetector();
  void releaseDetector(std::unique_ptr<detection::ContactDetector> detector);

  /// Read once at construction; the request defaults start from them and follow
  /// dynamic_reconfigure (monitoring_).
  const ServerParameters parameters_;
  ros::Duration tf_timeout_;
  std::mutex detectors_mutex_;
  std::vector<std::unique_ptr<detection::ContactDetector>> idle_detectors_;
  ServedRobots robots_;  // ~robots, in order
  /// The scenes of a batch are solved across these threads (~threads, the calling one included).
  core::WorkerPool batch_pool_;
  std::vector<ros::Subscriber> joint_state_subscribers_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  ros::Publisher responses_;
  ros::ServiceServer service_;
  ros::Publisher markers_;
  ros::ServiceServer batch_service_;
  ros::Publisher episodes_;
  ros::ServiceServer episode_service_;
  ros::ServiceServer episode_batch_service_;
  /// dynamic_reconfigure, call records and diagnostics; made at the end of construction.
  std::unique_ptr<ServerMonitoring> monitoring_;
};

}  // namespace collision_response
