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

#include "collision_response/core/errors.h"
#include "collision_response/core/scene.h"
#include "collision_response/core/solver_options.h"
#include "collision_response/core/validation.h"
#include "collision_response/core/worker_pool.h"
#include "collision_response/detection/contact_detector.h"
#include "collision_response/detection/detect_contacts.h"
#include "collision_response/detection/materials.h"
#include "collision_response/ros/response_markers.h"
#include "collision_response/ros/served_robot.h"
#include "collision_response/ros/server_parameters.h"

namespace diagnostic_updater {
class DiagnosticStatusWrapper;
class Updater;
}  // namespace diagnostic_updater
namespace dynamic_reconfigure {
template <class ConfigType>
class Server;
}  // namespace dynamic_reconfigure

namespace collision_response {

class SolverConfig;  // generated from cfg/Solver.cfg

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
  /// the markers (response_markers.h).
  std::optional<core::InvalidInput> solve(ComputeResponse::Request& request,
                                          ComputeResponse::Response& response,
                                          std::vector<ContactLinkFrame>* link_frames = nullptr);
  /// One episode: fills `result` (success false with a message on bad input); publishes nothing.
  /// An empty request.header.frame_id is set to ~default_frame (with a warning). Returns the error
  /// of a request rejected for one of its values, for a batch to name it. Reads (moves) the
  /// request's bodies.
  std::optional<core::InvalidInput> solveEpisode(ComputeEpisode::Request& request,
                                                 EpisodeResult& result);
  /// The part of solve() for requests with robots (request.robots, or contacts naming
  /// "<robot>/<link>"): rigid bodies and robots as general body models (core::computeBodyResponse).
  /// `scene` holds the request's validated bodies and given contacts; `validator` has checked them.
  void solveWithRobots(const ComputeResponse::Request& request, ComputeResponse::Response& response,
                       core::Scene& scene, core::SceneValidator& validator,
                       const core::SolverOptions& options,
                       std::vector<ContactLinkFrame>* link_frames);
  /// Whether a request involves robots: it lists some, or a contact names an id that is no body's
  /// and starts with a served robot's name and '/'.
  bool involvesRobots(const ComputeResponse::Request& request) const;
  /// The served robot called `name`, or nullptr.
  ServedRobot* findRobot(const std::string& name) const;
  /// ~robots: each model from its URDF parameter, and a subscriber to its joint-state topic.
  void loadRobots(ros::NodeHandle& node);
  /// The request defaults (parameters, dynamic_reconfigure), read together under the mutex so that
  /// a reconfigure cannot land between them.
  struct Defaults {
    core::SolverOptions options;
    double contact_tolerance;  ///< [m]
  };
  Defaults defaults() const;
  static ServerParameters readParameters(const ros::NodeHandle& private_node);
  /// dynamic_reconfigure and diagnostics, at the end of construction.
  void setUpMonitoring(const ros::NodeHandle& node, const ros::NodeHandle& private_node);
  void reconfigure(SolverConfig& config, uint32_t level);
  void recordCalls(std::size_t calls, std::size_t scenes, std::size_t failures, double solve_time,
                   double max_solve_time);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);

  /// Request to core scene in the request frame (tf2 look-ups for bodies in other frames).
  core::Scene toScene(const ComputeResponse::Request& request) const;
  /// Whether the request's contacts are to be found from the bodies' shapes (detection.mode);
  /// `robot_geometry`: a robot taking part has link collision geometry (MODE_AUTO counts it).
  static bool wantsDetection(const ComputeResponse::Request& request, bool robot_geometry = false);
  /// Robots' links as bodies of detection: each link with collision geometry placed at its pose
  /// (request frame), in the collision group of its robot (links of one robot are never paired).
  struct LinkBodies {
    std::vector<core::BodyState> bodies;  ///< id "<robot>/<link>", pose linkPose(link)
    std::vector<const detection::BodyGeometry*> geometry;
    std::vector<int> groups;
    std::size_t shapes = 0, vertices = 0, triangles = 0;
  };
  /// Contacts from the bodies' shapes in `scene` (validated, request frame) and the robots' links
  /// (if any), with a detector of the pool, within the contact limit and options.time_budget.
  detection::DetectedContacts detect(const ComputeResponse::Request& request,
                                     const core::Scene& scene, const core::SolverOptions& options,
                                     double contact_tolerance, const LinkBodies* links = nullptr);

  /// Detectors keep FCL objects between calls but are not thread-safe: each request borrows one.
  std::unique_ptr<detection::ContactDetector> acquireDetector();
  void releaseDetector(std::unique_ptr<detection::ContactDetector> detector);

  /// Read once at construction; default_options_ and contact_tolerance_ start from them and follow
  /// dynamic_reconfigure.
  const ServerParameters parameters_;
  mutable std::mutex options_mutex_;  // guards default_options_ and contact_tolerance_
  core::SolverOptions default_options_;
  double contact_tolerance_;  ///< [m]
  ros::Duration tf_timeout_;
  std::mutex detectors_mutex_;
  std::vector<std::unique_ptr<detection::ContactDetector>> idle_detectors_;
  std::vector<std::unique_ptr<ServedRobot>> robots_;  // ~robots, in order
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

  // Diagnostics: totals since start and the state at the last diagnostics update.
  struct Statistics {
    std::uint64_t calls = 0;      // service calls (compute, compute_batch and the episodes')
    std::uint64_t scenes = 0;     // scenes solved or rejected (1 per compute call)
    std::uint64_t failures = 0;   // scenes answered with success = false
    double solve_time = 0.0;      // [s] total solver time
    double max_solve_time = 0.0;  // [s] largest per-call solver time since the last update
    std::uint64_t calls_at_update = 0;
    std::uint64_t failures_at_update = 0;
    ros::WallTime last_update;
  };
  std::mutex statistics_mutex_;
  Statistics statistics_;
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  ros::WallTimer diagnostics_timer_;
  std::unique_ptr<dynamic_reconfigure::Server<SolverConfig>> reconfigure_server_;
};

}  // namespace collision_response
