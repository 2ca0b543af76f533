#pragma once

#include <vector>

#include "collision_response/core/body_model.h"
#include "collision_response/core/rigid_body.h"

namespace collision_response::core {

/// Contacts coupled through shared movable bodies. Immovable bodies do not couple contacts: two
/// objects resting on the same floor form two islands.
struct Island {
  std::vector<int> contacts;  ///< indices into the scene's contacts, ascending
};

/// Splits contacts (given as pairs of body indices) into islands, in order of their first contact.
std::vector<Island> findIslands(const std::vector<RigidBody>& bodies,
                                const std::vector<std::pair<int, int>>& contact_bodies);
/// The same for general bodies (body_model.h): movable are those with velocity unknowns.
std::vector<Island> findIslands(const std::vector<BodyModel*>& bodies,
                                const std::vector<std::pair<int, int>>& contact_bodies);
/// The same for bodies given by their numbers of velocity unknowns (BodyModel::velocityCount(),
/// 0: immovable), as the island pipeline (solve_islands.h) keeps them.
std::vector<Island> findIslands(const std::vector<int>& unknowns,
                                const std::vector<std::pair<int, int>>& contact_bodies);

}  // namespace collision_response::core
