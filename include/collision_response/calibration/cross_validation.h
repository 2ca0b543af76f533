// k-fold cross-validation of an identification (docs/calibration.md, "How sure"): the landings
// dealt into k folds, each fold predicted by the coefficients fitted on the others.
#pragma once

#include <functional>
#include <vector>

#include "collision_response/calibration/identification.h"

namespace collision_response::calibration {

struct CrossValidation {
  int folds = 0;
  /// Each landing's residual when held out (objects' landings in order).
  std::vector<LandingResidual> held_out;
  double rms_linear = 0.0, rms_angular = 0.0;  ///< over held_out, as rmsErrors()
  std::vector<Coefficients> fitted;            ///< per fold
  /// crossValidateCases(): each case's residual when held out, and rmsOfCases() over them.
  std::vector<Eigen::VectorXd> held_out_cases;
  double rms_cases = 0.0;
};

/// Landing k (counting the objects' landings in order) goes to fold k mod `folds`. folds in
/// [2, number of landings], else std::invalid_argument. progress(fold) before each fold's fit.
/// warm_start: each fold's fit starts there (the fit on all landings: folds differ little from
/// it) instead of searching the grid (options.grid_start).
CrossValidation crossValidate(const std::vector<ObjectLandings>& objects,
                              const IdentificationOptions& options, int folds,
                              core::WorkerPool& pool,
                              const std::function<void(int fold)>& progress = {},
                              const Coefficients* warm_start = nullptr);

/// The same over any cases (identifyCases()): case k to fold k mod `folds`; fills folds, fitted,
/// held_out_cases and rms_cases.
CrossValidation crossValidateCases(const std::vector<CaseResidual>& cases,
                                   const std::vector<int>& sizes,
                                   const IdentificationOptions& options, int folds,
                                   core::WorkerPool& pool,
                                   const std::function<void(int fold)>& progress = {},
                                   const Coefficients* warm_start = nullptr);

}  // namespace collision_response::calibration
