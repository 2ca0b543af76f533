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
/// half width into nearly a sphere), the contact threshold (kContactThreshold), split impulse for
/// every penetration (Bullet's default splits only those deeper than 4 cm; shallower ones are
/// pushed out by a velocity bias that adds to the rebound: 0.95 m/s instead of 0.70 in the drop of
/// kContactThreshold's note) and the
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
  /// threshold, the table shape's; Bullet takes the smaller of the two shapes'). Bullet's
  /// default, 2 % of the cube's bounding radius (1.8 mm here), makes speculative
  /// contacts that stop the cube at the table by the gap over the step: at a 1 ms step that
  /// absorbs a landing's bounce (a flat drop from 0.1 m with restitution 0.5 rebounded at 0 m/s
  /// instead of 0.70 m/s; 0.39 m/s at a 4 ms step). At 0.1 mm the cube reaches the table before
  /// its contacts are made, and the restitution acts as Bullet documents it.
  static constexpr double kContactThreshold = 1e-4;

 private:
  struct World;
  std::unique_ptr<World> world_;
  double step_;
};

}  // namespace collision_response::bench
