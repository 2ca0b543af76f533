#include "collision_response/core/islands.h"

#include <numeric>

namespace collision_response::core {
namespace {

int findRoot(std::vector<int>& parent, int i) {
  while (parent[i] != i) {
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

}  // namespace

std::vector<Island> findIslands(const std::vector<RigidBody>& bodies,
                                const std::vector<std::pair<int, int>>& contact_bodies) {
  // Union-find over bodies; only movable bodies join contacts into one island.
  std::vector<int> parent(bodies.size());
  std::iota(parent.begin(), parent.end(), 0);
  for (const auto& [a, b] : contact_bodies) {
    if (bodies[a].movable() && bodies[b].movable())
      parent[findRoot(parent, a)] = findRoot(parent, b);
  }
  std::vector<int> island_of_root(bodies.size(), -1);
  std::vector<Island> islands;
  for (int c = 0; c < static_cast<int>(contact_bodies.size()); ++c) {
    const auto [a, b] = contact_bodies[c];
    const int root = findRoot(parent, bodies[a].movable() ? a : b);
    if (island_of_root[root] < 0) {
      island_of_root[root] = static_cast<int>(islands.size());
      islands.emplace_back();
    }
    islands[island_of_root[root]].contacts.push_back(c);
  }
  return islands;
}

}  // namespace collision_response::core
