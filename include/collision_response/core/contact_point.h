#pragma once

#include <Eigen/Core>

namespace collision_response::core {

/// One contact between two bodies of a body list, by index, as a contact problem is built from it
/// (contact_problem.h). World frame, symbols of docs/physics.md, "Symbols and conventions".
struct ContactPoint {
  int body_a = -1;                                    ///< index of body a in the body list
  int body_b = -1;                                    ///< index of body b
  Eigen::Vector3d point = Eigen::Vector3d::Zero();    ///< contact point p, world [m]
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< n, unit, from a towards b
  double restitution = 0.0;                           ///< e in [0, 1]
  double static_friction = 0.0;                       ///< mu_s >= 0
  double dynamic_friction = 0.0;                      ///< 0 <= mu_d <= mu_s
  /// Part of body a / b the point belongs to, for bodies of several parts (a robot's link index,
  /// BodyModel::partPointJacobian()); -1 for single-part bodies. Free rigid bodies ignore it.
  int part_a = -1;
  int part_b = -1;

  ContactPoint() = default;
  ContactPoint(int a_index, int b_index, const Eigen::Vector3d& contact_point,
               const Eigen::Vector3d& unit_normal, double e, double mu_s, double mu_d)
      : body_a(a_index),
        body_b(b_index),
        point(contact_point),
        normal(unit_normal),
        restitution(e),
        static_friction(mu_s),
        dynamic_friction(mu_d) {}

  bool frictionless() const { return static_friction == 0.0 && dynamic_friction == 0.0; }
};

}  // namespace collision_response::core
