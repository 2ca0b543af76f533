// Bullet (libbullet-dev, double precision) simulating the cube's landing: a btDiscreteDynamicsWorld
// with a btBoxShape cube on a btStaticPlaneShape table, stepped at a fixed step, as a Bullet user
// sets it up (docs/benchmarks.md, "Peers on the real tosses").
#pragma once

#include <memory>

#include "landing_model.h"

namespace collision_response::bench {

/// Parameters: "restitution" (the cube's; the table's is 1, Bullet multiplies the two) and
/// "friction" (the cube's; the table's is 1, multiplied likewise). Everything else at Bullet's
/// defaults (sequential impulses, 10 iterations, split impulse, restitution velocity threshold
/// 0.2 m/s), except the cube's collision margin: 1 mm instead of 40 mm (the margin rounds the
/// box's edges and corners with that radius while keeping its extents; 40 mm would round a 52 mm
/// half width into nearly a sphere), the contact threshold (contactThreshold()), split impulse for
/// every penetration (Bullet's default splits only those deeper than 4 cm; shallower ones are
/// pushed out by a velocity bias that adds to the rebound: 0.95 m/s instead of 0.70 in the drop of
/// contactThreshold()'s note) and the
/// plane-convex contact generation with 3 perturbation iterations, so that a face on the table
/// gets its four corners at once.
class BulletLanding : public LandingModel {
 public:
  /// `step` [s]: the fixed step, in (0, 0.01].
  explicit BulletLanding(double step = 1e-3, TossedCube cube = {});
  ~BulletLanding() override;
  std::string name() const override { return "Bullet"; }
  std::vector<LandingParameter> parameters() const override;
  CubeState simulate(const CubeState& before, const std::vector<double>& values,
                     double duration) override;

  static constexpr double kMargin = 1e-3;  ///< the cube's collision margin [m]
  /// The distance [m] from the table within which Bullet makes a contact (the contact breaking
  /// threshold, the table shape's; Bullet takes the smaller of the two shapes'): 2 g step^2 (20 um
  /// at 1 ms). Bullet's default, 2 % of the cube's bounding radius (1.8 mm here), makes speculative
  /// contacts, which brake the cube by up to the threshold over the step before it touches: at a
  /// 1 ms step that absorbed a landing's bounce entirely (a flat drop from 0.1 m with restitution
  /// 0.5 rebounded at 0 m/s instead of 0.70 m/s). The braking is at most 2 g step (0.02 m/s at
  /// 1 ms); below about g step^2, the distance gravity moves a resting cube in one step, contacts
  /// flicker and a cube on the table does not settle (1 um at a 4 ms step: 0.03 m/s after 0.5 s).
  static double contactThreshold(double step) { return 2.0 * 9.81 * step * step; }

 private:
  struct World;
  std::unique_ptr<World> world_;
  double step_;
};

}  // namespace collision_response::bench
