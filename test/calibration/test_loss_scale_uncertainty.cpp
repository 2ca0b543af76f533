// The automatic loss scale's uncertainty in the covariance (identification.h,
// IdentificationOptions::loss_scale_uncertainty; docs/calibration.md, "How sure"), on cases whose
// residuals are linear in the coefficients, r_i = (e - a_i, mu - b): the fit of e is then the
// Cauchy M-estimate of the location of the a_i, computed here independently (the root of its
// estimating equation by bisection) at the first stage's scale 0.25, at the automatic scale c
// (twice the median |r| there) and at the scale's one-deviation range (the order statistics sqrt(n)
// / 2 ranks either side of the median). The a_i are skewed (a cluster and a tail), so the
// M-estimate moves with c and the scale's part of e's variance, ((e(c_high) - e(c_low)) / 2)^2, is
// known.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "collision_response/calibration/identification.h"

using namespace collision_response;
using namespace collision_response::calibration;

namespace {

constexpr double kMu = 0.3;  // every case's friction residual vanishes here

/// 41 points in [0.40, 0.50] and a tail of 20 in [0.60, 0.79]: a skewed sample.
std::vector<double> locations() {
  std::vector<double> a;
  for (int i = 0; i <= 40; ++i) a.push_back(0.40 + 0.0025 * i);
  for (int i = 0; i < 20; ++i) a.push_back(0.60 + 0.01 * i);
  return a;
}

/// The Cauchy M-estimate of location at scale c: the root of sum (e - a_i) / (1 + (e - a_i)^2 /
/// c^2) in [min a, max a] nearest the median (bisection from the median towards the root; the
/// estimating function is decreasing through it for these scales).
double cauchyLocation(const std::vector<double>& a, double c) {
  auto psi = [&](double e) {
    double s = 0.0;
    for (double ai : a) s += (e - ai) / (1.0 + (e - ai) * (e - ai) / (c * c));
    return s;
  };
  std::vector<double> sorted = a;
  std::sort(sorted.begin(), sorted.end());
  double lo = sorted.front(), hi = sorted.back();
  EXPECT_LT(psi(lo), 0.0);
  EXPECT_GT(psi(hi), 0.0);
  for (int k = 0; k < 200; ++k) {
    const double mid = 0.5 * (lo + hi);
    (psi(mid) < 0.0 ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

TEST(LossScaleUncertainty, ScaleRangeAndShiftMatchTheCauchyLocationEstimate) {
  const std::vector<double> a = locations();
  std::vector<CaseResidual> cases;
  for (double ai : a)
    cases.push_back([ai](const Coefficients& c) -> Eigen::VectorXd {
      return Eigen::Vector2d(c.restitution - ai, c.static_friction - kMu);
    });
  const std::vector<int> sizes(cases.size(), 2);
  core::WorkerPool pool(2);
  IdentificationOptions options;  // automatic scale, its uncertainty included
  const IdentificationResult fit = identifyCases(cases, sizes, options, pool);

  // The reference: the first stage's estimate at 0.25, the scale from its |r| (the friction
  // residual is 0 there), the second stage's estimate, and those at the range's ends.
  const double first = cauchyLocation(a, 0.25);
  std::vector<double> norms;
  for (double ai : a) norms.push_back(std::abs(first - ai));
  std::sort(norms.begin(), norms.end());
  const int n = static_cast<int>(norms.size());
  const double ranks = 0.5 * std::sqrt(static_cast<double>(n));
  const double c = 2.0 * norms[n / 2];
  const double c_low = 2.0 * norms[static_cast<int>(std::lround(n / 2 - ranks))];
  const double c_high = 2.0 * norms[static_cast<int>(std::lround(n / 2 + ranks))];
  const double e = cauchyLocation(a, c), e_low = cauchyLocation(a, c_low),
               e_high = cauchyLocation(a, c_high);
  const double shift = 0.5 * (e_high - e_low);
  std::printf(
      "scale %.5f [%.5f, %.5f] (reference %.5f [%.5f, %.5f]); e %.5f (%.5f), shift %.5f "
      "(%.5f), sd %.5f\n",
      fit.loss_scale, fit.loss_scale_low, fit.loss_scale_high, c, c_low, c_high,
      fit.coefficients.restitution, e, fit.loss_scale_shift[0], shift, fit.estimates[0].std_dev);
  // The ranks fall between distinct order statistics (a_i 0.0025 apart at least), so the fit's
  // first-stage round-off cannot pick another one.
  EXPECT_NEAR(fit.loss_scale, c, 1e-3);
  EXPECT_NEAR(fit.loss_scale_low, c_low, 1e-3);
  EXPECT_NEAR(fit.loss_scale_high, c_high, 1e-3);
  EXPECT_LT(c_low, c);
  EXPECT_GT(c_high, c);
  EXPECT_NEAR(fit.coefficients.restitution, e, 2e-4);
  ASSERT_EQ(fit.loss_scale_shift.size(), 2);
  // The estimate moves visibly with the scale here (the tail weighs more at a larger c).
  ASSERT_GT(shift, 2e-3);
  EXPECT_NEAR(fit.loss_scale_shift[0], shift, 0.1 * shift);
  EXPECT_NEAR(fit.loss_scale_shift[1], 0.0, 1e-4);  // mu fits exactly at every scale
  // The reported variance of e is the linearised one plus the shift's square: at least the shift.
  EXPECT_GE(fit.estimates[0].std_dev, 0.9 * shift);
  EXPECT_NEAR(fit.covariance(0, 0), fit.estimates[0].std_dev * fit.estimates[0].std_dev, 1e-15);

  // Without it (a fixed scale, or the option off) the range collapses and the deviation is the
  // linearised one alone, below the shift here.
  options.loss_scale_uncertainty = false;
  const IdentificationResult plain = identifyCases(cases, sizes, options, pool);
  EXPECT_EQ(plain.loss_scale_shift.size(), 0);
  EXPECT_EQ(plain.loss_scale_low, plain.loss_scale);
  EXPECT_NEAR(plain.coefficients.restitution, fit.coefficients.restitution, 1e-12);
  EXPECT_NEAR(fit.estimates[0].std_dev * fit.estimates[0].std_dev,
              plain.estimates[0].std_dev * plain.estimates[0].std_dev +
                  fit.loss_scale_shift[0] * fit.loss_scale_shift[0],
              1e-12);
}

}  // namespace
