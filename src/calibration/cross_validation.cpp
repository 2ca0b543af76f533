#include "collision_response/calibration/cross_validation.h"

#include <stdexcept>
#include <string>

namespace collision_response::calibration {

CrossValidation crossValidate(const std::vector<ObjectLandings>& objects,
                              const IdentificationOptions& options, int folds,
                              core::WorkerPool& pool, const std::function<void(int fold)>& progress,
                              const Coefficients* warm_start) {
  IdentificationOptions fold_options = options;
  fold_options.loss_scale_uncertainty = false;  // the folds report no interval
  if (warm_start != nullptr) {
    fold_options.grid_start = false;
    fold_options.initial = *warm_start;
  }
  int total = 0;
  for (const auto& o : objects) total += static_cast<int>(o.landings.size());
  if (folds < 2 || folds > total)
    throw std::invalid_argument("cross-validation: folds must be in [2, " + std::to_string(total) +
                                "] (the landings), not " + std::to_string(folds));
  CrossValidation out;
  out.folds = folds;
  out.held_out.resize(total);
  for (int fold = 0; fold < folds; ++fold) {
    if (progress) progress(fold);
    std::vector<ObjectLandings> training, testing;
    std::vector<int> tested;  // global indices of the held-out landings, in order
    int k = 0;
    for (const auto& o : objects) {
      training.push_back({o.object, {}});
      testing.push_back({o.object, {}});
      for (const auto& l : o.landings) {
        if (k % folds == fold) {
          testing.back().landings.push_back(l);
          tested.push_back(k);
        } else {
          training.back().landings.push_back(l);
        }
        ++k;
      }
    }
    const IdentificationResult fit = identifyCoefficients(training, fold_options, pool);
    out.fitted.push_back(fit.coefficients);
    const auto residuals = landingResiduals(testing, fit.coefficients, options.prediction, pool);
    for (size_t i = 0; i < tested.size(); ++i) out.held_out[tested[i]] = residuals[i];
  }
  std::tie(out.rms_linear, out.rms_angular) = rmsErrors(out.held_out);
  return out;
}

CrossValidation crossValidateCases(const std::vector<CaseResidual>& cases,
                                   const std::vector<int>& sizes,
                                   const IdentificationOptions& options, int folds,
                                   core::WorkerPool& pool,
                                   const std::function<void(int fold)>& progress,
                                   const Coefficients* warm_start) {
  IdentificationOptions fold_options = options;
  fold_options.loss_scale_uncertainty = false;  // the folds report no interval
  if (warm_start != nullptr) {
    fold_options.grid_start = false;
    fold_options.initial = *warm_start;
  }
  const int total = static_cast<int>(cases.size());
  if (folds < 2 || folds > total)
    throw std::invalid_argument("cross-validation: folds must be in [2, " + std::to_string(total) +
                                "] (the cases), not " + std::to_string(folds));
  CrossValidation out;
  out.folds = folds;
  out.held_out_cases.resize(total);
  for (int fold = 0; fold < folds; ++fold) {
    if (progress) progress(fold);
    std::vector<CaseResidual> training;
    std::vector<int> training_sizes;
    for (int k = 0; k < total; ++k)
      if (k % folds != fold) {
        training.push_back(cases[k]);
        training_sizes.push_back(sizes[k]);
      }
    const IdentificationResult fit = identifyCases(training, training_sizes, fold_options, pool);
    out.fitted.push_back(fit.coefficients);
    for (int k = fold; k < total; k += folds) out.held_out_cases[k] = cases[k](fit.coefficients);
  }
  out.rms_cases = rmsOfCases(out.held_out_cases);
  return out;
}

}  // namespace collision_response::calibration
