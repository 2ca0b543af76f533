#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

// RViz markers of one answered request: contact points, normals, impulses and the bodies' pre- and
// post-impact velocities, all in the request frame (header.frame_id).

#include <collision_response/ComputeResponse.h>
#include <visualization_msgs/MarkerArray.h>

namespace collision_response {

/// Arrow lengths of the markers.
struct MarkerScales {
  double impulse = 0.1;   ///< [m per N s] impulse arrows (normal + friction impulse)
  double velocity = 0.1;  ///< [m per m/s] pre- and post-impact linear velocity arrows
  double normal = 0.1;    ///< [m] length of the unit contact normal arrows
  double point = 0.02;    ///< [m] diameter of the contact point spheres
};

/// A contact on a robot's link, drawn in that link's tf frame so that RViz keeps it on the robot
/// model: frame_id the link's name (as robot_state_publisher broadcasts it), request_T_link the
/// link's pose in the request frame at the request's state.
struct ContactLinkFrame {
  std::string frame_id;  ///< empty: the contact is drawn in the request frame
  Eigen::Isometry3d request_T_link = Eigen::Isometry3d::Identity();
};

/// Markers of an answered request, first a DELETEALL so that markers of an earlier answer vanish.
/// Contacts are the request's, then the response's detected_contacts (the order of its impulses).
/// Namespaces: "contact_points" (one SPHERE_LIST), "contact_normals", "contact_impulses" (one ARROW
/// per contact, id = contact index, the impulse J = normal_impulse n + friction_impulse acting on
/// body_b, drawn from the contact point), "velocity_before", "velocity_after" (one ARROW per
/// movable body at its centre of mass, id = body index). Velocity before is drawn only for bodies
/// given in the request frame (frame_id empty or header.frame_id). Zero-length arrows are left
/// out. `response` must be a successful answer to `request`. `link_frames`: empty, or one per
/// contact (order of impulses); a contact with a frame_id is drawn in its link's frame: its
/// normal and impulse arrows (same namespaces and ids) and a sphere in "robot_contact_points"
/// (id = contact index) instead of a point of the "contact_points" list.
visualization_msgs::MarkerArray makeMarkers(const ComputeResponse::Request& request,
                                            const ComputeResponse::Response& response,
                                            const MarkerScales& scales,
                                            const std::vector<ContactLinkFrame>& link_frames = {});

}  // namespace collision_response
