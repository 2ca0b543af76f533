#pragma once

#include <vector>

#include "collision_response/core/configuration_coordinate.h"
#include "collision_response/robot/articulated_body.h"

namespace collision_response::robot {

/// A robot's joint positions as coordinates the impact's derivatives can be taken by
/// (core::computeBodyImpactDerivatives(); docs/robots.md, "Derivatives of robot impacts"): one per
/// joint with a coordinate that mimics no other (a follower moves with its root), locked joints
/// included (their positions shape M(q) and the links' Jacobians as the free ones' do), in joint
/// order; `joints` (if given) receives each coordinate's joint index. set(x) is setState() with
/// that joint at x [rad | m] and the rest of the state (positions, velocities, base pose and twist)
/// as it is. Each names the body and its index among the body's configuration coordinates
/// (core::ConfigurationCoordinate::body, index; ArticulatedBody::configurationCount()), so that
/// the impact is differentiated by it in closed form where its island is. The coordinates hold
/// `body` by reference: it must outlive them.
std::vector<core::ConfigurationCoordinate> jointPositionCoordinates(
    ArticulatedBody& body, std::vector<int>* joints = nullptr);

}  // namespace collision_response::robot
