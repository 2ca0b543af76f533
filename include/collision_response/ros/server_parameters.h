#pragma once

#include <xmlrpcpp/XmlRpcValue.h>

#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "collision_response/core/solver_options.h"
#include "collision_response/detection/materials.h"
#include "collision_response/ros/response_markers.h"

namespace collision_response {

/// One entry of ~robots: a robot the node serves as a body of requests (docs/robots.md, "Robots
/// through ROS"). Its model is read from the URDF on the parameter server at start-up.
struct RobotParameters {
  std::string name;  ///< contacts name its links "<name>/<link>"; no '/' in it
  std::string description_param = "/robot_description";  ///< parameter holding the URDF (a string)
  std::string joint_states_topic = "/joint_states";      ///< sensor_msgs/JointState, latest kept
  bool floating = false;  ///< base free (6 more velocity unknowns) or fixed
  /// tf frame whose pose places the URDF root link when a request gives no base pose; empty: the
  /// root link's name (what robot_state_publisher broadcasts).
  std::string base_frame;
  std::vector<std::string> locked_joints;  ///< joints that move with their parent in an impact
  /// Rotor inertia added to a joint's diagonal of M [kg m^2 revolute, kg prismatic], by joint name.
  std::map<std::string, double> armature;
};

/// Everything the node (or the nodelet) reads from its private namespace, with the defaults, in
/// one place (docs/interface.md, "Parameters"). Ranges are core::option_ranges'.
struct ServerParameters {
  /// ~law, ~solver, ~multi_contact ('simultaneous' or 'two_phase':
  /// solver.simultaneous_impulse_space), ~tolerance, ~max_iterations, ~integration_tolerance,
  /// ~time_budget [s]: the defaults of requests whose `options` leave them 0.
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
  /// ~threads [1, 256]: requests served concurrently (the node; a nodelet uses its manager's), and
  /// the threads a batch's scenes are spread over (node and nodelet alike).
  int threads = 2;
  /// ~robots: [{name, description_param, joint_states_topic, floating, base_frame, locked_joints,
  /// armature}], the robots requests may name (none by default).
  std::vector<RobotParameters> robots;
  /// ~joint_state_timeout [s]: a robot's latest joint state older than this (by its header.stamp,
  /// or its arrival if unstamped) is not used for a request.
  double joint_state_timeout = 0.5;
};

/// Reads and checks the parameters from `values`, the private namespace as one XmlRpc struct (what
/// the parameter server returns for it; an invalid value, e.g. no parameter at all, gives the
/// defaults). A parameter that is absent takes its default; one of the wrong type or out of its
/// range throws core::InvalidInput naming it ("~tolerance": never clamped). Needs no ROS master.
ServerParameters loadServerParameters(const XmlRpc::XmlRpcValue& values);

/// The ~multi_contact name of SolverOptions::simultaneous_impulse_space ("simultaneous",
/// "two_phase"), and back (false for another name, leaving `simultaneous` as it was).
const char* multiContactName(bool simultaneous);
bool multiContactFromName(const std::string& name, bool& simultaneous);

}  // namespace collision_response
