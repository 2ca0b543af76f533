#pragma once

#include <utility>
#include <vector>

#include "collision_response/scene.h"
#include "collision_response/solver_options.h"

namespace collision_response::core {

/// Tolerance on |q| - 1 for orientations and on |n| - 1 for contact normals; within it the value is
/// normalised, beyond it the request is rejected.
constexpr double kUnitTolerance = 1e-3;

/// Throws InvalidInput ("bodies" or "contacts") if a request of this size exceeds the limits;
/// cheap, so a server can call it before converting anything.
void checkSize(std::size_t body_count, std::size_t contact_count, const RequestLimits& limits);

/// Checks everything the solvers rely on and throws InvalidInput naming the first offending field:
/// sizes within limits; finite numbers everywhere; non-empty, unique ids; mass >= 0; for movable
/// bodies an inertia that is positive definite and satisfies the triangle inequality of principal
/// moments (an immovable body's inertia is ignored); a non-zero, unit orientation; contacts naming
/// two different known bodies, not both immovable; a non-zero, unit normal; e in [0, 1];
/// 0 <= mu_d <= mu_s; solver options in range. Returns, per contact, the indices of body_a and
/// body_b in scene.bodies.
std::vector<std::pair<int, int>> validate(const Scene& scene, const SolverOptions& options,
                                          const RequestLimits& limits);

}  // namespace collision_response::core
