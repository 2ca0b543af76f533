#pragma once

#include <collision_response/ComputeResponse.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <memory>
#include <mutex>
#include <vector>

#include "collision_response/contact_detection.h"
#include "collision_response/detected_contacts.h"
#include "collision_response/materials.h"
#include "collision_response/scene.h"
#include "collision_response/solver_options.h"

namespace collision_response {

/// The ROS face of the core library: serves ~compute, publishes every successful answer on
/// ~responses, and transforms bodies given in other frames into the request frame with tf2.
///
/// Parameters (private namespace, read once here):
///   ~law             "stronge" | "poisson" | "newton" | "seed_one_pass": default impact law
///   ~solver          "auto" | "exact" | "iterative": default method for islands of contacts
///   ~tolerance       relative tolerance of the iterative solver
///   ~max_iterations  iteration cap of the iterative solver
///   ~integration_tolerance  relative error of the impulse-space integration
///   ~max_bodies      larger requests are rejected
///   ~max_contacts    larger requests are rejected
///   ~time_budget     [s] wall time one request may spend solving; past it the call fails
///   ~tf_timeout      [s] how long to wait for a transform
///   ~contact_tolerance      [m] default of DetectionOptions.contact_tolerance
///   ~max_contacts_per_pair  contact points kept per pair of shapes
///   ~max_shapes, ~max_mesh_vertices, ~max_mesh_triangles  geometry limits of a request
///   ~materials       list of {a, b, restitution, static_friction, dynamic_friction}: the
///                    coefficients of detected contacts between bodies of materials a and b
class CollisionResponseServer {
 public:
  /// Throws std::invalid_argument for a bad parameter value.
  CollisionResponseServer(ros::NodeHandle node, ros::NodeHandle private_node);

  /// The service callback: always answers (returns true); failures are success = false with a
  /// message naming the field.
  bool compute(ComputeResponse::Request& request, ComputeResponse::Response& response);

 private:
  /// Request to core scene in the request frame (tf2 look-ups for bodies in other frames).
  core::Scene toScene(const ComputeResponse::Request& request) const;
  /// Whether the request's contacts are to be found from the bodies' shapes (detection.mode).
  static bool wantsDetection(const ComputeResponse::Request& request);
  /// Contacts from the bodies' shapes in `scene` (validated, request frame), with a detector of
  /// the pool.
  core::DetectedContacts detect(const ComputeResponse::Request& request, const core::Scene& scene);

  /// Detectors keep FCL objects between calls but are not thread-safe: each request borrows one.
  std::unique_ptr<core::ContactDetector> acquireDetector();
  void releaseDetector(std::unique_ptr<core::ContactDetector> detector);

  core::SolverOptions default_options_;
  core::RequestLimits limits_;
  ros::Duration tf_timeout_;
  double contact_tolerance_ = 1e-3;
  std::size_t max_contacts_per_pair_ = 8;
  core::MaterialTable materials_;
  std::mutex detectors_mutex_;
  std::vector<std::unique_ptr<core::ContactDetector>> idle_detectors_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  ros::Publisher responses_;
  ros::ServiceServer service_;
};

}  // namespace collision_response
