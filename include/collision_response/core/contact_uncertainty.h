#pragma once

#include <cstddef>
#include <optional>

#include "collision_response/core/coefficient_distribution.h"

namespace collision_response::core {

/// The uncertain coefficients of one contact of a scene (docs/uncertainty.md). A coefficient
/// without a distribution keeps the contact's own value (Contact::restitution, ...); the
/// coefficients of a contact, and of different contacts, are independent of each other.
struct ContactUncertainty {
  std::size_t contact = 0;                                  ///< index into Scene::contacts
  std::optional<CoefficientDistribution> restitution;       ///< e, range [0, 1]
  std::optional<CoefficientDistribution> static_friction;   ///< mu_s, range [0, infinity)
  std::optional<CoefficientDistribution> dynamic_friction;  ///< mu_d, range [0, infinity)
};

}  // namespace collision_response::core
