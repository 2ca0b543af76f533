#include "collision_response/robot/joint_safety.h"

#include <cmath>
#include <sstream>

namespace collision_response::robot {

Eigen::VectorXd impactJointImpulses(const ArticulatedBody& robot, int self,
                                    const std::vector<core::ContactPoint>& contacts,
                                    const std::vector<core::ContactImpulse>& answers) {
  Eigen::VectorXd impulses = Eigen::VectorXd::Zero(robot.jointCount());
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    const core::ContactPoint& contact = contacts[c];
    if (answers[c].resting || (contact.body_a != self && contact.body_b != self)) continue;
    const Eigen::Vector3d impulse = answers[c].total(contact.normal);
    if (contact.body_a == self)
      impulses -= robot.jointTorquesOf(contact.part_a, contact.point, impulse);
    if (contact.body_b == self)
      impulses += robot.jointTorquesOf(contact.part_b, contact.point, impulse);
  }
  return impulses;
}

std::vector<core::Warning> velocityLimitWarnings(const ArticulatedBody& robot,
                                                 const std::string& field) {
  std::vector<core::Warning> warnings;
  const Eigen::VectorXd& velocity = robot.jointVelocities();
  for (int joint = 0; joint < robot.jointCount(); ++joint) {
    const double limit = robot.velocityLimit(joint);
    if (!(std::abs(velocity(joint)) > limit)) continue;
    const bool prismatic =
        robot.model().link(robot.model().linkOfJoint(joint)).segment.getJoint().getType() >=
        KDL::Joint::TransAxis;
    const char* unit = prismatic ? " m/s" : " rad/s";
    std::ostringstream reason;
    reason << "joint '" << robot.jointNames()[joint]
           << "' leaves its velocity limit: " << velocity(joint) << unit
           << " after the impact, |velocity| > " << limit << unit;
    warnings.push_back({field + ".joint_state.velocity[" + std::to_string(joint) + "]",
                        reason.str(), core::Warning::Kind::kJointLimit});
  }
  return warnings;
}

}  // namespace collision_response::robot
