#include "collision_response/core/coefficient_distribution.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "collision_response/core/errors.h"
#include "collision_response/core/standard_normal.h"

namespace collision_response::core {

CoefficientDistribution CoefficientDistribution::normal(double mean, double std_dev) {
  CoefficientDistribution d;
  d.type = Type::kNormal;
  d.mean = mean;
  d.std_dev = std_dev;
  return d;
}

CoefficientDistribution CoefficientDistribution::interval(double min, double max) {
  CoefficientDistribution d;
  d.type = Type::kInterval;
  d.min = min;
  d.max = max;
  return d;
}

namespace {
// Standard deviations from the mean beyond which a truncation bound changes no moment (check()).
constexpr double kNegligibleTail = 9.0;
// From this value up (2^-8), Phi(-9) is under a quarter of an ulp: lowerMass() returns 0.
constexpr double kUnseenBesideLowerMass = 1.0 / 256.0;

std::string rangeText(double lower, double upper) {
  std::ostringstream out;
  out << "[" << lower << ", ";
  if (std::isinf(upper))
    out << "infinity";
  else
    out << upper;
  out << "]";
  return out.str();
}
}  // namespace

CheckedDistribution::CheckedDistribution(const CoefficientDistribution& distribution, double lower,
                                         double upper, const std::string& field,
                                         std::optional<Warning>* warning)
    : distribution_(distribution), lower_(lower), upper_(upper) {
  check([](const void* name) { return *static_cast<const std::string*>(name); }, &field, warning);
}

void CheckedDistribution::check(std::string (*name)(const void*), const void* context,
                                std::optional<Warning>* warning) {
  const CoefficientDistribution& distribution = distribution_;
  const double lower = lower_, upper = upper_;
  auto field = [&] { return name(context); };
  if (distribution.type == CoefficientDistribution::Type::kInterval) {
    if (!std::isfinite(distribution.min))
      throw InvalidInput(field() + ".min", "must be a finite number");
    if (!std::isfinite(distribution.max))
      throw InvalidInput(field() + ".max", "must be a finite number");
    if (distribution.min > distribution.max)
      throw InvalidInput(field() + ".min", "an interval needs min <= max");
    if (distribution.min < lower || distribution.max > upper)
      throw InvalidInput(
          field() + (distribution.min < lower ? ".min" : ".max"),
          "the interval must lie in the coefficient's range " + rangeText(lower, upper));
    mean_ = 0.5 * (distribution.min + distribution.max);
    const double width = distribution.max - distribution.min;
    variance_ = width * width / 12.0;
    return;
  }
  if (!std::isfinite(distribution.mean))
    throw InvalidInput(field() + ".mean", "must be a finite number");
  if (!std::isfinite(distribution.std_dev))
    throw InvalidInput(field() + ".std_dev", "must be a finite number");
  if (distribution.std_dev < 0.0)
    throw InvalidInput(field() + ".std_dev", "a standard deviation must be >= 0");
  if (distribution.mean < lower || distribution.mean > upper)
    throw InvalidInput(field() + ".mean",
                       "the mean must lie in the coefficient's range " + rangeText(lower, upper));
  const double s = distribution.std_dev;
  if (s == 0.0) {
    mean_ = distribution.mean;
    variance_ = 0.0;
    return;
  }
  const double alpha = (lower - distribution.mean) / s;
  const double beta = (upper - distribution.mean) / s;
  if (alpha <= -kNegligibleTail && beta >= kNegligibleTail && std::abs(distribution.mean) >= s) {
    // Both bounds 9 or more standard deviations away: the moments below round to those of the
    // normal itself, bit for bit, and are not computed (docs/uncertainty.md). Phi(beta) rounds to
    // 1 (its tail, under 1.2e-19, is below half the gap 5.6e-17 under 1), and so does
    // 1 - Phi(alpha); the variance factor 1 + (alpha phi(alpha) - beta phi(beta)) / kept - shift^2
    // rounds to 1 (|x| phi(x) <= 9.3e-18 each); the mean's shift s (phi(alpha) - phi(beta)) / kept
    // is under 2.1e-18 s, below half an ulp of the mean (at least 5.5e-17 |mean|, |mean| >= s).
    // Phi(alpha) itself is left for quantile() and cdf() to take where it shows (lowerMass()).
    alpha_ = alpha;
    cdf_lower_known_ = false;
    cdf_lower_ = 0.0;
    kept_mass_ = 1.0;
    mean_ = distribution.mean;
    variance_ = s * s;
    return;
  }
  cdf_lower_ = standardNormalCdf(alpha);
  kept_mass_ = standardNormalCdf(beta) - cdf_lower_;
  // Moments of the truncated normal.
  const double pa = standardNormalPdf(alpha);
  const double pb = standardNormalPdf(beta);
  const double shift = (pa - pb) / kept_mass_;
  const double a_term = std::isinf(alpha) ? 0.0 : alpha * pa;
  const double b_term = std::isinf(beta) ? 0.0 : beta * pb;
  mean_ = distribution.mean + s * shift;
  variance_ = s * s * std::max(0.0, 1.0 + (a_term - b_term) / kept_mass_ - shift * shift);
  if (warning != nullptr && 1.0 - kept_mass_ > kTruncationWarningMass) {
    std::ostringstream reason;
    reason << "the normal distribution (mean " << distribution.mean << ", std_dev " << s
           << ") has probability " << 1.0 - kept_mass_ << " outside the coefficient's range "
           << rangeText(lower, upper) << ": sampled as the normal truncated to the range (mean "
           << mean_ << ", std_dev " << std::sqrt(variance_) << ")";
    *warning = Warning{field(), reason.str(), Warning::Kind::kInput};
  }
}

double CheckedDistribution::quantile(double u) const {
  if (distribution_.type == CoefficientDistribution::Type::kInterval)
    return distribution_.min + u * (distribution_.max - distribution_.min);
  if (distribution_.std_dev == 0.0) return distribution_.mean;
  const double x =
      distribution_.mean +
      distribution_.std_dev * standardNormalQuantile(lowerMass(u * kept_mass_) + u * kept_mass_);
  return std::clamp(x, lower_, upper_);  // rounding only: the quantile lies in the range
}

double CheckedDistribution::cdf(double x) const {
  if (distribution_.type == CoefficientDistribution::Type::kInterval) {
    if (distribution_.max == distribution_.min) return x >= distribution_.min ? 1.0 : 0.0;
    return std::clamp((x - distribution_.min) / (distribution_.max - distribution_.min), 0.0, 1.0);
  }
  if (distribution_.std_dev == 0.0) return x >= distribution_.mean ? 1.0 : 0.0;
  if (x <= lower_) return 0.0;
  if (x >= upper_) return 1.0;
  const double below = standardNormalCdf((x - distribution_.mean) / distribution_.std_dev);
  return (below - lowerMass(below)) / kept_mass_;
}

double CheckedDistribution::lowerMass(double beside) const {
  // Phi(alpha) < 1.2e-19 when not known (alpha <= -9): below a quarter of an ulp of any value
  // from 2^-8 up, to which adding it or from which subtracting it changes nothing.
  if (cdf_lower_known_ || beside >= kUnseenBesideLowerMass) return cdf_lower_;
  return standardNormalCdf(alpha_);
}

}  // namespace collision_response::core
