// Identifying the coefficients that best predict recorded landings (docs/calibration.md,
// "Identification" and "How sure"): robust nonlinear least squares with Ceres over the landings'
// residuals (landing_prediction.h), bounded parameters, derivatives by differences, and the
// covariance at the optimum.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "collision_response/calibration/landing_extraction.h"
#include "collision_response/calibration/landing_prediction.h"
#include "collision_response/calibration/object_model.h"
#include "collision_response/core/worker_pool.h"

namespace collision_response::calibration {

/// The landings of one object (one object file): all objects given to one identification share
/// the coefficients (one pair of materials).
struct ObjectLandings {
  ObjectModel object;
  std::vector<Landing> landings;
};

struct IdentificationOptions {
  PredictionOptions prediction;
  /// Fit mu_s and mu_d (parametrised mu_s and r = mu_d / mu_s in [0, 1]); else one mu = mu_s =
  /// mu_d.
  bool split_friction = false;
  bool fit_inertia_scale = false;  ///< also fit s (inertia = s ObjectModel::inertia), s in [0.2, 5]
  Coefficients initial;            ///< the starting point (within the bounds)
  double max_friction = 2.0;       ///< the upper bound of mu_s (a search box, reported if reached)
  /// The Cauchy loss's scale c on each landing's residual norm: rho(s) = c^2 log(1 + s / c^2),
  /// s = |r|^2: a landing predicted c off (relative to its pre-impact speed) weighs half, farther
  /// ones less and less. 0 (the default): automatic, in two stages: a fit with c = 0.25, then
  /// c = twice the median |r| of its landings and the fit again (so that the scale follows the
  /// data's noise, whatever it is).
  double loss_scale = 0.0;
  /// With the automatic loss scale, carry its own uncertainty into the covariance
  /// (docs/calibration.md, "How sure"): refit (from the optimum) at the scales one standard
  /// deviation of the median below and above it, and add the spread of the optimum between them.
  /// Two more fits; false skips them (the cross-validation's folds, which report no interval).
  bool loss_scale_uncertainty = true;
  /// The step of the differences [-] (absolute in e, mu, r; relative in s): see docs/calibration.md
  /// why a large one (the prediction is piecewise smooth in the coefficients).
  double difference_step = 0.03;
  int max_iterations = 50;
  /// Start from the `starts` best of `initial` and a 5 x 5 grid over (e, mu) (the objective has
  /// several basins), keeping the fit of lowest cost; false: from `initial` only.
  bool grid_start = true;
  int starts = 3;  ///< >= 1
  /// Called after each solver iteration (from the calling thread) with its number.
  std::function<void(int iteration)> progress;
};

/// One coefficient's estimate: value, standard deviation and the 95 % interval value +- 1.96 sd
/// (normal approximation), not cut at the bounds (lower may be < 0: the docs say how to read it).
struct CoefficientEstimate {
  std::string name;  ///< "restitution", "static_friction", "dynamic_friction", "inertia_scale"
  double value = 0.0;
  double std_dev = 0.0;  ///< infinite when the covariance is singular (not identifiable)
  double lower = 0.0, upper = 0.0;
  bool at_bound = false;  ///< the value lies on a bound of its parameter
};

struct IdentificationResult {
  Coefficients coefficients;
  std::vector<CoefficientEstimate> estimates;  ///< e, mu_s, mu_d (derived for one mu), [s]
  std::vector<std::string> parameter_names;    ///< the fitted parameters, in covariance order
  /// Of the fitted parameters: the linearised one at the optimum, plus (automatic loss scale)
  /// loss_scale_shift loss_scale_shift^T, the loss scale's part.
  Eigen::MatrixXd covariance;
  double residual_sigma = 0.0;  ///< the residuals' estimated standard deviation (covariance scale)
  double loss_scale = 0.0;      ///< the Cauchy scale of the final fit
  /// The automatic scale's one-standard-deviation range [-] (twice the order statistics of the
  /// first stage's |r| sqrt(n) / 2 ranks either side of the median), and half the change of the
  /// fitted parameters (covariance order) between the refits there: the parameters' standard
  /// deviation due to the scale. Both scales equal loss_scale and the shift is empty for a fixed
  /// scale or without IdentificationOptions::loss_scale_uncertainty.
  double loss_scale_low = 0.0, loss_scale_high = 0.0;
  Eigen::VectorXd loss_scale_shift;
  std::vector<LandingResidual> residuals;  ///< per landing, objects' landings in order
  /// Each case's residual at the fit (identifyCases(); for landings the same as `residuals`).
  std::vector<Eigen::VectorXd> case_residuals;
  double rms_cases = 0.0;  ///< sqrt of the mean over cases of |r|^2 (a robot impact's whole r)
  double rms_linear = 0.0, rms_angular = 0.0;  ///< over the landings (|r| of each 3-vector)
  int landings = 0;
  int iterations = 0;
  bool converged = false;
  std::string summary;  ///< Ceres' one-line report
};

/// Fits the coefficients to every landing of `objects` (at least one landing; throws
/// std::invalid_argument otherwise, or if options are out of range), evaluating the landings in
/// parallel on `pool`.
IdentificationResult identifyCoefficients(const std::vector<ObjectLandings>& objects,
                                          const IdentificationOptions& options,
                                          core::WorkerPool& pool);

/// One measured outcome the fit scores, whatever it is (a landing, a robot's impact): its residual
/// vector under the coefficients, of a fixed length, dimensionless (errors relative to the
/// outcome's own scale, so that cases weigh alike). Called from several threads at once (it must
/// be thread safe); a non-finite residual or an exception marks the point as one the case cannot
/// be predicted at (Ceres steps back).
using CaseResidual = std::function<Eigen::VectorXd(const Coefficients&)>;

/// The fit of identifyCoefficients() over any cases, `sizes[i]` the length of case i's residual:
/// the same starts, loss, bounds, differences and covariance (the residuals' scale from the median
/// over cases of |r|^2 / median of chi-square(sizes[i])). Fills every field of the result but
/// `residuals`, rms_linear and rms_angular (landing-specific). Throws std::invalid_argument as
/// identifyCoefficients(), and for no case or sizes not matching.
IdentificationResult identifyCases(const std::vector<CaseResidual>& cases,
                                   const std::vector<int>& sizes,
                                   const IdentificationOptions& options, core::WorkerPool& pool);

/// The residuals of every landing of `objects` under `coefficients` (objects' landings in order).
std::vector<LandingResidual> landingResiduals(const std::vector<ObjectLandings>& objects,
                                              const Coefficients& coefficients,
                                              const PredictionOptions& options,
                                              core::WorkerPool& pool);

/// sqrt of the mean over cases of |r|^2.
double rmsOfCases(const std::vector<Eigen::VectorXd>& residuals);

/// RMS over landings of |r.head(3)| (linear) and |r.tail(3)| (angular).
std::pair<double, double> rmsErrors(const std::vector<LandingResidual>& residuals);

}  // namespace collision_response::calibration
