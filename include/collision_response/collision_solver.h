#pragma once

#include <string>
#include <vector>

#include "collision_response/contact_impulse.h"
#include "collision_response/scene.h"
#include "collision_response/solver_options.h"

namespace collision_response::core {

/// How one island was solved.
struct IslandReport {
  std::vector<int> contacts;  ///< indices into Scene::contacts
  std::string method;         ///< "none" (nothing approaching), "closed_form" or "iterative"
  std::size_t iterations = 0;
  double residual = 0.0;
  bool converged = true;
};

struct CollisionResult {
  std::vector<BodyState> bodies;         ///< post-impact states, same order as Scene::bodies
  std::vector<ContactImpulse> impulses;  ///< one per contact, same order as Scene::contacts
  double kinetic_energy_before = 0.0;    ///< of the movable bodies [J]
  double kinetic_energy_after = 0.0;     ///< [J]
  std::vector<IslandReport> islands;
};

/// Validates the scene (throws InvalidInput naming the field) and computes the post-impact states:
/// islands of coupled contacts are solved separately; an island with no approaching contact costs
/// nothing, one with a single contact is solved in closed form (SolverMethod::kAuto), others
/// iteratively.
CollisionResult computeResponse(const Scene& scene, const SolverOptions& options = {},
                                const RequestLimits& limits = {});

}  // namespace collision_response::core
