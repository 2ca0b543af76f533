#pragma once

#include <Eigen/Core>

#include "collision_response/core/contact_space.h"

namespace collision_response::core {

/// One contact as the solvers see it: body indices, unit normal, material and contact space.
struct ContactRow {
  int body_a = -1;
  int body_b = -1;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< unit, from a towards b
  double restitution = 0.0;                           ///< e
  double static_friction = 0.0;                       ///< mu_s
  double dynamic_friction = 0.0;                      ///< mu_d
  /// Resting contacts that already slide: the unit tangential slip direction, friction then being
  /// -mu_d P_n slip_direction (iterative solver only). Zero otherwise.
  Eigen::Vector3d slip_direction = Eigen::Vector3d::Zero();
  ContactSpace space;

  ContactRow(int a_index, int b_index, const RigidBody& a, const RigidBody& b,
             const Eigen::Vector3d& point, const Eigen::Vector3d& unit_normal, double e,
             double mu_s, double mu_d)
      : body_a(a_index),
        body_b(b_index),
        normal(unit_normal),
        restitution(e),
        static_friction(mu_s),
        dynamic_friction(mu_d),
        space(a, b, point) {}

  bool frictionless() const { return static_friction == 0.0 && dynamic_friction == 0.0; }
};

}  // namespace collision_response::core
