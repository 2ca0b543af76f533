// The reference for the linear method's stick probability of a contact that slides at the means
// (test_geometry_uncertainty, test_robot_uncertainty): the first-order probability of the stick
// condition, computed from the test's own solves or closed forms, independent of the library's
// derivatives. Under Newton's law a contact sticks iff its sticking impulse P (the answer with the
// contact held: no slip at the end) lies in its static cone, i.e. iff the margin g = mu_s P_n -
// |P_t| is >= 0 (stickMargin()); under Poisson's and Stronge's iff its slip stops within the
// impact, the slip speed s extended past its zero <= 0 (in units of mu: slipRateInMuD()).
#pragma once

#include <cmath>

namespace collision_response::testing {

/// P(g >= 0) = Phi(g(0, 0) / (sigma |grad g|)) to first order in two dimensions (a, b) with the
/// same standard deviation `sigma` (a tilt of the normal along two orthonormal tangents: the
/// margin's variance sigma^2 |grad g|^2 does not depend on the basis). `margin(a, b)` is g at
/// (a, b); its gradient by central differences with step `h`.
template <class Margin>
double firstOrderStickProbability(Margin&& margin, double sigma, double h) {
  const double g_a = (margin(h, 0.0) - margin(-h, 0.0)) / (2.0 * h);
  const double g_b = (margin(0.0, h) - margin(0.0, -h)) / (2.0 * h);
  return 0.5 * std::erfc(-margin(0.0, 0.0) / (sigma * std::hypot(g_a, g_b)) / std::sqrt(2.0));
}

/// The same in one dimension x with standard deviation `sigma`: `margin(dx)` is g with x moved by
/// dx from its mean.
template <class Margin>
double firstOrderStickProbabilityAlong(Margin&& margin, double sigma, double h) {
  const double g_x = (margin(h) - margin(-h)) / (2.0 * h);
  return 0.5 * std::erfc(-margin(0.0) / (sigma * std::abs(g_x)) / std::sqrt(2.0));
}

/// g = mu_s P_n - |P_t| of an impulse with normal part `normal_impulse` and tangential part
/// `friction_impulse` (any vector type with norm()).
template <class Vector>
double stickMargin(double mu_s, double normal_impulse, const Vector& friction_impulse) {
  return mu_s * normal_impulse - friction_impulse.norm();
}

/// ds/dmu_d at `mu_d` by central differences with step 1e-6, `speed(mu)` the slip speed after a
/// solve with dynamic friction mu: the rate that makes the slip speed a margin in units of mu,
/// g = s / (ds/dmu_d) (= mu_d - mu*, mu* the mu_d at which the slip, linearised in mu_d, would
/// vanish at the impact's end).
template <class Speed>
double slipRateInMuD(Speed&& speed, double mu_d) {
  const double k = 1e-6;
  return (speed(mu_d + k) - speed(mu_d - k)) / (2.0 * k);
}

}  // namespace collision_response::testing
