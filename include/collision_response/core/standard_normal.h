#pragma once

namespace collision_response::core {

/// The standard normal distribution N(0, 1): density, cumulative distribution and its inverse
/// (the quantile function), for the uncertainty propagation (uncertainty.h).

/// phi(x) = exp(-x^2 / 2) / sqrt(2 pi); 0 for infinite x.
double standardNormalPdf(double x);
/// Phi(x) = P(X <= x), from erfc (accurate in both tails); 0 at -infinity, 1 at +infinity.
double standardNormalCdf(double x);
/// Phi^-1(p) for p in [0, 1] (-infinity at 0, +infinity at 1): Acklam's rational approximation
/// refined by one Halley step on Phi, relative error near machine precision (below p = 6e-311,
/// where the step would overflow, the approximation unrefined: finite, relative error about
/// 1e-9). NaN outside [0, 1].
double standardNormalQuantile(double p);

}  // namespace collision_response::core
