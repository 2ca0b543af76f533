// The identification on synthetic recordings (synthetic_recordings.h: the true motion from the
// episode with known coefficients and a closed-form cube-corner geometry, sampled at 148 Hz, with
// Gaussian tracking noise): the known coefficients lie in the reported 95 % intervals, the
// intervals shrink as landings are added (about as 1/sqrt(n)), and over repeated noise draws the
// spread of the estimates agrees with the reported standard deviation. CR_CALIBRATION_SMALL=1 (the
// sanitizer pass) fits fewer landings in each test; every assertion holds at both sizes.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "collision_response/calibration/cross_validation.h"
#include "collision_response/calibration/identification.h"
#include "collision_response/calibration/landing_extraction.h"
#include "synthetic_recordings.h"

using namespace collision_response;
using namespace collision_response::calibration;
using namespace collision_response::calibration::test;

namespace {

constexpr double kE = 0.45, kMu = 0.3;   // the true coefficients
constexpr double kSigmaPosition = 3e-4;  // [m] tracking noise (the tosses' fits: ~1e-4)
constexpr double kSigmaRotation = 3e-3;  // [rad]

/// `count` true tosses whose noise-free recording gives a landing.
std::vector<PoseTrack> trueTosses(int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<PoseTrack> tosses;
  const ObjectModel cube = syntheticCube();
  while (static_cast<int>(tosses.size()) < count) {
    PoseTrack track = trueToss(rng, kE, kMu, core::ImpactLaw::kStronge);
    if (track.size() < 30) continue;
    if (extractLandings(track, cube.shape, cube.floor_height).front().ok)
      tosses.push_back(std::move(track));
  }
  return tosses;
}

/// The landings of noisy recordings of the tosses (noise seeded by `seed`), at most `limit`.
std::vector<ObjectLandings> landings(const std::vector<PoseTrack>& tosses, unsigned seed,
                                     int limit = 1 << 30) {
  std::mt19937 rng(seed);
  std::vector<ObjectLandings> out{{syntheticCube(), {}}};
  for (const auto& truth : tosses) {
    if (static_cast<int>(out[0].landings.size()) >= limit) break;
    const PoseTrack track = noisy(truth, rng, kSigmaPosition, kSigmaRotation);
    const Extraction x = extractLandings(track, out[0].object.shape, 0.0).front();
    if (x.ok) out[0].landings.push_back(x.landing);
  }
  return out;
}

/// The defaults, from the grid's best point only (one basin here: the data are the model's own).
IdentificationOptions options() {
  IdentificationOptions o;
  o.starts = 1;
  return o;
}

const CoefficientEstimate& estimate(const IdentificationResult& r, const std::string& name) {
  for (const auto& e : r.estimates)
    if (e.name == name) return e;
  throw std::runtime_error("no estimate " + name);
}

TEST(Identification, KnownCoefficientsLieInTheIntervals) {
  core::WorkerPool pool(2);
  const auto data = landings(trueTosses(30, 11), 101);
  ASSERT_GE(data[0].landings.size(), 25u);
  const IdentificationResult fit = identifyCoefficients(data, options(), pool);
  const auto& e = estimate(fit, "restitution");
  const auto& mu = estimate(fit, "static_friction");
  EXPECT_LE(e.lower, kE);
  EXPECT_GE(e.upper, kE);
  EXPECT_LE(mu.lower, kMu);
  EXPECT_GE(mu.upper, kMu);
  // Informative intervals (the start is 0.3, 0.3: the fit moved e by 0.15).
  EXPECT_GT(e.std_dev, 0.0);
  EXPECT_LT(e.upper - e.lower, 0.1);
  EXPECT_LT(mu.upper - mu.lower, 0.1);
  EXPECT_DOUBLE_EQ(fit.coefficients.dynamic_friction, fit.coefficients.static_friction);
}

TEST(Identification, IntervalsShrinkAsLandingsAreAdded) {
  core::WorkerPool pool(2);
  // Six times the landings at either size.
  const int most = sized(36, 24);
  const auto tosses = trueTosses(most, 12);
  double previous_e = INFINITY, previous_mu = INFINITY, first_e = 0.0, first_mu = 0.0;
  for (int n : {most / 6, most / 2, most}) {
    const IdentificationResult fit =
        identifyCoefficients(landings(tosses, 202, n), options(), pool);
    const double sd_e = estimate(fit, "restitution").std_dev;
    const double sd_mu = estimate(fit, "static_friction").std_dev;
    EXPECT_LT(sd_e, previous_e) << n << " landings";
    EXPECT_LT(sd_mu, previous_mu) << n << " landings";
    if (n == most / 6) first_e = sd_e, first_mu = sd_mu;
    previous_e = sd_e;
    previous_mu = sd_mu;
  }
  // Six times the landings: about 0.41 of the deviation (1/sqrt(6)) if the landings were alike;
  // they are not (a glancing corner says more about mu than a flat fall): at most 0.7 of it.
  EXPECT_LT(previous_e, 0.7 * first_e);
  EXPECT_LT(previous_mu, 0.7 * first_mu);
}

// The reported standard deviation against the spread of the estimates over 16 noise draws of the
// same tosses. The sample deviation of 16 draws is itself uncertain by about 1/sqrt(2 * 15) = 18 %
// (so its 95 % range is about 0.64..1.36 of the true spread); the covariance is a linearisation
// with the residuals' variance pooled over the 6 components: a factor 2 either way.
TEST(Identification, SpreadOfEstimatesAgreesWithTheReportedDeviation) {
  core::WorkerPool pool(2);
  // Fewer tosses make each estimate less certain, not the comparison: that rests on the draws.
  const auto tosses = trueTosses(sized(14, 8), 13);
  std::vector<double> es, mus;
  double sd_e = 0.0, sd_mu = 0.0, scale_e = 0.0, scale_mu = 0.0;
  constexpr int kDraws = 16;
  for (int draw = 0; draw < kDraws; ++draw) {
    const IdentificationResult fit =
        identifyCoefficients(landings(tosses, 300 + draw), options(), pool);
    es.push_back(fit.coefficients.restitution);
    mus.push_back(fit.coefficients.static_friction);
    sd_e += estimate(fit, "restitution").std_dev / kDraws;
    sd_mu += estimate(fit, "static_friction").std_dev / kDraws;
    // The automatic loss scale's part of the deviation (identification.h, loss_scale_shift).
    ASSERT_EQ(fit.loss_scale_shift.size(), 2);
    scale_e += std::abs(fit.loss_scale_shift[0]) / kDraws;
    scale_mu += std::abs(fit.loss_scale_shift[1]) / kDraws;
  }
  auto spread = [](const std::vector<double>& x) {
    double mean = 0.0, sum = 0.0;
    for (double v : x) mean += v / x.size();
    for (double v : x) sum += (v - mean) * (v - mean);
    return std::sqrt(sum / (x.size() - 1));
  };
  const double spread_e = spread(es), spread_mu = spread(mus);
  std::printf("spread / reported deviation: e %.4f / %.4f = %.2f, mu %.4f / %.4f = %.2f\n",
              spread_e, sd_e, spread_e / sd_e, spread_mu, sd_mu, spread_mu / sd_mu);
  EXPECT_GT(spread_e / sd_e, 0.5) << "spread " << spread_e << " reported " << sd_e;
  EXPECT_LT(spread_e / sd_e, 2.0) << "spread " << spread_e << " reported " << sd_e;
  EXPECT_GT(spread_mu / sd_mu, 0.5) << "spread " << spread_mu << " reported " << sd_mu;
  EXPECT_LT(spread_mu / sd_mu, 2.0) << "spread " << spread_mu << " reported " << sd_mu;
  // The reported deviation includes the loss scale's part; the lower bounds above keep the whole
  // within twice the spread over draws. The model is right here, so moving the scale by its own
  // deviation moves the optimum by less than the noise does: the scale's part stays below the
  // spread over draws.
  std::printf("loss scale's part of the deviation: e %.5f, mu %.5f\n", scale_e, scale_mu);
  EXPECT_LT(scale_e, spread_e);
  EXPECT_LT(scale_mu, spread_mu);
}

// Cross-validation on landings made with the true coefficients: every fold finds them (within a
// few of the full fit's deviations) and the held-out error is close to the training error. The
// deviation is the fit's linearisation, within a factor 2 of the estimates' actual spread
// (SpreadOfEstimatesAgreesWithTheReportedDeviation measures 1.76 for mu): 4 of them with that
// factor. (Since slow slips are braked in the resting analysis, docs/physics.md "Slow slips", the
// fit reports mu's deviation as 0.00060 instead of 0.00082, its estimate 0.2984 as before, and one
// fold's 0.2965 lies 4.6 reported deviations from 0.3.)
TEST(Identification, CrossValidationOfAConsistentModel) {
  core::WorkerPool pool(2);
  const auto data = landings(trueTosses(sized(20, 14), 14), 400);
  const IdentificationResult fit = identifyCoefficients(data, options(), pool);
  const CrossValidation cv = crossValidate(data, options(), 4, pool);
  ASSERT_EQ(cv.fitted.size(), 4u);
  ASSERT_EQ(cv.held_out.size(), data[0].landings.size());
  for (const auto& c : cv.fitted) {
    EXPECT_NEAR(c.restitution, kE,
                4.0 * 2.0 * estimate(fit, "restitution").std_dev * std::sqrt(4.0 / 3));
    EXPECT_NEAR(c.static_friction, kMu,
                4.0 * 2.0 * estimate(fit, "static_friction").std_dev * std::sqrt(4.0 / 3));
  }
  EXPECT_GE(cv.rms_linear, 0.9 * fit.rms_linear);
  EXPECT_LT(cv.rms_linear, 1.5 * fit.rms_linear);
}

}  // namespace
