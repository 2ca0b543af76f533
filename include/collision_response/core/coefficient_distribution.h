#pragma once

#include <optional>
#include <string>
#include <type_traits>

#include "collision_response/core/warning.h"

namespace collision_response::core {

/// The distribution of one uncertain contact coefficient (restitution e, static friction mu_s,
/// dynamic friction mu_d; dimensionless), docs/uncertainty.md.
///
/// A coefficient only has values in its admissible range [lower, upper] (e: [0, 1]; mu_s, mu_d:
/// [0, infinity)). An interval must lie inside it (else the request is refused). A normal
/// distribution always reaches beyond it: the coefficient is then the normal *conditioned* on the
/// range (a truncated normal: the density of the normal inside, renormalised; no value is clamped
/// onto a bound). Its mean must lie inside the range, and when the mass cut off is above
/// kTruncationWarningMass the answer says so in a warning with the mass and the truncated
/// distribution's own mean and standard deviation.
struct CoefficientDistribution {
  enum class Type {
    kNormal,    ///< mean, std_dev >= 0 (0: the mean exactly)
    kInterval,  ///< uniform on [min, max], min <= max (min == max: that value exactly)
  };
  Type type = Type::kNormal;
  double mean = 0.0;     ///< kNormal: mean of the normal before truncation
  double std_dev = 0.0;  ///< kNormal: its standard deviation
  double min = 0.0;      ///< kInterval: lower end
  double max = 0.0;      ///< kInterval: upper end

  static CoefficientDistribution normal(double mean, double std_dev);
  static CoefficientDistribution interval(double min, double max);
};

/// Above this probability mass outside the admissible range, a truncated normal is reported in a
/// warning.
constexpr double kTruncationWarningMass = 1e-6;

/// A CoefficientDistribution checked against its admissible range [lower, upper], with the
/// moments and the quantile function of the distribution actually sampled (truncated for normals).
class CheckedDistribution {
 public:
  /// Throws InvalidInput naming `field` + ".std_dev", ".min", ".max" or ".mean": a non-finite
  /// value, std_dev < 0, min > max, an interval outside [lower, upper], a normal's mean outside
  /// it. `warning` (if given) receives the truncation warning, if any, naming `field`.
  CheckedDistribution(const CoefficientDistribution& distribution, double lower, double upper,
                      const std::string& field, std::optional<Warning>* warning = nullptr);
  /// The same, with the field's name given by `field()` (a callable returning std::string), called
  /// only when it is needed: an error or a warning (callers that check many distributions build
  /// no names for the valid ones).
  template <class FieldName,
            class = std::enable_if_t<std::is_invocable_r_v<std::string, const FieldName&>>>
  CheckedDistribution(const CoefficientDistribution& distribution, double lower, double upper,
                      const FieldName& field, std::optional<Warning>* warning = nullptr)
      : distribution_(distribution), lower_(lower), upper_(upper) {
    check([](const void* name) { return (*static_cast<const FieldName*>(name))(); }, &field,
          warning);
  }

  double mean() const { return mean_; }
  double variance() const { return variance_; }
  /// The value with probability u below it, u in [0, 1] (the inverse CDF; inside [lower, upper]).
  double quantile(double u) const;
  /// P(value <= x).
  double cdf(double x) const;
  /// The probability mass a normal had outside [lower, upper] (0 for an interval).
  double truncatedMass() const { return 1.0 - kept_mass_; }

 private:
  // The checks and moments of the constructors; name(context) is the field's name.
  void check(std::string (*name)(const void*), const void* context,
             std::optional<Warning>* warning);

  // Phi(alpha) to add to or subtract from `beside` (a probability): cdf_lower_, or, when it was
  // not computed (bounds 9+ standard deviations away), 0 where it cannot change `beside` and
  // Phi(alpha) where it can.
  double lowerMass(double beside) const;

  CoefficientDistribution distribution_;
  double lower_ = 0.0;
  double upper_ = 0.0;
  double alpha_ = 0.0;           // normal: (lower - mean) / std_dev
  bool cdf_lower_known_ = true;  // false: cdf_lower_ is 0 in place of Phi(alpha) < 1.2e-19
  double cdf_lower_ = 0.0;       // normal: Phi(alpha)
  double kept_mass_ = 1.0;       // normal: Phi(beta) - Phi(alpha)
  double mean_ = 0.0;
  double variance_ = 0.0;
};

}  // namespace collision_response::core
