#pragma once

#include <string>

#include "collision_response/core/body_state.h"
#include "collision_response/robot/articulated_body.h"

namespace collision_response::robot {

// A robot's links as bodies of contact detection: each link a body at its frame's pose, so that a
// detector built for rigid bodies (detection/) finds the contacts on them. Detection reads the
// poses and shapes only; the impact is solved on the robot itself (the link is the contact's part,
// core::ContactPoint::part_a / part_b).

/// Link `link` of `robot` (at its state: setState()) as a body of detection: id `id`, the body
/// frame the link's frame at linkPose(link) (the world of the robot's base pose: for the ROS node
/// the request frame), at rest, no wrench, a stand-in mass of 1 kg and unit inertia [kg m^2] about
/// the link frame's origin (detection pairs no two immovable bodies; the link's own inertia is the
/// robot's, not read here).
core::BodyState linkBody(const ArticulatedBody& robot, int link, std::string id);

}  // namespace collision_response::robot
