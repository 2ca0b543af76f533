#pragma once

#include <Eigen/Core>
#include <string>

namespace collision_response::core {

/// One contact point between two bodies of a scene, in the scene's common frame.
struct Contact {
  std::string body_a;                                 ///< id of the first body
  std::string body_b;                                 ///< id of the second body
  Eigen::Vector3d point = Eigen::Vector3d::Zero();    ///< contact point [m]
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< unit normal from body_a towards body_b
  double restitution = 0.0;                           ///< e in [0, 1]
  double static_friction = 0.0;                       ///< mu_s >= 0
  double dynamic_friction = 0.0;                      ///< 0 <= mu_d <= mu_s

  bool frictionless() const { return static_friction == 0.0 && dynamic_friction == 0.0; }
};

}  // namespace collision_response::core
