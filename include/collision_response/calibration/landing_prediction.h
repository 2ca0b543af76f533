// The predicted outcome of a recorded landing under given coefficients (docs/calibration.md,
// "Identification"): the object from its pre-impact state against the floor plane z = 0, by the
// episode (core::computeEpisode()) or one impact, then free flight to the first post-landing
// sample's time, where the measured outcome is; and the residual the fit minimises.
#pragma once

#include <Eigen/Core>
#include <memory>

#include "collision_response/calibration/landing_extraction.h"
#include "collision_response/calibration/object_model.h"
#include "collision_response/core/solver_options.h"

namespace collision_response::calibration {

/// The coefficients of the object's material against the floor's, and the inertia's scale.
struct Coefficients {
  double restitution = 0.3;       ///< e in [0, 1]
  double static_friction = 0.3;   ///< mu_s >= 0
  double dynamic_friction = 0.3;  ///< mu_d in [0, mu_s]
  double inertia_scale = 1.0;     ///< the object's inertia is this times ObjectModel::inertia, > 0
};

struct PredictionOptions {
  core::ImpactLaw law = core::ImpactLaw::kStronge;
  /// One impact only: the episode stops at its second impact (or sustained contact) and the
  /// object flies on from there as if the floor were gone: what one service call predicts.
  bool single_impact = false;
  double gravity_z = -9.81;  ///< [m/s^2]
};

/// The residual of one landing: the predicted minus the measured velocities at the first
/// post-landing sample, relative to the pre-impact speed |v_before|: (v_p - v_m) / |v_before| and
/// L (w_p - w_m) / |v_before| with L = lengthScale() (the real-tosses benchmark's scores).
using LandingResidual = Eigen::Matrix<double, 6, 1>;

class LandingPredictor {
 public:
  /// Prepares the object's shape against the floor plane (detection::ShapeGaps). Throws
  /// std::runtime_error naming object.source for a shape the detection rejects.
  LandingPredictor(const ObjectModel& object, const PredictionOptions& options);
  ~LandingPredictor();
  LandingPredictor(const LandingPredictor&) = delete;
  LandingPredictor& operator=(const LandingPredictor&) = delete;

  /// The state at landing.t_after predicted from landing.before (at landing.t_before). Thread
  /// safe (const). Throws what computeEpisode() throws for invalid coefficients.
  MotionState predict(const Landing& landing, const Coefficients& coefficients) const;
  LandingResidual residual(const Landing& landing, const Coefficients& coefficients) const;
  const ObjectModel& object() const { return object_; }

 private:
  struct Impl;
  ObjectModel object_;
  PredictionOptions options_;
  double length_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace collision_response::calibration
