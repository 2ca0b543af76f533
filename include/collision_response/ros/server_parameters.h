#pragma once

#include <xmlrpcpp/XmlRpcValue.h>

#include <cstddef>
#include <string>

#include "collision_response/core/solver_options.h"
#include "collision_response/detection/materials.h"
#include "collision_response/ros/response_markers.h"

namespace collision_response {

/// Everything the node (or the nodelet) reads from its private namespace, with the defaults, in
/// one place (docs/interface.md, "Parameters"). Ranges are core::option_ranges'.
struct ServerParameters {
  /// ~law, ~solver, ~tolerance, ~max_iterations, ~integration_tolerance, ~time_budget [s]: the
  /// defaults of requests whose `options` leave them 0.
  core::SolverOptions solver;
  /// ~max_bodies, ~max_contacts, ~max_shapes, ~max_mesh_vertices, ~max_mesh_triangles: larger
  /// requests are rejected before any work.
  core::RequestLimits limits;
  double tf_timeout = 0.1;                ///< ~tf_timeout [s]: wait for a body's transform
  double contact_tolerance = 1e-3;        ///< ~contact_tolerance [m]: detection's default
  std::size_t max_contacts_per_pair = 8;  ///< ~max_contacts_per_pair: points per pair of shapes
  /// ~materials: [{a, b, restitution, static_friction, dynamic_friction}], coefficients of
  /// detected contacts per pair of materials.
  detection::MaterialTable materials;
  std::size_t max_batch_scenes = 10000;  ///< ~max_batch_scenes: larger batches are rejected
  /// ~marker_impulse_scale [m per N s], ~marker_velocity_scale [m per m/s]: arrow lengths.
  MarkerScales marker_scales;
  std::string default_frame = "world";  ///< ~default_frame: requests with an empty frame
  int threads =
      2;  ///< ~threads: requests served concurrently (the node; a nodelet uses its manager's)
};

/// Reads and checks the parameters from `values`, the private namespace as one XmlRpc struct (what
/// the parameter server returns for it; an invalid value, e.g. no parameter at all, gives the
/// defaults). A parameter that is absent takes its default; one of the wrong type or out of its
/// range throws core::InvalidInput naming it ("~tolerance": never clamped). Needs no ROS master.
ServerParameters loadServerParameters(const XmlRpc::XmlRpcValue& values);

}  // namespace collision_response
