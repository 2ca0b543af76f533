// Fitting and scoring the landing models of the real-tosses benchmark on extracted landings
// (docs/benchmarks.md, "Real tosses": the metric, the optimiser).
#pragma once

#include <vector>

#include "landing_model.h"
#include "toss_data.h"

namespace collision_response::bench {

/// A prediction's errors on one landing, at the start of the measured post-landing flight, each
/// relative to the pre-impact speed |v_before| (dimensionless): the linear velocity's
/// |v_predicted - v_measured| / |v_before| and the angular velocity's
/// h |w_predicted - w_measured| / |v_before| (h the half width: the error as the speed it gives
/// a point at a face's centre). Normalising the angular error by |w_before| instead would divide by
/// as little as 0.5 rad/s on some kept tosses (docs/benchmarks.md, "Real tosses").
struct LandingError {
  double linear = 0.0;
  double angular = 0.0;
};

/// The median of `v` (the mean of the two middle values for an even count; NaN when empty).
double median(std::vector<double> v);

/// Runs the model on the landing (from its pre-impact state to the start of its post-landing
/// flight) and measures the errors.
LandingError landingError(LandingModel& model, const std::vector<double>& values,
                          const Landing& landing, const TossedCube& cube);

/// The fit's objective: sqrt(mean over the landings of (linear^2 + angular^2)/2). A model that
/// throws or gives a non-finite state scores +infinity.
double fitObjective(LandingModel& model, const std::vector<double>& values,
                    const std::vector<Landing>& landings, const TossedCube& cube);

struct FitOptions {
  int starts = 4;  ///< Nelder-Mead starts: the parameters' initial values, then seeded random ones
  int max_evaluations = 200;  ///< per start
  unsigned seed = 24;
};

struct FitResult {
  std::vector<double> values;  ///< in parameters() order
  double objective = 0.0;      ///< on the training landings
  int evaluations = 0;         ///< in all
};

/// Minimises fitObjective() over the parameters' box (log-scaled ones in log space) by
/// Nelder-Mead from several starts, each simplex kept inside the box by clamping.
FitResult fitLandingModel(LandingModel& model, const std::vector<Landing>& training,
                          const TossedCube& cube, const FitOptions& options = {});

/// A model's score on held-out landings.
struct LandingScore {
  int landings = 0;
  double rms_linear = 0.0, median_linear = 0.0;    ///< of LandingError::linear
  double rms_angular = 0.0, median_angular = 0.0;  ///< of LandingError::angular
  double median_time_us = 0.0;                     ///< median wall time of one simulate() [us]
  int failures = 0;  ///< landings whose simulate() threw or gave a non-finite state
  /// Each held-out landing's errors, in the order given (for paired comparisons).
  std::vector<double> linear, angular;
};

/// The difference RMS(a) - RMS(b) of two models' errors on the same landings, and its 95 %
/// interval from a paired bootstrap (2000 resamples of the landings, seeded): an interval below 0
/// says that a is more accurate than b beyond the sampling noise of the held-out half.
struct RmsDifference {
  double difference = 0.0, lower = 0.0, upper = 0.0;
};
RmsDifference pairedRmsDifference(const std::vector<double>& a, const std::vector<double>& b);

LandingScore scoreLandingModel(LandingModel& model, const std::vector<double>& values,
                               const std::vector<Landing>& held_out, const TossedCube& cube,
                               int time_repetitions = 3);

}  // namespace collision_response::bench
