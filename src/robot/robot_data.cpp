#include "collision_response/robot/robot_data.h"

namespace collision_response::robot {

RobotData::RobotData(const RobotModel& model)
    : q(Eigen::VectorXd::Zero(model.jointCount())),
      qdot(Eigen::VectorXd::Zero(model.jointCount())),
      locked(model.jointCount(), false),
      frames(model.linkCount(), KDL::Frame::Identity()),
      axes(model.linkCount(), KDL::Twist::Zero()),
      twists(model.linkCount(), KDL::Twist::Zero()),
      composite(model.linkCount()),
      link_inertias(model.linkCount()),
      torques(Eigen::VectorXd::Zero(model.jointCount())) {}

}  // namespace collision_response::robot
