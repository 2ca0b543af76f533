// A prediction of a cube's landing on a table, the common interface of the real-tosses benchmark
// (real_tosses.cpp): our laws (one impact, the episode), the baselines and the peer engines
// (Bullet, ODE, MuJoCo) each implement it, and the harness fits every model's parameters on the
// same training tosses and scores it on the same held-out ones.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "collision_response/calibration/motion_state.h"

namespace collision_response::bench {

/// The tossed cube (../data: side 0.1048 m, 0.37 kg; inertia not measured: uniform cube).
struct TossedCube {
  double half_width = 0.0524;  ///< [m]
  double mass = 0.37;          ///< [kg]
  double inertia = 6.77e-4;    ///< about each axis through the centre [kg m^2] (uniform cube)
};

/// The cube's state (calibration::MotionState). World frame: z up, the table is the plane z = 0
/// (the harness shifts each toss so), gravity (0, 0, -9.81) m/s^2.
using CubeState = calibration::MotionState;

/// One fitted parameter of a model, with the box the fit searches.
struct LandingParameter {
  std::string name;  ///< e.g. "restitution", "static_friction", "solref_timeconst"
  double lower = 0.0;
  double upper = 1.0;
  double initial = 0.5;
  bool log_scale = false;  ///< search in log(value) (stiffnesses, time constants)
};

/// A landing predictor. simulate() may be called from one thread at a time per instance.
class LandingModel {
 public:
  virtual ~LandingModel() = default;
  virtual std::string name() const = 0;
  /// The parameters the harness fits (may be empty: "no change").
  virtual std::vector<LandingParameter> parameters() const = 0;
  /// The cube's state `duration` [s] after `before` (in flight, above the table, some time before
  /// its first contact), with the parameters' values in parameters() order.
  virtual CubeState simulate(const CubeState& before, const std::vector<double>& values,
                             double duration) = 0;
};

}  // namespace collision_response::bench
