#include "collision_response/ros/collision_response_server.h"

// The callbacks of CollisionResponseServer (~compute, ~compute_batch; the episodes' are in
// episode_service.cpp), the robots it serves and its detector pool. A request is assembled by
// request_assembly.h; defaults, call records and diagnostics are ServerMonitoring's.
#include <collision_response/CollisionResponse.h>
#include <collision_response/Episode.h>

#include <algorithm>
#include <chrono>
#include <optional>

#include "collision_response/core/body_impact_derivatives.h"
#include "collision_response/core/body_response.h"
#include "collision_response/core/compute_response.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/impact_derivatives.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/validation.h"
#include "collision_response/robot/joint_position_coordinates.h"
#include "collision_response/ros/message_conversion.h"
#include "collision_response/ros/robot_conversion.h"
#include "collision_response/ros/robot_uncertainty.h"
#include "collision_response/ros/uncertainty_conversion.h"

namespace collision_response {
namespace {

// The core numbers the request's contacts and the detected ones together: a path starting
// "contacts[k]" with k past the request's `given` contacts names detected_contacts[k - given].
// The index k of such a first segment, or npos for any other.
std::size_t contactIndex(const std::string& first_segment) {
  if (first_segment.rfind("contacts[", 0) != 0) return std::string::npos;
  return std::stoul(first_segment.substr(9, first_segment.find(']') - 9));
}

bool isDetectedContact(const std::string& first_segment, std::size_t given) {
  const std::size_t k = contactIndex(first_segment);
  return k != std::string::npos && k >= given;
}

// The error as the request names the value: detected contacts as detected_contacts[i].
core::InvalidInput inRequestTerms(const core::InvalidInput& error, std::size_t given) {
  const std::string& first = error.path().front();
  if (!isDetectedContact(first, given)) return error;
  return error.withFirstSegment("detected_contacts[" + std::to_string(contactIndex(first) - given) +
                                "]");
}

// The warning's text as the request names the value (detected contacts as detected_contacts[i]).
std::string inRequestTerms(const core::Warning& warning, std::size_t given) {
  const std::size_t end = warning.field.find_first_of(".");
  const std::string first = warning.field.substr(0, end);
  if (!isDetectedContact(first, given)) return warning.text();
  const std::string rest = end == std::string::npos ? "" : warning.field.substr(end);
  return "detected_contacts[" + std::to_string(contactIndex(first) - given) + "]" + rest + ": " +
         warning.reason;
}

// The answer of a failed request: no partial results (message and solve_time stay).
void clearAnswer(ComputeResponse::Response& response) {
  response.bodies.clear();
  response.impulses.clear();
  response.islands.clear();
  response.detected_contacts.clear();
  response.detected_depths.clear();
  response.warnings.clear();
  response.robots.clear();
  response.effective_masses.clear();
  response.reflected_masses_a.clear();
  response.reflected_masses_b.clear();
  response.approach_speeds.clear();
  response.transferred_energies.clear();
  response.derivatives = ImpactDerivatives();
  response.outcome_distribution = OutcomeDistribution();
}

// A batch's scene as a single ~compute request (its contents moved out of `scene`); a scene without
// a frame takes the batch's header.
ComputeResponse::Request singleRequest(Scene& scene, const std_msgs::Header& batch_header) {
  ComputeResponse::Request single;
  single.header = scene.header.frame_id.empty() ? batch_header : scene.header;
  single.bodies = std::move(scene.bodies);
  single.contacts = std::move(scene.contacts);
  single.options = scene.options;
  single.detection = scene.detection;
  single.robots = std::move(scene.robots);
  single.uncertainties = std::move(scene.uncertainties);
  return single;
}

// A single request's answer moved into a batch's result (success and message are the caller's).
void moveAnswer(ComputeResponse::Response& answer, SceneResult& result) {
  result.bodies = std::move(answer.bodies);
  result.impulses = std::move(answer.impulses);
  result.kinetic_energy_before = answer.kinetic_energy_before;
  result.kinetic_energy_after = answer.kinetic_energy_after;
  result.islands = std::move(answer.islands);
  result.detected_contacts = std::move(answer.detected_contacts);
  result.detected_depths = std::move(answer.detected_depths);
  result.warnings = std::move(answer.warnings);
  result.solve_time = answer.solve_time;
  result.robots = std::move(answer.robots);
  result.effective_masses = std::move(answer.effective_masses);
  result.reflected_masses_a = std::move(answer.reflected_masses_a);
  result.reflected_masses_b = std::move(answer.reflected_masses_b);
  result.approach_speeds = std::move(answer.approach_speeds);
  result.transferred_energies = std::move(answer.transferred_energies);
  result.derivatives = std::move(answer.derivatives);
  result.outcome_distribution = std::move(answer.outcome_distribution);
}

// True if the request asks for an outcome distribution (a method and uncertainties); a warning
// when it gives only one of the two.
bool wantsDistribution(const ComputeResponse::Request& request,
                       const core::UncertaintyOptions& uncertainty,
                       std::vector<std::string>& warnings) {
  if (uncertainty.method == core::UncertaintyMethod::kNone) {
    if (!request.uncertainties.empty())
      warnings.push_back(
          "uncertainties: given but options.uncertainty is none: no distribution computed");
    return false;
  }
  if (request.uncertainties.empty()) {
    warnings.push_back("options.uncertainty: no uncertainties given: no distribution computed");
    return false;
  }
  return true;
}

}  // namespace

ServerParameters CollisionResponseServer::readParameters(const ros::NodeHandle& private_node) {
  XmlRpc::XmlRpcValue values;  // the whole private namespace; none at all: the defaults
  private_node.getParam(private_node.getNamespace(), values);
  return loadServerParameters(values);
}

CollisionResponseServer::CollisionResponseServer(ros::NodeHandle node, ros::NodeHandle private_node)
    : parameters_(readParameters(private_node)),
      tf_timeout_(parameters_.tf_timeout),
      batch_pool_(parameters_.threads),
      tf_listener_(tf_buffer_, node) {
  loadRobots(node);
  responses_ = private_node.advertise<CollisionResponse>("responses", 10);
  markers_ = private_node.advertise<visualization_msgs::MarkerArray>("markers", 1, true);
  episodes_ = private_node.advertise<Episode>("episodes", 10);
  monitoring_ = std::make_unique<ServerMonitoring>(
      node, private_node, SolverDefaults{parameters_.solver, parameters_.contact_tolerance});
  // The services last: their callbacks may run at once, on other threads.
  service_ = private_node.advertiseService("compute", &CollisionResponseServer::compute, this);
  batch_service_ =
      private_node.advertiseService("compute_batch", &CollisionResponseServer::computeBatch, this);
  episode_service_ = private_node.advertiseService("compute_episode",
                                                   &CollisionResponseServer::computeEpisode, this);
  episode_batch_service_ = private_node.advertiseService(
      "compute_episode_batch", &CollisionResponseServer::computeEpisodeBatch, this);
  const core::SolverOptions options = defaults().options;
  ROS_INFO("collision_response: serving %s (law %s, solver %s)", service_.getService().c_str(),
           core::toString(options.law), core::toString(options.method));
}

void CollisionResponseServer::loadRobots(ros::NodeHandle& node) {
  for (std::size_t i = 0; i < parameters_.robots.size(); ++i) {
    const RobotParameters& entry = parameters_.robots[i];
    const std::string field = "~robots[" + std::to_string(i) + "]";
    std::string urdf;
    if (!node.getParam(entry.description_param, urdf)) {
      throw core::InvalidInput(
          field + ".description_param",
          "no string parameter '" + entry.description_param + "' holding the robot's URDF");
    }
    robots_.push_back(std::make_unique<ServedRobot>(entry, urdf, field));
    ServedRobot* robot = robots_.back().get();
    joint_state_subscribers_.push_back(node.subscribe<sensor_msgs::JointState>(
        entry.joint_states_topic, 10, [robot](const sensor_msgs::JointState::ConstPtr& message) {
          robot->jointStates().update(*message, ros::Time::now());
        }));
    ROS_INFO("collision_response: robot '%s' (%d joints, %s base) from %s, joint states on %s",
             entry.name.c_str(), robot->model().jointCount(), entry.floating ? "floating" : "fixed",
             entry.description_param.c_str(), entry.joint_states_topic.c_str());
  }
}

std::unique_ptr<detection::ContactDetector> CollisionResponseServer::acquireDetector() {
  const std::lock_guard<std::mutex> lock(detectors_mutex_);
  if (idle_detectors_.empty()) return std::make_unique<detection::ContactDetector>();
  std::unique_ptr<detection::ContactDetector> detector = std::move(idle_detectors_.back());
  idle_detectors_.pop_back();
  return detector;
}

void CollisionResponseServer::releaseDetector(
    std::unique_ptr<detection::ContactDetector> detector) {
  const std::lock_guard<std::mutex> lock(detectors_mutex_);
  idle_detectors_.push_back(std::move(detector));
}

detection::DetectedContacts CollisionResponseServer::detect(const ComputeResponse::Request& request,
                                                            const core::Scene& scene,
                                                            const core::SolverOptions& options,
                                                            double contact_tolerance,
                                                            const LinkBodies* links) {
  // Limits first, from the messages, so an oversized mesh costs no conversion.
  std::size_t shapes = 0, vertices = 0, triangles = 0;
  for (const BodyState& body : request.bodies) countGeometry(body, shapes, vertices, triangles);
  if (links != nullptr) {
    shapes += links->shapes;
    vertices += links->vertices;
    triangles += links->triangles;
  }
  core::checkGeometrySize(shapes, vertices, triangles, parameters_.limits);

  detection::DetectionInput input =
      detectionInputFromMsg(request.bodies, request.detection, contact_tolerance);
  input.options.max_contacts_per_pair = parameters_.max_contacts_per_pair;
  // What the solver would accept, within the request's time budget.
  input.options.max_contacts = parameters_.limits.max_contacts -
                               std::min(parameters_.limits.max_contacts, request.contacts.size());
  input.options.deadline = core::Deadline::in(options.time_budget);
  const std::vector<core::BodyState>* bodies = &scene.bodies;
  std::vector<core::BodyState> with_links;
  if (links != nullptr && !links->bodies.empty()) {
    with_links = scene.bodies;
    with_links.insert(with_links.end(), links->bodies.begin(), links->bodies.end());
    bodies = &with_links;
    for (const detection::BodyGeometry* geometry : links->geometry) {
      input.geometry.push_back(*geometry);
      input.materials.emplace_back();  // the request's detection coefficients
    }
    input.collision_groups.assign(scene.bodies.size(), -1);
    input.collision_groups.insert(input.collision_groups.end(), links->groups.begin(),
                                  links->groups.end());
  }
  std::unique_ptr<detection::ContactDetector> detector = acquireDetector();
  // Back to the pool after a detection; one that threw (its cache half rebuilt) is dropped.
  detection::DetectedContacts found = detection::detectContacts(
      *detector, *bodies, input, parameters_.materials, parameters_.limits);
  releaseDetector(std::move(detector));
  return found;
}

bool CollisionResponseServer::compute(ComputeResponse::Request& request,
                                      ComputeResponse::Response& response) {
  // Markers only when someone looks: the hot path does not pay for them.
  const bool draw = markers_.getNumSubscribers() > 0;
  std::vector<ContactLinkFrame> link_frames;
  solve(request, response, &batch_pool_, draw ? &link_frames : nullptr);
  recordCalls(1, 1, response.success ? 0 : 1, response.solve_time, response.solve_time);
  if (!response.success) return true;
  CollisionResponse published;
  published.header = request.header;
  published.bodies = response.bodies;
  published.contacts = request.contacts;
  published.contacts.insert(published.contacts.end(), response.detected_contacts.begin(),
                            response.detected_contacts.end());
  published.impulses = response.impulses;
  published.kinetic_energy_before = response.kinetic_energy_before;
  published.kinetic_energy_after = response.kinetic_energy_after;
  published.robots = response.robots;
  responses_.publish(published);
  if (draw)
    markers_.publish(makeMarkers(request, response, parameters_.marker_scales, link_frames));
  return true;
}

std::optional<core::InvalidInput> CollisionResponseServer::solve(
    ComputeResponse::Request& request, ComputeResponse::Response& response,
    core::WorkerPool* sampling_pool, std::vector<ContactLinkFrame>* link_frames) {
  std::optional<core::InvalidInput> field_error;
  response.success = false;
  const auto begin = std::chrono::steady_clock::now();  // a timeout reports the time to it
  if (request.header.frame_id.empty()) {
    // The answer, the published message and the markers need a frame RViz and tf can place.
    request.header.frame_id = parameters_.default_frame;
    response.warnings.push_back("header.frame_id: empty, taken as ~default_frame '" +
                                parameters_.default_frame + "'");
  }
  try {
    core::Scene scene = toScene(request);
    const Defaults defaults_now = defaults();
    const core::SolverOptions options = fromMsg(request.options, defaults_now.options);
    // Each value is checked once: the bodies and given contacts before detection (which needs
    // valid poses), the detected contacts after it.
    core::SceneValidator validator(scene, options, parameters_.limits);
    if (involvesRobots(request, robots_)) {
      solveWithRobots(request, response, scene, validator, options, sampling_pool, link_frames);
      response.success = true;
      return field_error;
    }
    solveRigid(request, response, scene, validator, options, defaults_now.contact_tolerance,
               sampling_pool);
    response.success = true;
  } catch (const core::InvalidInput& e) {
    field_error = inRequestTerms(e, request.contacts.size());
    response.message = field_error->what();
    ROS_DEBUG("collision_response: rejected request: %s", response.message.c_str());
  } catch (const core::SolverTimeout& e) {
    response.message = e.what();
    response.solve_time =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
    ROS_WARN("collision_response: %s", e.what());
  } catch (const std::exception& e) {
    response.message = std::string("internal error: ") + e.what();
    ROS_ERROR("collision_response: %s", response.message.c_str());
  }
  if (!response.success) clearAnswer(response);
  return field_error;
}

void CollisionResponseServer::solveRigid(const ComputeResponse::Request& request,
                                         ComputeResponse::Response& response, core::Scene& scene,
                                         core::SceneValidator& validator,
                                         const core::SolverOptions& options,
                                         double contact_tolerance,
                                         core::WorkerPool* sampling_pool) {
  validator.checkContacts(scene);
  if (wantsDetection(request)) {
    const detection::DetectedContacts detected = detect(request, scene, options, contact_tolerance);
    response.detected_contacts.reserve(detected.contacts.size());
    for (const core::Contact& contact : detected.contacts)
      response.detected_contacts.push_back(toMsg(contact));
    response.detected_depths = detected.depths;
    scene.contacts.insert(scene.contacts.end(), detected.contacts.begin(), detected.contacts.end());
    // Their bodies by index, as detection paired them: no id is looked up.
    validator.checkContacts(scene, detected.bodies);
  }
  const auto start = std::chrono::steady_clock::now();
  core::CollisionResult result;
  if (request.options.joint_position_derivatives) {
    response.warnings.push_back(
        "options.joint_position_derivatives: ignored: the request has no robot");
  }
  if (request.options.derivatives) {
    // The prediction comes with its Jacobians (validated once more by the library: cheap next to
    // the 2 to 4 solves per column its finite differences may take).
    core::ImpactDerivatives derivatives =
        core::computeImpactDerivatives(scene, options, parameters_.limits);
    response.derivatives = toMsg(derivatives);
    result = std::move(derivatives.result);
  } else {
    result = core::computeValidatedResponse(scene, validator.contactBodies(), options);
  }
  response.solve_time =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  response.bodies.reserve(result.bodies.size());
  for (const core::BodyState& body : result.bodies)
    response.bodies.push_back(toMsg(body, request.header.frame_id));
  response.impulses.reserve(result.impulses.size());
  for (const core::ContactImpulse& impulse : result.impulses)
    response.impulses.push_back(toMsg(impulse));
  for (const core::SolveReport& island : result.islands) response.islands.push_back(toMsg(island));
  response.kinetic_energy_before = result.kinetic_energy_before;
  response.kinetic_energy_after = result.kinetic_energy_after;
  for (const core::Warning& warning : result.warnings) {
    // Detected contacts that separate are ordinary (neighbours moving apart); a given one that
    // separates may have its normal flipped.
    if (warning.kind == core::Warning::Kind::kSeparating &&
        isDetectedContact(warning.field.substr(0, warning.field.find('.')),
                          request.contacts.size()))
      continue;
    response.warnings.push_back(inRequestTerms(warning, request.contacts.size()));
  }
  solveUncertainty(request, response, scene, options, sampling_pool);
}

void CollisionResponseServer::solveUncertainty(const ComputeResponse::Request& request,
                                               ComputeResponse::Response& response,
                                               const core::Scene& scene,
                                               const core::SolverOptions& options,
                                               core::WorkerPool* sampling_pool) {
  const core::UncertaintyOptions uncertainty = uncertaintyOptions(request.options);
  if (!wantsDistribution(request, uncertainty, response.warnings)) return;
  const auto start = std::chrono::steady_clock::now();
  const core::OutcomeDistribution outcome =
      core::computeOutcomeDistribution(scene, fromMsg(request.uncertainties), options, uncertainty,
                                       sampling_pool, parameters_.limits);
  response.solve_time +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  response.outcome_distribution = toMsg(outcome);
  for (const core::Warning& warning : outcome.warnings)
    response.warnings.push_back(inRequestTerms(warning, request.contacts.size()));
}

void CollisionResponseServer::solveWithRobots(const ComputeResponse::Request& request,
                                              ComputeResponse::Response& response,
                                              core::Scene& scene, core::SceneValidator& validator,
                                              const core::SolverOptions& options,
                                              core::WorkerPool* sampling_pool,
                                              std::vector<ContactLinkFrame>* link_frames) {
  // The robots (those listed, then those only named by contacts), each at its state.
  std::vector<RequestRobot> robots = requestRobots(request, scene.bodies, robots_);
  placeRobots(robots, request.header, tf_buffer_, tf_timeout_, ros::Time::now(),
              parameters_.joint_state_timeout, response.warnings);
  const RobotLinkIds link_ids = robotLinkIds(robots);
  validator.addOtherBodyIds(link_ids.ids);
  validator.checkContacts(scene);
  if (wantsDetection(request, anyRobotGeometry(robots)))
    detectWithLinks(request, response, scene, validator, robots, options);

  // Contacts by model index and part: the rigid bodies, then the robots.
  const int rigid_count = static_cast<int>(scene.bodies.size());
  const std::vector<core::ContactPoint> points =
      placeContacts(scene.contacts, validator.contactBodies(), rigid_count, link_ids.robot_link);
  if (link_frames != nullptr) *link_frames = contactLinkFrames(points, robots, rigid_count);
  solveBodyModels(request, response, scene, robots, points, options, sampling_pool);
}

void CollisionResponseServer::detectWithLinks(const ComputeResponse::Request& request,
                                              ComputeResponse::Response& response,
                                              core::Scene& scene, core::SceneValidator& validator,
                                              const std::vector<RequestRobot>& robots,
                                              const core::SolverOptions& options) {
  const LinkBodies links = linkBodies(robots);
  const detection::DetectedContacts detected =
      detect(request, scene, options, defaults().contact_tolerance, &links);
  for (const core::Contact& contact : detected.contacts)
    response.detected_contacts.push_back(toMsg(contact));
  response.detected_depths = detected.depths;
  scene.contacts.insert(scene.contacts.end(), detected.contacts.begin(), detected.contacts.end());
  // Their bodies by index, as detection paired them (a link: its robot and link from here on).
  validator.checkContacts(
      scene, detectedContactBodies(detected.bodies, static_cast<int>(scene.bodies.size()), links));
}

void CollisionResponseServer::solveBodyModels(const ComputeResponse::Request& request,
                                              ComputeResponse::Response& response,
                                              core::Scene& scene, std::vector<RequestRobot>& robots,
                                              const std::vector<core::ContactPoint>& points,
                                              const core::SolverOptions& options,
                                              core::WorkerPool* sampling_pool) {
  const int rigid_count = static_cast<int>(scene.bodies.size());
  std::vector<core::RigidBody> rigid;
  core::makeRigidBodies(scene.bodies, rigid);
  core::setFreeAccelerations(scene.bodies, rigid);  // their wrenches, for resting contacts
  const std::vector<core::BodyModel*> models = bodyModels(rigid, robots);
  double energy_before = 0.0;
  for (const core::BodyState& body : scene.bodies) energy_before += core::kineticEnergy(body);
  for (const RequestRobot& robot : robots) energy_before += robot.energy_before;

  // The outcome distribution first, on copies of the bodies at their pre-impact state.
  double distribution_time = 0.0;
  std::vector<core::Warning> distribution_warnings;
  const core::UncertaintyOptions uncertainty = uncertaintyOptions(request.options);
  if (wantsDistribution(request, uncertainty, response.warnings)) {
    const auto begin = std::chrono::steady_clock::now();
    response.outcome_distribution =
        robotOutcomeDistribution(request.uncertainties, rigid, robots, points, options, uncertainty,
                                 sampling_pool, distribution_warnings);
    distribution_time =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
  }

  const auto start = std::chrono::steady_clock::now();
  core::BodyResponse result;
  if (request.options.derivatives) {
    // With its Jacobians (docs/robots.md, "Derivatives of robot impacts").
    // The joint positions' columns on request (options.joint_position_derivatives).
    std::vector<core::ConfigurationCoordinate> coordinates;
    std::vector<std::pair<int, int>> coordinate_joints;  // (robot, joint) per coordinate
    if (request.options.joint_position_derivatives) {
      for (std::size_t r = 0; r < robots.size(); ++r) {
        std::vector<int> joints;
        for (core::ConfigurationCoordinate& coordinate :
             robot::jointPositionCoordinates(*robots[r].model, &joints))
          coordinates.push_back(std::move(coordinate));
        for (const int joint : joints) coordinate_joints.emplace_back(static_cast<int>(r), joint);
      }
    }
    core::BodyImpactDerivatives derivatives =
        core::computeBodyImpactDerivatives(models, points, options, coordinates);
    response.derivatives = toMsg(derivatives, rigid_count, robots, coordinate_joints);
    result = std::move(derivatives.result);
  } else {
    if (request.options.joint_position_derivatives) {
      response.warnings.push_back(
          "options.joint_position_derivatives: ignored without options.derivatives");
    }
    result = core::computeBodyResponse(models, points, options);
  }
  response.solve_time =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() +
      distribution_time;

  // The answer: rigid bodies, impulses, islands, effective masses, robots.
  double energy_after = 0.0;
  response.bodies.reserve(scene.bodies.size());
  for (int i = 0; i < rigid_count; ++i) {
    core::BodyState& body = scene.bodies[i];
    if (!body.immovable()) {
      body.linear_velocity = rigid[i].linear_velocity;
      body.angular_velocity = rigid[i].angular_velocity;
    }
    energy_after += core::kineticEnergy(body);
    response.bodies.push_back(toMsg(body, request.header.frame_id));
  }
  response.impulses.reserve(result.impulses.size());
  for (const core::ContactImpulse& impulse : result.impulses)
    response.impulses.push_back(toMsg(impulse));
  for (const core::SolveReport& island : result.islands) response.islands.push_back(toMsg(island));
  response.effective_masses = result.effective_masses;
  for (const core::Warning& warning : result.warnings)
    response.warnings.push_back(inRequestTerms(warning, request.contacts.size()));
  for (const core::Warning& warning : distribution_warnings)
    response.warnings.push_back(inRequestTerms(warning, request.contacts.size()));
  response.robots = robotAnswers(robots, rigid_count, points, result.impulses, request.header);
  addSafetyOutputs(models, points, result.impulses, robots, response);
  for (const RobotResult& robot : response.robots) energy_after += robot.kinetic_energy_after;
  response.kinetic_energy_before = energy_before;
  response.kinetic_energy_after = energy_after;
}

bool CollisionResponseServer::refuseOversizedBatch(std::size_t scenes, std::string& message) {
  if (scenes <= parameters_.max_batch_scenes) return false;
  message = "scenes: " + std::to_string(scenes) + " scenes exceed ~max_batch_scenes (" +
            std::to_string(parameters_.max_batch_scenes) + ")";
  recordCalls(1, 0, 0, 0.0, 0.0);
  return true;
}

bool CollisionResponseServer::computeBatch(ComputeBatch::Request& request,
                                           ComputeBatch::Response& response) {
  response.success = false;
  response.solve_time = 0.0;
  if (refuseOversizedBatch(request.scenes.size(), response.message)) return true;
  // The scenes are independent: solved across the batch pool (~threads), each by solve() as a
  // single request, into its own result.
  response.results.resize(request.scenes.size());
  std::vector<char> failed(request.scenes.size(), 0);
  batch_pool_.parallelFor(request.scenes.size(), [&](std::size_t i) {
    ComputeResponse::Request single = singleRequest(request.scenes[i], request.header);
    ComputeResponse::Response answer;
    // A scene's samples run on this thread (sampling_pool nullptr): the batch already occupies
    // the pool, and a worker waiting in a nested parallelFor would help no other scene.
    const std::optional<core::InvalidInput> field_error = solve(single, answer, nullptr);
    SceneResult& result = response.results[i];
    result.success = answer.success;
    if (!answer.success) {
      // "scenes[i].bodies[1].inertia.m: ..." for a field, "scenes[i]: ..." for anything else.
      const std::string scene_field = "scenes[" + std::to_string(i) + "]";
      result.message = field_error ? field_error->prefixed(scene_field).what()
                                   : scene_field + ": " + answer.message;
      failed[i] = 1;
    }
    moveAnswer(answer, result);
  });
  std::size_t failures = 0;
  double max_solve_time = 0.0;
  for (std::size_t i = 0; i < response.results.size(); ++i) {
    failures += failed[i];
    response.solve_time += response.results[i].solve_time;
    max_solve_time = std::max(max_solve_time, response.results[i].solve_time);
  }
  response.success = true;
  recordCalls(1, request.scenes.size(), failures, response.solve_time, max_solve_time);
  return true;
}

CollisionResponseServer::~CollisionResponseServer() {
  // Callbacks first (shutdown waits for one in progress), then the members they use.
  service_.shutdown();
  batch_service_.shutdown();
  episode_service_.shutdown();
  episode_batch_service_.shutdown();
  monitoring_.reset();
}

}  // namespace collision_response
