#pragma once

#include <cstddef>
#include <optional>

#include <Eigen/Core>

#include "collision_response/core/coefficient_distribution.h"

namespace collision_response::core {

/// The uncertain coefficients of one contact of a scene (docs/uncertainty.md). A coefficient
/// without a distribution keeps the contact's own value (Contact::restitution, ...); the
/// coefficients of a contact, and of different contacts, are independent of each other.
///
/// The contact's normal and point may be uncertain too (both methods; the linear one takes their
/// columns as central differences of the solver): per sample the normal is normalize(n + a t1 + b t2), a and b
/// independent N(0, normal_std_dev^2) and (t1, t2) an orthonormal basis of n's tangent plane (the
/// distribution does not depend on which), and the point p + point_std_dev .* z, z three
/// independent standard normals. They are independent of the coefficients and of each other.
struct ContactUncertainty {
  std::size_t contact = 0;                                  ///< index into Scene::contacts
  std::optional<CoefficientDistribution> restitution;       ///< e, range [0, 1]
  std::optional<CoefficientDistribution> static_friction;   ///< mu_s, range [0, infinity)
  std::optional<CoefficientDistribution> dynamic_friction;  ///< mu_d, range [0, infinity)
  /// [rad] (small angles) standard deviation of each of the normal's two tangent-plane
  /// components, in [0, pi/2] (0: the contact's normal exactly).
  double normal_std_dev = 0.0;
  /// [m] standard deviation of the point along each axis of the scene's (world) frame, each in
  /// [0, 1e7] (0: exact along that axis).
  Eigen::Vector3d point_std_dev = Eigen::Vector3d::Zero();
};

}  // namespace collision_response::core
