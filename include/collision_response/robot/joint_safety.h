#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "collision_response/core/contact_impulse.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/warning.h"
#include "collision_response/robot/articulated_body.h"

namespace collision_response::robot {

// A robot's joints after an impact, for a safety assessment (docs/robots.md, "Safety outputs").

/// The generalized impulse the impact's contacts give every joint of `robot`, body `self` of the
/// contact list: the sum of J(p)^T P over the contacts with a side on it that are not resting, P =
/// normal_impulse n + friction_impulse (+ on b, - on a) [N m s revolute, N s prismatic], joint
/// order, locked joints included (what their brake or gear train takes). jointCount() entries,
/// zero when no impact touches the robot. `answers` has one entry per contact.
Eigen::VectorXd impactJointImpulses(const ArticulatedBody& robot, int self,
                                    const std::vector<core::ContactPoint>& contacts,
                                    const std::vector<core::ContactImpulse>& answers);

/// One warning (kind kJointLimit) per joint whose velocity |qdot| exceeds its velocity limit
/// (ArticulatedBody::velocityLimit(); joints without one never do), in joint order, the field
/// `field + ".joint_state.velocity[j]"` (j the joint's index in jointNames()), the reason naming
/// the joint, its velocity and its limit. Called on the robot after the impact.
std::vector<core::Warning> velocityLimitWarnings(const ArticulatedBody& robot,
                                                 const std::string& field);

}  // namespace collision_response::robot
