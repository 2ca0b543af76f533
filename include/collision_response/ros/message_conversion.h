#pragma once

// Conversions between the package's ROS messages and the core library's types. Pure copies: the
// core's validate() checks the values, with the same field names as the messages.

#include <collision_response/BodyState.h>
#include <collision_response/Contact.h>
#include <collision_response/ContactImpulse.h>
#include <collision_response/DetectionOptions.h>
#include <collision_response/ImpactDerivatives.h>
#include <collision_response/IslandReport.h>
#include <collision_response/SolverOptions.h>

#include "collision_response/core/body_state.h"
#include "collision_response/core/compute_response.h"
#include "collision_response/core/contact.h"
#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/impact_derivatives.h"
#include "collision_response/core/solver_options.h"
#include "collision_response/detection/detect_contacts.h"

namespace collision_response {

/// Vectors and points, component by component (no frame change).
Eigen::Vector3d toEigen(const geometry_msgs::Vector3& v);
Eigen::Vector3d toEigen(const geometry_msgs::Point& p);
geometry_msgs::Vector3 toVector3(const Eigen::Vector3d& v);
geometry_msgs::Point toPoint(const Eigen::Vector3d& p);

/// Pose and twist are taken as given, in whatever frame msg.frame_id names.
core::BodyState fromMsg(const BodyState& msg);
/// `frame_id` is the frame the state is expressed in.
BodyState toMsg(const core::BodyState& state, const std::string& frame_id);

core::Contact fromMsg(const Contact& msg);
Contact toMsg(const core::Contact& contact);

/// True if the body carries any collision shape (primitives, meshes or planes).
bool hasGeometry(const BodyState& msg);
/// Number of shapes, mesh vertices and mesh triangles of the body, for the request limits.
void countGeometry(const BodyState& msg, std::size_t& shapes, std::size_t& vertices,
                   std::size_t& triangles);
/// The body's collision shapes, each placed in the body frame. Throws core::InvalidInput naming
/// the field under `field` (e.g. "bodies[2]"): "bodies[2].primitive_poses" when its count differs
/// from the primitives' (likewise mesh_poses, plane_poses), "bodies[2].primitives[0].type" for an
/// unknown type, "bodies[2].primitive_poses[0].orientation" for a zero or non-unit quaternion, an
/// out-of-range mesh vertex index. Sizes and values are checked by detection::detectContacts().
detection::BodyGeometry geometryFromMsg(const BodyState& msg, const std::string& field);

/// Detection settings of a request; a zero contact_tolerance takes `default_tolerance`.
detection::DetectionOptions fromMsg(const DetectionOptions& msg, double default_tolerance);
/// What detection needs of a request's bodies and detection options: each body's shapes
/// (geometryFromMsg(), named "bodies[i]"), its material, the coefficients of pairs without one, the
/// contact tolerance (0 = `default_tolerance`). Limits, deadline and contacts per pair are the
/// caller's to set. Throws core::InvalidInput as geometryFromMsg().
detection::DetectionInput detectionInputFromMsg(const std::vector<BodyState>& bodies,
                                                const DetectionOptions& msg,
                                                double default_tolerance);
ContactImpulse toMsg(const core::ContactImpulse& impulse);
IslandReport toMsg(const core::SolveReport& report);

/// The Jacobians of computeImpactDerivatives() as ImpactDerivatives.msg: labels, row-major
/// entries, each contact's mode. Frames and units are the library's (the request frame).
ImpactDerivatives toMsg(const core::ImpactDerivatives& derivatives);

/// ImpactDerivatives.msg from a Jacobian and its labels (rows x columns, written row-major) and
/// each contact's mode: the one conversion of both the rigid-body and the robots' derivatives.
ImpactDerivatives derivativesMsg(core::DerivativeMethod method, const Eigen::MatrixXd& jacobian,
                                 std::vector<std::string> row_labels,
                                 std::vector<std::string> column_labels,
                                 const std::vector<core::ContactDerivativeMode>& contacts);

/// Options of a request; zero fields take the value of `defaults`. Throws core::InvalidInput
/// ("options.law", "options.solver") for an unknown enumeration value.
core::SolverOptions fromMsg(const SolverOptions& msg, const core::SolverOptions& defaults);

}  // namespace collision_response
