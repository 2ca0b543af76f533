#include "collision_response/ros/collision_response_server.h"

#include <collision_response/CollisionResponse.h>
#include <collision_response/SolverConfig.h>
#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <tf2_eigen/tf2_eigen.h>

#include <algorithm>
#include <chrono>
#include <stdexcept>

#include "collision_response/collision_solver.h"
#include "collision_response/errors.h"
#include "collision_response/ros/message_conversion.h"
#include "collision_response/validation.h"

namespace collision_response {
namespace {

template <typename T>
T readParam(const ros::NodeHandle& node, const std::string& name, T value) {
  node.param(name, value, value);
  return value;
}

std::size_t positiveSize(const ros::NodeHandle& node, const std::string& name, int fallback) {
  const int value = readParam(node, name, fallback);
  if (value <= 0)
    throw std::invalid_argument("~" + name + " must be positive, got " + std::to_string(value));
  return static_cast<std::size_t>(value);
}

double numberParam(const XmlRpc::XmlRpcValue& value, const std::string& field) {
  if (value.getType() == XmlRpc::XmlRpcValue::TypeDouble) return static_cast<double>(value);
  if (value.getType() == XmlRpc::XmlRpcValue::TypeInt) return static_cast<int>(value);
  throw std::invalid_argument(field + " must be a number");
}

// ~materials: a list of {a, b, restitution, static_friction, dynamic_friction}.
core::MaterialTable readMaterials(const ros::NodeHandle& node) {
  core::MaterialTable table;
  XmlRpc::XmlRpcValue list;
  if (!node.getParam("materials", list)) return table;
  if (list.getType() != XmlRpc::XmlRpcValue::TypeArray)
    throw std::invalid_argument("~materials must be a list of {a, b, restitution, ...}");
  for (int i = 0; i < list.size(); ++i) {
    const std::string field = "~materials[" + std::to_string(i) + "]";
    XmlRpc::XmlRpcValue& entry = list[i];
    if (entry.getType() != XmlRpc::XmlRpcValue::TypeStruct || !entry.hasMember("a") ||
        !entry.hasMember("b") || entry["a"].getType() != XmlRpc::XmlRpcValue::TypeString ||
        entry["b"].getType() != XmlRpc::XmlRpcValue::TypeString) {
      throw std::invalid_argument(field + " must have string members a and b");
    }
    for (const auto& [name, value] : entry) {
      if (name != "a" && name != "b" && name != "restitution" && name != "static_friction" &&
          name != "dynamic_friction") {
        throw std::invalid_argument(field + " has an unknown member '" + name +
                                    "' (a, b, restitution, static_friction, dynamic_friction)");
      }
    }
    core::ContactMaterial material;
    const auto member = [&](const char* name, double& out) {
      if (entry.hasMember(name)) out = numberParam(entry[name], field + "." + name);
    };
    member("restitution", material.restitution);
    member("static_friction", material.static_friction);
    member("dynamic_friction", material.dynamic_friction);
    try {
      table.set(static_cast<std::string>(entry["a"]), static_cast<std::string>(entry["b"]),
                material, field);
    } catch (const core::InvalidInput& e) {
      throw std::invalid_argument(e.what());
    }
  }
  return table;
}

// The core numbers the request's contacts and the detected ones together: a field
// "contacts[k]..." with k past the request's `given` contacts names detected_contacts[k - given].
// The index k of such a field, or npos for any other field.
std::size_t contactIndex(const std::string& field) {
  if (field.rfind("contacts[", 0) != 0) return std::string::npos;
  return std::stoul(field.substr(9, field.find(']') - 9));
}

bool isDetectedContact(const std::string& field, std::size_t given) {
  const std::size_t k = contactIndex(field);
  return k != std::string::npos && k >= given;
}

std::string detectedContactField(const core::InvalidInput& error, std::size_t given) {
  const std::string message = error.what();
  if (!isDetectedContact(error.field(), given)) return message;
  const std::size_t close = error.field().find(']');
  return "detected_contacts[" + std::to_string(contactIndex(error.field()) - given) + "]" +
         message.substr(close + 1);
}

}  // namespace

CollisionResponseServer::CollisionResponseServer(ros::NodeHandle node, ros::NodeHandle private_node)
    : tf_listener_(tf_buffer_, node) {
  const core::SolverOptions built_in;
  // Default impact law for requests whose options.law is 0.
  const std::string law = readParam<std::string>(private_node, "law", core::toString(built_in.law));
  if (!core::fromString(law, default_options_.law)) {
    throw std::invalid_argument(
        "~law must be 'stronge', 'poisson', 'newton' or 'seed_one_pass', got '" + law + "'");
  }
  // Default method for islands of several contacts.
  const std::string solver =
      readParam<std::string>(private_node, "solver", core::toString(built_in.method));
  if (!core::fromString(solver, default_options_.method)) {
    throw std::invalid_argument("~solver must be 'auto', 'exact' or 'iterative', got '" + solver +
                                "'");
  }
  // Relative tolerance and iteration cap of the iterative solver.
  default_options_.tolerance = readParam(private_node, "tolerance", built_in.tolerance);
  // Ranges as in cfg/Solver.cfg, so that dynamic_reconfigure never clamps a start-up value.
  if (!(default_options_.tolerance >= 0.0 && default_options_.tolerance <= 1.0))
    throw std::invalid_argument("~tolerance must lie in [0, 1]");
  default_options_.integration_tolerance =
      readParam(private_node, "integration_tolerance", built_in.integration_tolerance);
  if (!(default_options_.integration_tolerance >= 1e-15 &&
        default_options_.integration_tolerance <= 1.0)) {
    throw std::invalid_argument("~integration_tolerance must lie in [1e-15, 1]");
  }
  default_options_.max_iterations =
      positiveSize(private_node, "max_iterations", static_cast<int>(built_in.max_iterations));
  if (default_options_.max_iterations > 100000000)
    throw std::invalid_argument("~max_iterations must be at most 100000000");
  // Wall time one request may spend solving [s].
  default_options_.time_budget = readParam(private_node, "time_budget", built_in.time_budget);
  if (!(default_options_.time_budget > 0.0))
    throw std::invalid_argument("~time_budget must be > 0");
  // Request size limits: larger requests are rejected before any work.
  limits_.max_bodies =
      positiveSize(private_node, "max_bodies", static_cast<int>(limits_.max_bodies));
  limits_.max_contacts =
      positiveSize(private_node, "max_contacts", static_cast<int>(limits_.max_contacts));
  // How long a request may wait for a transform [s].
  const double tf_timeout = readParam(private_node, "tf_timeout", 0.1);
  if (!(tf_timeout >= 0.0)) throw std::invalid_argument("~tf_timeout must be >= 0");
  tf_timeout_ = ros::Duration(tf_timeout);
  // Contacts from shapes: default tolerance [m], points per pair of shapes, geometry limits.
  contact_tolerance_ = readParam(private_node, "contact_tolerance", contact_tolerance_);
  if (!(contact_tolerance_ >= 0.0) || !(contact_tolerance_ <= 1.0))
    throw std::invalid_argument("~contact_tolerance must lie in [0, 1] m");
  max_contacts_per_pair_ =
      positiveSize(private_node, "max_contacts_per_pair", static_cast<int>(max_contacts_per_pair_));
  limits_.max_shapes =
      positiveSize(private_node, "max_shapes", static_cast<int>(limits_.max_shapes));
  limits_.max_mesh_vertices =
      positiveSize(private_node, "max_mesh_vertices", static_cast<int>(limits_.max_mesh_vertices));
  limits_.max_mesh_triangles = positiveSize(private_node, "max_mesh_triangles",
                                            static_cast<int>(limits_.max_mesh_triangles));
  // Coefficients of detected contacts per pair of materials.
  materials_ = readMaterials(private_node);

  max_batch_scenes_ = positiveSize(private_node, "max_batch_scenes", 10000);
  // Frame of requests whose header.frame_id is empty (answers, published messages, markers, tf).
  default_frame_ = readParam<std::string>(private_node, "default_frame", default_frame_);
  if (default_frame_.empty()) throw std::invalid_argument("~default_frame must not be empty");
  marker_scales_.impulse = readParam(private_node, "marker_impulse_scale", marker_scales_.impulse);
  marker_scales_.velocity =
      readParam(private_node, "marker_velocity_scale", marker_scales_.velocity);
  if (!(marker_scales_.impulse > 0.0) || !(marker_scales_.velocity > 0.0))
    throw std::invalid_argument("~marker_impulse_scale and ~marker_velocity_scale must be > 0");

  responses_ = private_node.advertise<CollisionResponse>("responses", 10);
  markers_ = private_node.advertise<visualization_msgs::MarkerArray>("markers", 1, true);
  setUpMonitoring(node, private_node);
  // The services last: their callbacks may run at once, on other threads.
  service_ = private_node.advertiseService("compute", &CollisionResponseServer::compute, this);
  batch_service_ =
      private_node.advertiseService("compute_batch", &CollisionResponseServer::computeBatch, this);
  ROS_INFO("collision_response: serving %s (law %s, solver %s)", service_.getService().c_str(),
           core::toString(default_options_.law), core::toString(default_options_.method));
}

core::Scene CollisionResponseServer::toScene(const ComputeResponse::Request& request) const {
  const std::string& request_frame = request.header.frame_id;
  core::Scene scene;
  // Size first, so an oversized request costs no conversion.
  core::checkSize(request.bodies.size(), request.contacts.size(), limits_);
  scene.bodies.reserve(request.bodies.size());
  for (std::size_t i = 0; i < request.bodies.size(); ++i) {
    const BodyState& msg = request.bodies[i];
    core::BodyState state = fromMsg(msg);
    if (!msg.frame_id.empty() && msg.frame_id != request_frame) {
      const std::string field = "bodies[" + std::to_string(i) + "].frame_id";
      geometry_msgs::TransformStamped transform;
      try {
        transform = tf_buffer_.lookupTransform(request_frame, msg.frame_id, request.header.stamp,
                                               tf_timeout_);
      } catch (const tf2::TransformException& e) {
        throw core::InvalidInput(field, "no transform from '" + msg.frame_id + "' to '" +
                                            request_frame + "': " + e.what());
      }
      state = core::transformed(state, tf2::transformToEigen(transform));
    }
    scene.bodies.push_back(std::move(state));
  }
  scene.contacts.reserve(request.contacts.size());
  for (const Contact& contact : request.contacts) scene.contacts.push_back(fromMsg(contact));
  return scene;
}

bool CollisionResponseServer::wantsDetection(const ComputeResponse::Request& request) {
  switch (request.detection.mode) {
    case DetectionOptions::MODE_AUTO:
      return request.contacts.empty() &&
             std::any_of(request.bodies.begin(), request.bodies.end(),
                         [](const BodyState& body) { return hasGeometry(body); });
    case DetectionOptions::MODE_ALWAYS:
      return true;
    case DetectionOptions::MODE_NEVER:
      return false;
    default:
      throw core::InvalidInput("detection.mode", "unknown value " +
                                                     std::to_string(request.detection.mode) +
                                                     " (MODE_AUTO 0, MODE_ALWAYS 1, MODE_NEVER 2)");
  }
}

std::unique_ptr<core::ContactDetector> CollisionResponseServer::acquireDetector() {
  const std::lock_guard<std::mutex> lock(detectors_mutex_);
  if (idle_detectors_.empty()) return std::make_unique<core::ContactDetector>();
  std::unique_ptr<core::ContactDetector> detector = std::move(idle_detectors_.back());
  idle_detectors_.pop_back();
  return detector;
}

void CollisionResponseServer::releaseDetector(std::unique_ptr<core::ContactDetector> detector) {
  const std::lock_guard<std::mutex> lock(detectors_mutex_);
  idle_detectors_.push_back(std::move(detector));
}

core::DetectedContacts CollisionResponseServer::detect(const ComputeResponse::Request& request,
                                                       const core::Scene& scene,
                                                       const core::SolverOptions& options,
                                                       double contact_tolerance) {
  // Limits first, from the messages, so an oversized mesh costs no conversion.
  std::size_t shapes = 0, vertices = 0, triangles = 0;
  for (const BodyState& body : request.bodies) countGeometry(body, shapes, vertices, triangles);
  core::checkGeometrySize(shapes, vertices, triangles, limits_);

  core::DetectionInput input;
  input.options = fromMsg(request.detection, contact_tolerance);
  input.options.max_contacts_per_pair = max_contacts_per_pair_;
  // What the solver would accept, within the request's time budget.
  input.options.max_contacts =
      limits_.max_contacts - std::min(limits_.max_contacts, request.contacts.size());
  input.options.deadline = core::Deadline::in(options.time_budget);
  input.defaults = {request.detection.restitution, request.detection.static_friction,
                    request.detection.dynamic_friction};
  input.geometry.reserve(request.bodies.size());
  input.materials.reserve(request.bodies.size());
  for (std::size_t i = 0; i < request.bodies.size(); ++i) {
    input.geometry.push_back(
        geometryFromMsg(request.bodies[i], "bodies[" + std::to_string(i) + "]"));
    input.materials.push_back(request.bodies[i].material);
  }
  std::unique_ptr<core::ContactDetector> detector = acquireDetector();
  // Back to the pool after a detection; one that threw (its cache half rebuilt) is dropped.
  core::DetectedContacts found =
      core::detectContacts(*detector, scene.bodies, input, materials_, limits_);
  releaseDetector(std::move(detector));
  return found;
}

bool CollisionResponseServer::compute(ComputeResponse::Request& request,
                                      ComputeResponse::Response& response) {
  solve(request, response);
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
  responses_.publish(published);
  // Markers only when someone looks: the hot path does not pay for them.
  if (markers_.getNumSubscribers() > 0)
    markers_.publish(makeMarkers(request, response, marker_scales_));
  return true;
}

void CollisionResponseServer::solve(ComputeResponse::Request& request,
                                    ComputeResponse::Response& response) {
  response.success = false;
  const auto begin = std::chrono::steady_clock::now();  // a timeout reports the time to it
  if (request.header.frame_id.empty()) {
    // The answer, the published message and the markers need a frame RViz and tf can place.
    request.header.frame_id = default_frame_;
    response.warnings.push_back("header.frame_id: empty, taken as ~default_frame '" +
                                default_frame_ + "'");
  }
  try {
    core::Scene scene = toScene(request);
    const Defaults defaults_now = defaults();
    const core::SolverOptions options = fromMsg(request.options, defaults_now.options);
    if (wantsDetection(request)) {
      core::validate(scene, options, limits_);  // detection needs valid poses
      const core::DetectedContacts detected =
          detect(request, scene, options, defaults_now.contact_tolerance);
      response.detected_contacts.reserve(detected.contacts.size());
      for (const core::Contact& contact : detected.contacts)
        response.detected_contacts.push_back(toMsg(contact));
      response.detected_depths = detected.depths;
      scene.contacts.insert(scene.contacts.end(), detected.contacts.begin(),
                            detected.contacts.end());
    }
    const auto start = std::chrono::steady_clock::now();
    const core::CollisionResult result = core::computeResponse(scene, options, limits_);
    response.solve_time =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

    response.bodies.reserve(result.bodies.size());
    for (const core::BodyState& body : result.bodies)
      response.bodies.push_back(toMsg(body, request.header.frame_id));
    response.impulses.reserve(result.impulses.size());
    for (const core::ContactImpulse& impulse : result.impulses)
      response.impulses.push_back(toMsg(impulse));
    for (const core::SolveReport& island : result.islands)
      response.islands.push_back(toMsg(island));
    response.kinetic_energy_before = result.kinetic_energy_before;
    response.kinetic_energy_after = result.kinetic_energy_after;
    for (const core::Warning& warning : result.warnings) {
      // Detected contacts that separate are ordinary (neighbours moving apart); a given one that
      // separates may have its normal flipped.
      if (isDetectedContact(warning.field, request.contacts.size())) continue;
      response.warnings.push_back(warning.text());
    }
    response.success = true;
  } catch (const core::InvalidInput& e) {
    response.message = detectedContactField(e, request.contacts.size());
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
  if (!response.success) {
    response.bodies.clear();
    response.impulses.clear();
    response.islands.clear();
    response.detected_contacts.clear();
    response.detected_depths.clear();
    response.warnings.clear();
  }
}

bool CollisionResponseServer::computeBatch(ComputeBatch::Request& request,
                                           ComputeBatch::Response& response) {
  response.success = false;
  response.solve_time = 0.0;
  if (request.scenes.size() > max_batch_scenes_) {
    response.message = "scenes: " + std::to_string(request.scenes.size()) +
                       " scenes exceed ~max_batch_scenes (" + std::to_string(max_batch_scenes_) +
                       ")";
    recordCalls(1, 0, 0, 0.0, 0.0);
    return true;
  }
  std::size_t failures = 0;
  double max_solve_time = 0.0;
  response.results.resize(request.scenes.size());
  ComputeResponse::Request single;
  ComputeResponse::Response answer;
  for (std::size_t i = 0; i < request.scenes.size(); ++i) {
    Scene& scene = request.scenes[i];
    single.header = scene.header.frame_id.empty() ? request.header : scene.header;
    single.bodies = std::move(scene.bodies);
    single.contacts = std::move(scene.contacts);
    single.options = scene.options;
    single.detection = scene.detection;
    answer = ComputeResponse::Response();
    solve(single, answer);
    SceneResult& result = response.results[i];
    result.success = answer.success;
    if (!answer.success) {
      // A field error reads "scenes[i].bodies[1].inertia.m: ...", anything else "scenes[i]: ...".
      const std::size_t colon = answer.message.find(": ");
      const bool field_error = colon != std::string::npos && colon > 0 &&
                               answer.message.substr(0, colon).find(' ') == std::string::npos;
      result.message =
          "scenes[" + std::to_string(i) + "]" + (field_error ? "." : ": ") + answer.message;
      ++failures;
    }
    result.bodies = std::move(answer.bodies);
    result.impulses = std::move(answer.impulses);
    result.kinetic_energy_before = answer.kinetic_energy_before;
    result.kinetic_energy_after = answer.kinetic_energy_after;
    result.islands = std::move(answer.islands);
    result.detected_contacts = std::move(answer.detected_contacts);
    result.detected_depths = std::move(answer.detected_depths);
    result.warnings = std::move(answer.warnings);
    result.solve_time = answer.solve_time;
    response.solve_time += answer.solve_time;
    max_solve_time = std::max(max_solve_time, answer.solve_time);
  }
  response.success = true;
  recordCalls(1, request.scenes.size(), failures, response.solve_time, max_solve_time);
  return true;
}

CollisionResponseServer::Defaults CollisionResponseServer::defaults() const {
  std::lock_guard<std::mutex> lock(options_mutex_);
  return {default_options_, contact_tolerance_};
}

void CollisionResponseServer::setUpMonitoring(const ros::NodeHandle& node,
                                              const ros::NodeHandle& private_node) {
  // dynamic_reconfigure starts from the validated parameters: write them back first so that the
  // server's first callback (with the values it reads from the parameter server) changes nothing.
  ros::NodeHandle reconfigure_node(private_node);
  reconfigure_node.setParam("law", std::string(core::toString(default_options_.law)));
  reconfigure_node.setParam("solver", std::string(core::toString(default_options_.method)));
  reconfigure_node.setParam("tolerance", default_options_.tolerance);
  reconfigure_node.setParam("max_iterations", static_cast<int>(default_options_.max_iterations));
  reconfigure_node.setParam("integration_tolerance", default_options_.integration_tolerance);
  reconfigure_node.setParam("contact_tolerance", contact_tolerance_);
  reconfigure_server_ = std::make_unique<dynamic_reconfigure::Server<SolverConfig>>(private_node);
  reconfigure_server_->setCallback(
      [this](SolverConfig& config, uint32_t level) { reconfigure(config, level); });

  statistics_.last_update = ros::WallTime::now();
  diagnostics_ = std::make_unique<diagnostic_updater::Updater>(node, private_node,
                                                               private_node.getNamespace());
  diagnostics_->setHardwareID("none");
  diagnostics_->add("solver", this, &CollisionResponseServer::diagnose);
  diagnostics_timer_ = private_node.createWallTimer(
      ros::WallDuration(1.0), [this](const ros::WallTimerEvent&) { diagnostics_->force_update(); });
}

CollisionResponseServer::~CollisionResponseServer() {
  // Callbacks first (shutdown waits for one in progress), then the members they use.
  service_.shutdown();
  batch_service_.shutdown();
  diagnostics_timer_.stop();
  reconfigure_server_.reset();
}

void CollisionResponseServer::reconfigure(SolverConfig& config, uint32_t /*level*/) {
  std::lock_guard<std::mutex> lock(options_mutex_);
  core::SolverOptions options = default_options_;
  // String enums are not enforced by dynamic_reconfigure: an unknown name keeps the old value.
  if (!core::fromString(config.law, options.law)) {
    ROS_WARN("collision_response: reconfigure: unknown law '%s', keeping '%s'", config.law.c_str(),
             core::toString(options.law));
    config.law = core::toString(options.law);
  }
  if (!core::fromString(config.solver, options.method)) {
    ROS_WARN("collision_response: reconfigure: unknown solver '%s', keeping '%s'",
             config.solver.c_str(), core::toString(options.method));
    config.solver = core::toString(options.method);
  }
  options.tolerance = config.tolerance;
  options.max_iterations = static_cast<std::size_t>(std::max(1, config.max_iterations));
  options.integration_tolerance = config.integration_tolerance;
  default_options_ = options;
  contact_tolerance_ = config.contact_tolerance;
  ROS_INFO(
      "collision_response: solver defaults: law %s, solver %s, tolerance %g, max_iterations "
      "%zu, integration_tolerance %g, contact_tolerance %g m",
      core::toString(options.law), core::toString(options.method), options.tolerance,
      options.max_iterations, options.integration_tolerance, contact_tolerance_);
}

void CollisionResponseServer::recordCalls(std::size_t calls, std::size_t scenes,
                                          std::size_t failures, double solve_time,
                                          double max_solve_time) {
  std::lock_guard<std::mutex> lock(statistics_mutex_);
  statistics_.calls += calls;
  statistics_.scenes += scenes;
  statistics_.failures += failures;
  statistics_.solve_time += solve_time;
  statistics_.max_solve_time = std::max(statistics_.max_solve_time, max_solve_time);
}

void CollisionResponseServer::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::lock_guard<std::mutex> lock(statistics_mutex_);
  Statistics& s = statistics_;
  const ros::WallTime now = ros::WallTime::now();
  const double period = std::max(1e-9, (now - s.last_update).toSec());
  const double rate = static_cast<double>(s.calls - s.calls_at_update) / period;
  const std::uint64_t new_failures = s.failures - s.failures_at_update;
  if (new_failures == 0) {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "serving");
  } else {
    status.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "%lu failed scenes in the last %.1f s",
                    static_cast<unsigned long>(new_failures), period);
  }
  status.add("call rate [1/s]", rate);
  status.add("calls", s.calls);
  status.add("scenes", s.scenes);
  status.add("failures", s.failures);
  status.add("mean solver time per scene [s]",
             s.scenes > 0 ? s.solve_time / static_cast<double>(s.scenes) : 0.0);
  status.add("max solver time per call since last update [s]", s.max_solve_time);
  s.calls_at_update = s.calls;
  s.failures_at_update = s.failures;
  s.max_solve_time = 0.0;
  s.last_update = now;
}

}  // namespace collision_response
