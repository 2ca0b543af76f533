#include "collision_response/ros/collision_response_server.h"

#include <collision_response/CollisionResponse.h>
#include <collision_response/Episode.h>
#include <collision_response/SolverConfig.h>
#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <tf2_eigen/tf2_eigen.h>

#include <algorithm>
#include <chrono>
#include <optional>
#include <stdexcept>
#include <unordered_set>

#include "collision_response/core/body_response.h"
#include "collision_response/core/compute_response.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/validation.h"
#include "collision_response/ros/message_conversion.h"
#include "collision_response/ros/robot_conversion.h"

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

}  // namespace

ServerParameters CollisionResponseServer::readParameters(const ros::NodeHandle& private_node) {
  XmlRpc::XmlRpcValue values;  // the whole private namespace; none at all: the defaults
  private_node.getParam(private_node.getNamespace(), values);
  return loadServerParameters(values);
}

CollisionResponseServer::CollisionResponseServer(ros::NodeHandle node, ros::NodeHandle private_node)
    : parameters_(readParameters(private_node)),
      default_options_(parameters_.solver),
      contact_tolerance_(parameters_.contact_tolerance),
      tf_timeout_(parameters_.tf_timeout),
      batch_pool_(parameters_.threads),
      tf_listener_(tf_buffer_, node) {
  loadRobots(node);
  responses_ = private_node.advertise<CollisionResponse>("responses", 10);
  markers_ = private_node.advertise<visualization_msgs::MarkerArray>("markers", 1, true);
  episodes_ = private_node.advertise<Episode>("episodes", 10);
  setUpMonitoring(node, private_node);
  // The services last: their callbacks may run at once, on other threads.
  service_ = private_node.advertiseService("compute", &CollisionResponseServer::compute, this);
  batch_service_ =
      private_node.advertiseService("compute_batch", &CollisionResponseServer::computeBatch, this);
  episode_service_ = private_node.advertiseService("compute_episode",
                                                   &CollisionResponseServer::computeEpisode, this);
  episode_batch_service_ = private_node.advertiseService(
      "compute_episode_batch", &CollisionResponseServer::computeEpisodeBatch, this);
  ROS_INFO("collision_response: serving %s (law %s, solver %s)", service_.getService().c_str(),
           core::toString(default_options_.law), core::toString(default_options_.method));
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

ServedRobot* CollisionResponseServer::findRobot(const std::string& name) const {
  for (const auto& robot : robots_)
    if (robot->name() == name) return robot.get();
  return nullptr;
}

bool CollisionResponseServer::involvesRobots(const ComputeResponse::Request& request) const {
  if (!request.robots.empty()) return true;
  if (robots_.empty()) return false;
  const auto names_link = [&](const std::string& id) {
    const std::size_t slash = id.find('/');
    if (slash == std::string::npos || findRobot(id.substr(0, slash)) == nullptr) return false;
    for (const BodyState& body : request.bodies)
      if (body.id == id) return false;
    return true;
  };
  for (const Contact& contact : request.contacts)
    if (names_link(contact.body_a) || names_link(contact.body_b)) return true;
  return false;
}

core::Scene CollisionResponseServer::toScene(const ComputeResponse::Request& request) const {
  const std::string& request_frame = request.header.frame_id;
  core::Scene scene;
  // Size first, so an oversized request costs no conversion.
  core::checkSize(request.bodies.size(), request.contacts.size(), parameters_.limits);
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

bool CollisionResponseServer::wantsDetection(const ComputeResponse::Request& request,
                                             bool robot_geometry) {
  switch (request.detection.mode) {
    case DetectionOptions::MODE_AUTO:
      return request.contacts.empty() &&
             (robot_geometry ||
              std::any_of(request.bodies.begin(), request.bodies.end(),
                          [](const BodyState& body) { return hasGeometry(body); }));
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
  solve(request, response, draw ? &link_frames : nullptr);
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
    std::vector<ContactLinkFrame>* link_frames) {
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
    if (involvesRobots(request)) {
      solveWithRobots(request, response, scene, validator, options, link_frames);
      response.success = true;
      return field_error;
    }
    validator.checkContacts(scene);
    if (wantsDetection(request)) {
      const detection::DetectedContacts detected =
          detect(request, scene, options, defaults_now.contact_tolerance);
      response.detected_contacts.reserve(detected.contacts.size());
      for (const core::Contact& contact : detected.contacts)
        response.detected_contacts.push_back(toMsg(contact));
      response.detected_depths = detected.depths;
      scene.contacts.insert(scene.contacts.end(), detected.contacts.begin(),
                            detected.contacts.end());
      validator.checkContacts(scene);
    }
    const auto start = std::chrono::steady_clock::now();
    const core::CollisionResult result =
        core::computeValidatedResponse(scene, validator.contactBodies(), options);
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
      if (warning.kind == core::Warning::Kind::kSeparating &&
          isDetectedContact(warning.field.substr(0, warning.field.find('.')),
                            request.contacts.size()))
        continue;
      response.warnings.push_back(inRequestTerms(warning, request.contacts.size()));
    }
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
  if (!response.success) {
    response.bodies.clear();
    response.impulses.clear();
    response.islands.clear();
    response.detected_contacts.clear();
    response.detected_depths.clear();
    response.warnings.clear();
    response.robots.clear();
    response.effective_masses.clear();
  }
  return field_error;
}

namespace {

// A robot taking part in a request: the served robot, its message (the request's, or a default one
// for a robot only named by contacts), and its model at the request's state.
struct RequestRobot {
  ServedRobot* served = nullptr;
  RobotState message;
  std::string field;  // "robots[i]", or the first contact naming it
  Eigen::Isometry3d base_pose = Eigen::Isometry3d::Identity();
  std::optional<robot::ArticulatedBody> model;
  Eigen::VectorXd velocity_before;
  double energy_before = 0.0;
};

}  // namespace

void CollisionResponseServer::solveWithRobots(const ComputeResponse::Request& request,
                                              ComputeResponse::Response& response,
                                              core::Scene& scene, core::SceneValidator& validator,
                                              const core::SolverOptions& options,
                                              std::vector<ContactLinkFrame>* link_frames) {
  // The robots: those listed, then those only named by contacts ("<robot>/<link>").
  std::vector<RequestRobot> robots;
  const auto add = [&](ServedRobot* served, const RobotState& message, const std::string& field) {
    robots.emplace_back();
    robots.back().served = served;
    robots.back().message = message;
    robots.back().field = field;
  };
  const auto find_listed = [&](const std::string& name) {
    for (std::size_t r = 0; r < robots.size(); ++r)
      if (robots[r].served->name() == name) return static_cast<int>(r);
    return -1;
  };
  for (std::size_t i = 0; i < request.robots.size(); ++i) {
    const std::string field = "robots[" + std::to_string(i) + "]";
    ServedRobot* served = findRobot(request.robots[i].name);
    if (served == nullptr) {
      throw core::InvalidInput(field + ".name",
                               "names no robot of ~robots ('" + request.robots[i].name + "')");
    }
    if (find_listed(served->name()) >= 0)
      throw core::InvalidInput(field + ".name", "repeats robot '" + served->name() + "'");
    add(served, request.robots[i], field);
  }
  std::unordered_set<std::string> body_ids;
  for (const core::BodyState& body : scene.bodies) body_ids.insert(body.id);
  for (std::size_t c = 0; c < request.contacts.size(); ++c) {
    for (const std::string* id : {&request.contacts[c].body_a, &request.contacts[c].body_b}) {
      const std::size_t slash = id->find('/');
      if (slash == std::string::npos || body_ids.count(*id) > 0) continue;
      ServedRobot* served = findRobot(id->substr(0, slash));
      if (served == nullptr || find_listed(served->name()) >= 0) continue;
      RobotState message;
      message.name = served->name();
      add(served, message, "contacts[" + std::to_string(c) + "]");
    }
  }

  // Each robot at its state: base pose from the request or tf2, joints from the request or the
  // latest joint states.
  const ros::Time now = ros::Time::now();
  std::vector<std::string> link_ids;
  std::vector<std::pair<int, int>> robot_link_of_id;  // (robot, link) of link_ids[k]
  for (std::size_t r = 0; r < robots.size(); ++r) {
    RequestRobot& robot = robots[r];
    if (const std::optional<Eigen::Isometry3d> pose = basePoseFromMsg(robot.message, robot.field)) {
      robot.base_pose = *pose;
    } else {
      const std::string& base_frame = robot.served->baseFrame();
      try {
        robot.base_pose = tf2::transformToEigen(tf_buffer_.lookupTransform(
            request.header.frame_id, base_frame, request.header.stamp, tf_timeout_));
      } catch (const tf2::TransformException& e) {
        throw core::InvalidInput(robot.field + ".base_pose",
                                 "not given, and no transform from '" + base_frame + "' to '" +
                                     request.header.frame_id + "': " + e.what());
      }
    }
    robot.model =
        robotAtRequestState(*robot.served, robot.message, robot.base_pose, now,
                            parameters_.joint_state_timeout, robot.field, &response.warnings);
    robot.velocity_before = robot.model->velocity();
    robot.energy_before = robot.model->kineticEnergy();
    const std::vector<std::string>& ids = robot.served->linkIds();
    for (std::size_t link = 0; link < ids.size(); ++link) {
      link_ids.push_back(ids[link]);
      robot_link_of_id.emplace_back(static_cast<int>(r), static_cast<int>(link));
    }
  }
  validator.addOtherBodyIds(link_ids);
  validator.checkContacts(scene);
  bool robot_geometry = false;
  for (const RequestRobot& robot : robots) robot_geometry |= robot.served->hasGeometry();
  if (wantsDetection(request, robot_geometry)) {
    // The links with collision geometry as bodies of detection, placed by the robots' state. Mass
    // 1 kg (detection pairs no two immovable bodies); detection reads only poses and shapes.
    LinkBodies links;
    for (std::size_t r = 0; r < robots.size(); ++r) {
      const robot::ArticulatedBody& model = *robots[r].model;
      for (int link = 0; link < model.linkCount(); ++link) {
        const detection::BodyGeometry& geometry = robots[r].served->linkGeometry()[link];
        if (geometry.shapes.empty()) continue;
        core::BodyState body;
        body.id = robots[r].served->linkIds()[link];
        body.mass = 1.0;
        body.inertia = Eigen::Matrix3d::Identity();
        const Eigen::Isometry3d pose = model.linkPose(link);
        body.position = pose.translation();
        body.orientation = Eigen::Quaterniond(pose.linear());
        links.bodies.push_back(std::move(body));
        links.geometry.push_back(&geometry);
        links.groups.push_back(static_cast<int>(r));
        links.shapes += geometry.shapes.size();
        for (const detection::Shape& shape : geometry.shapes) {
          links.vertices += shape.vertices.size();
          links.triangles += shape.triangles.size();
        }
      }
    }
    const detection::DetectedContacts detected =
        detect(request, scene, options, defaults().contact_tolerance, &links);
    for (const core::Contact& contact : detected.contacts)
      response.detected_contacts.push_back(toMsg(contact));
    response.detected_depths = detected.depths;
    scene.contacts.insert(scene.contacts.end(), detected.contacts.begin(), detected.contacts.end());
    validator.checkContacts(scene);
  }

  // Body models: the rigid bodies, then the robots; contacts by model index and part.
  const int rigid_count = static_cast<int>(scene.bodies.size());
  std::vector<core::RigidBody> rigid;
  rigid.reserve(scene.bodies.size());
  for (const core::BodyState& body : scene.bodies) {
    rigid.push_back(core::makeRigidBody(body));
    core::setFreeAcceleration(body, rigid.back());  // their wrenches, for resting contacts
  }
  std::vector<core::BodyModel*> models;
  models.reserve(rigid.size() + robots.size());
  for (core::RigidBody& body : rigid) models.push_back(&body);
  for (RequestRobot& robot : robots) models.push_back(&*robot.model);
  const std::vector<core::ContactPoint> points =
      placeContacts(scene.contacts, validator.contactBodies(), rigid_count, robot_link_of_id);
  if (link_frames != nullptr) {
    link_frames->assign(points.size(), ContactLinkFrame());
    for (std::size_t c = 0; c < points.size(); ++c) {
      const bool on_a = points[c].part_a >= 0;
      const int part = on_a ? points[c].part_a : points[c].part_b;
      if (part < 0) continue;
      const robot::ArticulatedBody& model =
          *robots[(on_a ? points[c].body_a : points[c].body_b) - rigid_count].model;
      (*link_frames)[c] = {model.linkName(part), model.linkPose(part)};
    }
  }

  double energy_before = 0.0;
  for (const core::BodyState& body : scene.bodies) energy_before += core::kineticEnergy(body);
  for (const RequestRobot& robot : robots) energy_before += robot.energy_before;

  const auto start = std::chrono::steady_clock::now();
  const core::BodyResponse result = core::computeBodyResponse(models, points, options);
  response.solve_time =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

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
  response.robots.reserve(robots.size());
  for (std::size_t r = 0; r < robots.size(); ++r) {
    const RequestRobot& robot = robots[r];
    response.robots.push_back(toMsg(robot.served->name(), *robot.model, robot.velocity_before,
                                    robot.energy_before, robot.base_pose, request.header));
    const Eigen::VectorXd torques = robot.model->restingContactTorques(
        rigid_count + static_cast<int>(r), points, result.impulses);
    response.robots.back().contact_joint_torques.assign(torques.data(),
                                                        torques.data() + torques.size());
    energy_after += response.robots.back().kinetic_energy_after;
  }
  response.kinetic_energy_before = energy_before;
  response.kinetic_energy_after = energy_after;
}

bool CollisionResponseServer::computeBatch(ComputeBatch::Request& request,
                                           ComputeBatch::Response& response) {
  response.success = false;
  response.solve_time = 0.0;
  if (request.scenes.size() > parameters_.max_batch_scenes) {
    response.message = "scenes: " + std::to_string(request.scenes.size()) +
                       " scenes exceed ~max_batch_scenes (" +
                       std::to_string(parameters_.max_batch_scenes) + ")";
    recordCalls(1, 0, 0, 0.0, 0.0);
    return true;
  }
  // The scenes are independent: solved across the batch pool (~threads), each by solve() as a
  // single request, into its own result.
  response.results.resize(request.scenes.size());
  std::vector<char> failed(request.scenes.size(), 0);
  batch_pool_.parallelFor(request.scenes.size(), [&](std::size_t i) {
    Scene& scene = request.scenes[i];
    ComputeResponse::Request single;
    ComputeResponse::Response answer;
    single.header = scene.header.frame_id.empty() ? request.header : scene.header;
    single.bodies = std::move(scene.bodies);
    single.contacts = std::move(scene.contacts);
    single.options = scene.options;
    single.detection = scene.detection;
    single.robots = std::move(scene.robots);
    const std::optional<core::InvalidInput> field_error = solve(single, answer);
    SceneResult& result = response.results[i];
    result.success = answer.success;
    if (!answer.success) {
      // "scenes[i].bodies[1].inertia.m: ..." for a field, "scenes[i]: ..." for anything else.
      const std::string scene_field = "scenes[" + std::to_string(i) + "]";
      result.message = field_error ? field_error->prefixed(scene_field).what()
                                   : scene_field + ": " + answer.message;
      failed[i] = 1;
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
    result.robots = std::move(answer.robots);
    result.effective_masses = std::move(answer.effective_masses);
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
  reconfigure_node.setParam(
      "multi_contact", std::string(multiContactName(default_options_.simultaneous_impulse_space)));
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
  episode_service_.shutdown();
  episode_batch_service_.shutdown();
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
  if (!multiContactFromName(config.multi_contact, options.simultaneous_impulse_space)) {
    ROS_WARN("collision_response: reconfigure: unknown multi_contact '%s', keeping '%s'",
             config.multi_contact.c_str(), multiContactName(options.simultaneous_impulse_space));
    config.multi_contact = multiContactName(options.simultaneous_impulse_space);
  }
  options.tolerance = config.tolerance;
  options.max_iterations = static_cast<std::size_t>(std::max(1, config.max_iterations));
  options.integration_tolerance = config.integration_tolerance;
  default_options_ = options;
  contact_tolerance_ = config.contact_tolerance;
  ROS_INFO(
      "collision_response: solver defaults: law %s, solver %s, multi_contact %s, tolerance %g, "
      "max_iterations %zu, integration_tolerance %g, contact_tolerance %g m",
      core::toString(options.law), core::toString(options.method),
      multiContactName(options.simultaneous_impulse_space), options.tolerance,
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
