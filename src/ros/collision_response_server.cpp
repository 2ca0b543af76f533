#include "collision_response/ros/collision_response_server.h"

#include <collision_response/CollisionResponse.h>
#include <tf2_eigen/tf2_eigen.h>

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
  if (!(default_options_.tolerance >= 0.0)) throw std::invalid_argument("~tolerance must be >= 0");
  default_options_.integration_tolerance =
      readParam(private_node, "integration_tolerance", built_in.integration_tolerance);
  if (!(default_options_.integration_tolerance > 0.0)) {
    throw std::invalid_argument("~integration_tolerance must be > 0");
  }
  default_options_.max_iterations =
      positiveSize(private_node, "max_iterations", static_cast<int>(built_in.max_iterations));
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

  responses_ = private_node.advertise<CollisionResponse>("responses", 10);
  service_ = private_node.advertiseService("compute", &CollisionResponseServer::compute, this);
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
      if (request_frame.empty()) {
        throw core::InvalidInput(
            field,
            "is '" + msg.frame_id + "' but header.frame_id is empty: name the request frame");
      }
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

bool CollisionResponseServer::compute(ComputeResponse::Request& request,
                                      ComputeResponse::Response& response) {
  response.success = false;
  try {
    const core::Scene scene = toScene(request);
    const core::SolverOptions options = fromMsg(request.options, default_options_);
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
    for (const core::IslandReport& island : result.islands)
      response.islands.push_back(toMsg(island));
    response.kinetic_energy_before = result.kinetic_energy_before;
    response.kinetic_energy_after = result.kinetic_energy_after;
    response.success = true;

    CollisionResponse published;
    published.header = request.header;
    published.bodies = response.bodies;
    published.contacts = request.contacts;
    published.impulses = response.impulses;
    published.kinetic_energy_before = response.kinetic_energy_before;
    published.kinetic_energy_after = response.kinetic_energy_after;
    responses_.publish(published);
  } catch (const core::InvalidInput& e) {
    response.message = e.what();
    ROS_DEBUG("collision_response: rejected request: %s", e.what());
  } catch (const core::SolverTimeout& e) {
    response.message = e.what();
    ROS_WARN("collision_response: %s", e.what());
  } catch (const std::exception& e) {
    response.message = std::string("internal error: ") + e.what();
    ROS_ERROR("collision_response: %s", response.message.c_str());
  }
  if (!response.success) {
    response.bodies.clear();
    response.impulses.clear();
    response.islands.clear();
  }
  return true;
}

}  // namespace collision_response
