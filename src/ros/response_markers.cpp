#include "collision_response/ros/response_markers.h"

#include "collision_response/ros/message_conversion.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <vector>

namespace collision_response {
namespace {

using visualization_msgs::Marker;

std_msgs::ColorRGBA color(float r, float g, float b) {
  std_msgs::ColorRGBA c;
  c.r = r;
  c.g = g;
  c.b = b;
  c.a = 1.0f;
  return c;
}

/// Centre of mass of a body in the frame of its pose.
Eigen::Vector3d centreOfMass(const BodyState& body) {
  const auto& q = body.pose.orientation;
  Eigen::Quaterniond rotation(q.w, q.x, q.y, q.z);
  if (rotation.norm() > 0.0) rotation.normalize();
  return toEigen(body.pose.position) + rotation * toEigen(body.inertia.com);
}

Marker marker(const std_msgs::Header& header, const std::string& ns, int id, int type,
              const std_msgs::ColorRGBA& c) {
  Marker m;
  m.header = header;
  m.ns = ns;
  m.id = id;
  m.type = type;
  m.action = Marker::ADD;
  m.pose.orientation.w = 1.0;
  m.color = c;
  return m;
}

/// An arrow from `from` to `from + v`; nothing is added for a zero-length arrow.
void addArrow(visualization_msgs::MarkerArray& array, const std_msgs::Header& header,
              const std::string& ns, int id, const std_msgs::ColorRGBA& c,
              const Eigen::Vector3d& from, const Eigen::Vector3d& v) {
  const double length = v.norm();
  if (!(length > 1e-9)) return;
  Marker m = marker(header, ns, id, Marker::ARROW, c);
  m.points = {toPoint(from), toPoint(from + v)};
  m.scale.x = std::min(0.012, 0.2 * length);  // shaft diameter [m]
  m.scale.y = 2.0 * m.scale.x;                // head diameter [m]
  m.scale.z = std::min(0.04, 0.4 * length);   // head length [m]
  array.markers.push_back(std::move(m));
}

}  // namespace

visualization_msgs::MarkerArray makeMarkers(const ComputeResponse::Request& request,
                                            const ComputeResponse::Response& response,
                                            const MarkerScales& scales,
                                            const std::vector<ContactLinkFrame>& link_frames) {
  visualization_msgs::MarkerArray array;
  Marker clear;
  clear.header = request.header;
  clear.action = Marker::DELETEALL;
  array.markers.push_back(clear);

  const std_msgs::Header& header = request.header;
  // The request's contacts, then those detected from shapes: the order of response.impulses.
  std::vector<const Contact*> contacts;
  for (const Contact& c : request.contacts) contacts.push_back(&c);
  for (const Contact& c : response.detected_contacts) contacts.push_back(&c);
  const auto on_link = [&](std::size_t i) {
    return i < link_frames.size() && !link_frames[i].frame_id.empty();
  };
  Marker points = marker(header, "contact_points", 0, Marker::SPHERE_LIST, color(1, 1, 0));
  points.scale.x = points.scale.y = points.scale.z = scales.point;
  for (std::size_t i = 0; i < contacts.size(); ++i) {
    const Contact& c = *contacts[i];
    Eigen::Vector3d n = toEigen(c.normal);
    if (n.norm() > 0.0) n.normalize();
    Eigen::Vector3d j = Eigen::Vector3d::Zero();
    if (i < response.impulses.size()) {
      const ContactImpulse& impulse = response.impulses[i];
      j = impulse.normal_impulse * n + toEigen(impulse.friction_impulse);
    }
    // In the request frame, or in the link's frame (p_link = link_T_request p).
    std_msgs::Header frame = header;
    Eigen::Vector3d p = toEigen(c.point);
    if (on_link(i)) {
      const Eigen::Isometry3d link_T_request = link_frames[i].request_T_link.inverse();
      frame.frame_id = link_frames[i].frame_id;
      p = link_T_request * p;
      n = link_T_request.linear() * n;
      j = link_T_request.linear() * j;
      Marker sphere = marker(frame, "robot_contact_points", static_cast<int>(i), Marker::SPHERE,
                             color(1, 1, 0));
      sphere.pose.position = toPoint(p);
      sphere.scale.x = sphere.scale.y = sphere.scale.z = scales.point;
      array.markers.push_back(std::move(sphere));
    } else {
      points.points.push_back(c.point);
    }
    addArrow(array, frame, "contact_normals", static_cast<int>(i), color(0, 0.6f, 1), p,
             scales.normal * n);
    addArrow(array, frame, "contact_impulses", static_cast<int>(i), color(1, 0, 0), p,
             scales.impulse * j);
  }
  if (!points.points.empty()) array.markers.push_back(std::move(points));
  for (std::size_t i = 0; i < response.bodies.size(); ++i) {
    const BodyState& after = response.bodies[i];
    if (!(after.inertia.m > 0.0)) continue;  // immovable: velocity prescribed
    const Eigen::Vector3d com = centreOfMass(after);
    if (i < request.bodies.size()) {
      const BodyState& before = request.bodies[i];
      if (before.frame_id.empty() || before.frame_id == header.frame_id) {
        addArrow(array, header, "velocity_before", static_cast<int>(i), color(0.6f, 0.6f, 0.6f),
                 com, scales.velocity * toEigen(before.twist.linear));
      }
    }
    addArrow(array, header, "velocity_after", static_cast<int>(i), color(0, 0.8f, 0), com,
             scales.velocity * toEigen(after.twist.linear));
  }
  return array;
}

}  // namespace collision_response
