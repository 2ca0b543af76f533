#pragma once

#include <cmath>

namespace collision_response::core {

/// The root in (0, 1] of the cubic Hermite interpolant of an event value g over one integration
/// step: g(0) = e0 < 0 <= g(1) = e1, with slopes dg/dt = d0 at 0 and d1 at 1 (per unit of the
/// step's fraction t). Safeguarded Newton (bisection whenever a Newton step leaves the bracket),
/// to 1e-15 in t. Where the impulse-space integration (impulse_space_integrator.cpp) and its
/// derivatives (impulse_space_derivatives.cpp) place an event inside a step, so that both place
/// it at the same point.
inline double hermiteRoot(double e0, double d0, double e1, double d1) {
  double lo = 0.0, hi = 1.0, t = e0 / (e0 - e1);
  for (int i = 0; i < 50; ++i) {
    const double t2 = t * t, t3 = t2 * t;
    const double v = (2 * t3 - 3 * t2 + 1) * e0 + (t3 - 2 * t2 + t) * d0 + (3 * t2 - 2 * t3) * e1 +
                     (t3 - t2) * d1;
    const double dv =
        (6 * t2 - 6 * t) * (e0 - e1) + (3 * t2 - 4 * t + 1) * d0 + (3 * t2 - 2 * t) * d1;
    if (v < 0.0)
      lo = t;
    else
      hi = t;
    double next = dv != 0.0 ? t - v / dv : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - t) <= 1e-15) return next;
    t = next;
  }
  return t;
}

}  // namespace collision_response::core
