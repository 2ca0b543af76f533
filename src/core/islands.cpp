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

// Union-find over bodies; only movable bodies join contacts into one island.
template <typename Movable>
std::vector<Island> islandsOf(std::size_t body_count, const Movable& movable,
                              const std::vector<std::pair<int, int>>& contact_bodies) {
  if (contact_bodies.size() == 1) {  // (a braced list would copy its Island: one more allocation)
    std::vector<Island> one(1);
    one[0].contacts.push_back(0);
    return one;
  }
  std::vector<int> parent(body_count);
  std::iota(parent.begin(), parent.end(), 0);
  for (const auto& [a, b] : contact_bodies) {
    if (movable(a) && movable(b)) parent[findRoot(parent, a)] = findRoot(parent, b);
  }
  std::vector<int> island_of_root(body_count, -1);
  std::vector<Island> islands;
  for (int c = 0; c < static_cast<int>(contact_bodies.size()); ++c) {
    const auto [a, b] = contact_bodies[c];
    const int root = findRoot(parent, movable(a) ? a : b);
    if (island_of_root[root] < 0) {
      island_of_root[root] = static_cast<int>(islands.size());
      islands.emplace_back();
    }
    islands[island_of_root[root]].contacts.push_back(c);
  }
  return islands;
}

}  // namespace

std::vector<Island> findIslands(const std::vector<RigidBody>& bodies,
                                const std::vector<std::pair<int, int>>& contact_bodies) {
  return islandsOf(
      bodies.size(), [&](int b) { return bodies[b].movable(); }, contact_bodies);
}

std::vector<Island> findIslands(const std::vector<BodyModel*>& bodies,
                                const std::vector<std::pair<int, int>>& contact_bodies) {
  return islandsOf(
      bodies.size(), [&](int b) { return bodies[b]->velocityCount() > 0; }, contact_bodies);
}

std::vector<Island> findIslands(const std::vector<int>& unknowns,
                                const std::vector<std::pair<int, int>>& contact_bodies) {
  return islandsOf(
      unknowns.size(), [&](int b) { return unknowns[b] > 0; }, contact_bodies);
}

}  // namespace collision_response::core
