// MuJoCo 2.2 (Debian's libmujoco-dev) simulating the cube's landing: a free box geom above a plane,
// loaded from MJCF, stepped by mj_step at a fixed step, as a MuJoCo user sets it up
// (docs/benchmarks.md, "Peers on the real tosses").
#pragma once

#include <memory>

#include "landing_model.h"

namespace collision_response::bench {

/// Parameters, the way MuJoCo users tune a bounce: "friction" (the sliding coefficient, on both
/// geoms: MuJoCo takes the larger of the two), "solref_timeconst" [s] and "solref_dampratio" (the
/// contact's spring-damper reference, on both geoms: with equal solmix MuJoCo averages them; a
/// damping ratio below 1 bounces). solimp fixed at MuJoCo's default (0.9, 0.95, 0.001, 0.5, 2);
/// everything else at its defaults too (Euler integrator, pyramidal friction cone unless asked for
/// the elliptic one, condim 3,
/// Newton solver, contact margin 0). Search box: friction [0.01, 2]; time constant from two steps
/// (MuJoCo raises smaller ones to that) to 0.05 s; damping ratio [0.05, 1] (above 1 only more
/// dissipative than critical). Softer corners let the cube sink through the table: at (0.1 s, 2)
/// a landing ended 9 cm deep, at (0.05 s, 2) 2.5 cm; at the box's corners it stays within 3.3 mm.
class MujocoLanding : public LandingModel {
 public:
  /// `step` [s]: the fixed step (MuJoCo's option timestep), in (0, 0.01]. `elliptic_cone`: MuJoCo's
  /// elliptic friction cone instead of its default pyramidal one. With friction near 0 the pyramid
  /// is not frictionless: in landing_peers_check's frictionless landing a face spinning on the
  /// table jumped by 1.4 rad/s in spin and 0.04 m/s in speed; the elliptic cone kept both.
  explicit MujocoLanding(double step = 1e-3, TossedCube cube = {}, bool elliptic_cone = false);
  ~MujocoLanding() override;
  std::string name() const override { return elliptic_ ? "MuJoCo elliptic" : "MuJoCo"; }
  std::vector<LandingParameter> parameters() const override;
  /// Throws std::runtime_error if MuJoCo reports the simulation unstable (it then resets the
  /// state, which is no answer); landing_peers_check steps every corner of the search box.
  CubeState simulate(const CubeState& before, const std::vector<double>& values,
                     double duration) override;

 private:
  struct World;
  std::unique_ptr<World> world_;
  double step_;
  bool elliptic_;
};

}  // namespace collision_response::bench
