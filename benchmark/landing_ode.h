// ODE (libode-dev, double precision) simulating the cube's landing: a dBox on a dPlane, contact
// joints from dCollide each step, stepped by dWorldStep at a fixed step, as an ODE user sets it up
// (docs/benchmarks.md, "Peers on the real tosses").
#pragma once

#include <memory>

#include "landing_model.h"

namespace collision_response::bench {

/// Parameters: "mu" (Coulomb coefficient: dContactApprox1, the friction pyramid scaled by the
/// normal force, the same mu in both tangent directions) and "bounce" (ODE's restitution, applied
/// above bounce_vel = 0.1 m/s). World: ERP 0.2 (ODE's default), CFM 1e-5 (the manual's default; the
/// double-precision build's is 1e-10: a little softness keeps a flat face's four redundant contacts
/// well posed),
/// contact surface layer 1 mm and maximum correcting velocity 0.1 m/s (ODE's manual's advice
/// against jitter and popping out of penetration), no auto-disable.
class OdeLanding : public LandingModel {
 public:
  /// `step` [s]: the fixed step, in (0, 0.01].
  explicit OdeLanding(double step = 1e-3, TossedCube cube = {});
  ~OdeLanding() override;
  std::string name() const override { return "ODE"; }
  std::vector<LandingParameter> parameters() const override;
  CubeState simulate(const CubeState& before, const std::vector<double>& values,
                     double duration) override;

  static constexpr double kBounceVelocity = 0.1;  ///< [m/s], below it no bounce
  static constexpr double kErp = 0.2, kCfm = 1e-5;
  static constexpr double kSurfaceLayer = 1e-3;          ///< [m]
  static constexpr double kMaxCorrectingVelocity = 0.1;  ///< [m/s]

 private:
  struct World;
  std::unique_ptr<World> world_;
  double step_;
};

}  // namespace collision_response::bench
