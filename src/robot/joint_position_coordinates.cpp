#include "collision_response/robot/joint_position_coordinates.h"

namespace collision_response::robot {

std::vector<core::ConfigurationCoordinate> jointPositionCoordinates(ArticulatedBody& body,
                                                                    std::vector<int>* joints) {
  std::vector<core::ConfigurationCoordinate> out;
  if (joints != nullptr) joints->clear();
  for (int j = 0; j < body.jointCount(); ++j) {
    if (body.mimicRoot(j) != j) continue;
    core::ConfigurationCoordinate coordinate;
    coordinate.value = body.jointPositions()(j);
    coordinate.body = &body;  // the body's configuration coordinates are these, in this order
    coordinate.index = static_cast<int>(out.size());
    coordinate.set = [&body, j](double x) {
      Eigen::VectorXd q = body.jointPositions();
      q(j) = x;
      body.setState(q, body.jointVelocities(), body.linkPose(0), body.baseLinearVelocity(),
                    body.baseAngularVelocity());
    };
    out.push_back(std::move(coordinate));
    if (joints != nullptr) joints->push_back(j);
  }
  return out;
}

}  // namespace collision_response::robot
