#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <string>
#include <vector>

#include "collision_response/core/warning.h"

namespace collision_response::core {

/// How an outcome distribution was obtained (docs/uncertainty.md).
enum class UncertaintyMethod {
  kNone,     ///< no propagation
  kLinear,   ///< first order: the Jacobian w.r.t. the coefficients at their means
  kSampled,  ///< quasi-random samples of the coefficients, each solved by computeResponse()
};

const char* toString(UncertaintyMethod method);  ///< "none", "linear", "sampled"

/// The distribution of the outcome of an impact whose contact coefficients are uncertain
/// (computeOutcomeDistribution(), docs/uncertainty.md).
///
/// Quantities (entries of mean, q05, q95, rows and columns of covariance), as the rows of
/// ImpactDerivatives: for each movable body i of the scene, in scene order, its post-impact twist
/// "bodies[i].twist.linear.x" .. "bodies[i].twist.angular.z" (linear velocity of the centre of
/// mass [m/s], angular velocity [rad/s], world); then for each contact c, "impulses[c].
/// normal_impulse" and "impulses[c].friction_impulse.x/y/z" [N s, world].
struct OutcomeDistribution {
  UncertaintyMethod method = UncertaintyMethod::kNone;
  std::size_t samples = 0;          ///< kSampled: solves averaged; kLinear: 0
  std::vector<std::string> labels;  ///< one per quantity, as above
  Eigen::VectorXd mean;             ///< [units of the label]
  Eigen::MatrixXd covariance;       ///< [product of the two labels' units]
  /// 5 % and 95 % quantiles of each quantity on its own. kLinear: mean -/+ 1.645 standard
  /// deviations (the normal approximation); kSampled: the empirical quantiles (linear
  /// interpolation between order statistics).
  Eigen::VectorXd q05;
  Eigen::VectorXd q95;
  /// Per contact of the scene: the probability that it ends the impact sticking
  /// (ContactImpulse::sticking). kSampled: the fraction of samples; kLinear: from the linearised
  /// margin of the mode the contact is in at the means (docs/uncertainty.md).
  std::vector<double> stick_probability;
  /// computeBodyOutcomeDistribution() only: per velocity unknown, the probability that its
  /// magnitude exceeds its limit (kSampled: the fraction of samples; kLinear: the normal tail
  /// P(|v| > limit) of N(mean, covariance_rr)); empty otherwise.
  std::vector<double> limit_probability;
  /// Truncated normals, mu_d > mu_s in samples (capped at mu_s); kLinear: a linearisation at a
  /// mode switch, a stick probability in [0.001, 0.999] (the spread reaches a stick/slip switch).
  std::vector<Warning> warnings;
};

}  // namespace collision_response::core
