// What a peer engine's adapter returns for one scene instance.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "bench_scenes.h"

namespace collision_response::bench {

/// Answer and cost of one peer configuration on one scene instance.
struct PeerRun {
  Velocities after;                       ///< post-impact velocities, Scene::bodies order
  std::vector<Eigen::Vector3d> impulses;  ///< per contact, +P on body b, world [N s]
  double ns_per_solve = 0.0;              ///< median wall time of the contact-resolving step [ns]
  std::string note;                       ///< anything the table should say (fallbacks, failures)
};

}  // namespace collision_response::bench
