// The reference for the linear method's stick probability of a sliding contact whose normal is
// uncertain (test_geometry_uncertainty, test_robot_uncertainty), from the test's own differences
// of the solver, independent of the library's derivatives.
#pragma once

#include <gtest/gtest.h>

#include <cmath>

namespace collision_response::testing {

/// P(stick) = Phi(margin / (sigma |g|)) to first order in the normal's tilt (a, b), each tilt with
/// standard deviation `sigma`: margin = mu_s - mu*(0, 0), mu*(a, b) = mu_d - s / (ds/dmu_d) the
/// mu_d at which the linearised slip speed would vanish, g the margin's slope over the tilt.
/// `speed(a, b, mu_d)` is the contact's tangential slip speed after a solve with the normal tilted
/// by (a, b) along two orthonormal tangents (any pair: both tilts have the same sigma, so the
/// margin's variance does not depend on the basis) and the given mu_d. ds/dmu_d by central
/// differences with step 1e-6 at each tilt, g by central differences of mu* with step 1e-4.
template <class Speed>
double firstOrderStickProbability(Speed&& speed, double mu_s, double mu_d, double sigma) {
  auto mu_star = [&](double a, double b) {
    const double k = 1e-6;
    const double rate = (speed(a, b, mu_d + k) - speed(a, b, mu_d - k)) / (2.0 * k);
    EXPECT_LT(rate, 0.0) << "more friction must slow the slip";
    return mu_d - speed(a, b, mu_d) / rate;
  };
  const double h = 1e-4;
  const double g_a = -(mu_star(h, 0.0) - mu_star(-h, 0.0)) / (2.0 * h);
  const double g_b = -(mu_star(0.0, h) - mu_star(0.0, -h)) / (2.0 * h);
  const double margin = mu_s - mu_star(0.0, 0.0);
  return 0.5 * std::erfc(-margin / (sigma * std::hypot(g_a, g_b)) / std::sqrt(2.0));
}

/// mu* = mu_d - s / (ds/dmu_d) at `mu_d`, from `speed(mu)`, the slip speed after a solve with
/// dynamic friction mu (ds/dmu_d by central differences with step 1e-6).
template <class Speed>
double stoppingFriction(Speed&& speed, double mu_d) {
  const double k = 1e-6;
  const double rate = (speed(mu_d + k) - speed(mu_d - k)) / (2.0 * k);
  EXPECT_LT(rate, 0.0) << "more friction must slow the slip";
  return mu_d - speed(mu_d) / rate;
}

/// P(stick) = Phi(margin / (sigma |g|)) to first order in one uncertain coefficient x with
/// standard deviation `sigma`: margin = mu_s - mu_star(0), g = -d mu_star / dx by central
/// differences with step `h`; `mu_star(dx)` is stoppingFriction() with x moved by dx from its mean.
template <class MuStar>
double firstOrderStickProbabilityAlong(MuStar&& mu_star, double mu_s, double sigma, double h) {
  const double g = -(mu_star(h) - mu_star(-h)) / (2.0 * h);
  const double margin = mu_s - mu_star(0.0);
  return 0.5 * std::erfc(-margin / (sigma * std::abs(g)) / std::sqrt(2.0));
}

}  // namespace collision_response::testing
