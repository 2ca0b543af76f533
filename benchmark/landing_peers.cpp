// The available peer engines (see landing_peers.h).
#include "landing_peers.h"

#ifdef HAVE_LANDING_BULLET
#include "landing_bullet.h"
#endif
#ifdef HAVE_LANDING_ODE
#include "landing_ode.h"
#endif
#ifdef HAVE_LANDING_MUJOCO
#include "landing_mujoco.h"
#endif

namespace collision_response::bench {

std::vector<std::unique_ptr<LandingModel>> makeLandingPeers(double step) {
  std::vector<std::unique_ptr<LandingModel>> peers;
#ifdef HAVE_LANDING_BULLET
  peers.push_back(std::make_unique<BulletLanding>(step));
#endif
#ifdef HAVE_LANDING_ODE
  peers.push_back(std::make_unique<OdeLanding>(step));
#endif
#ifdef HAVE_LANDING_MUJOCO
  peers.push_back(std::make_unique<MujocoLanding>(step));
#endif
  (void)step;
  return peers;
}

}  // namespace collision_response::bench
