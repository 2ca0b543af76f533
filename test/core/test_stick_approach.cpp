// Tests of StickApproach, the rotating slip's approach to stick in closed form (docs/physics.md,
// "Approach to stick in closed form"), on its own: the integrator checks the series' answers and
// falls back to its steps when they are wrong, so its own tests would pass with wrong series, only
// slower. Here every remaining quantity from the series is compared with an independent classical
// RK4 integration of the sliding equations with a small fixed step.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

#include "collision_response/core/constants.h"
#include "collision_response/core/stick_approach.h"

namespace cr = collision_response::core;
using Eigen::Matrix2d;
using Eigen::Vector2d;

namespace {

using collision_response::core::kPi;

/// A random slip's coefficients: A = K_tt with eigenvalues in [0.3, 3] 1/kg along a random angle
/// (both equal if isotropic), b = K_tn with components in [-0.4, 0.4] 1/kg, mu_d in [0.2, 1].
struct SlipCoefficients {
  Matrix2d A;
  Vector2d b;
  double mu = 0.0;
  double lambda_max = 0.0;  ///< A's larger eigenvalue [1/kg]
};
SlipCoefficients randomSlip(std::mt19937_64& rng, bool isotropic) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0), positive(0.0, 1.0);
  const double angle = kPi * positive(rng);
  const Vector2d e1(std::cos(angle), std::sin(angle)), e2(-e1.y(), e1.x());
  const double l1 = 0.3 + 2.7 * positive(rng), l2 = isotropic ? l1 : 0.3 + 2.7 * positive(rng);
  SlipCoefficients out;
  out.A = l1 * e1 * e1.transpose() + l2 * e2 * e2.transpose();
  out.b = Vector2d(0.4 * unit(rng), 0.4 * unit(rng));
  out.mu = 0.2 + 0.8 * positive(rng);
  out.lambda_max = std::max(l1, l2);
  return out;
}

/// What remains of a slip from direction s0 and speed 1 to its stop, by RK4 in the clock xi
/// (dp/dxi = |u_t|, in which the stop is an exponentially attracting equilibrium) up to
/// |u_t| < 1e-14: du_t/dxi = b |u_t| - mu A u_t, dp/dxi = |u_t|, dP_t/dxi = -mu u_t, and the rise
/// of u_n, d(rise)/dxi = b . dP_t/dxi + c dp/dxi, with the integral of the rise over p.
struct Reference {
  double p = 0.0;
  Vector2d P_t = Vector2d::Zero();
  double rise = 0.0;
  double rise_integral = 0.0;  // integral of rise(p) dp
};

Reference integrate(const Matrix2d& A, const Vector2d& b, double c, double mu, const Vector2d& s0,
                    double h) {
  using State = Eigen::Matrix<double, 7, 1>;  // u_t (2), p, P_t (2), rise, rise integral
  const auto rate = [&](const State& x) {
    const Vector2d u = x.head<2>();
    const double sigma = u.norm();
    State d;
    d.head<2>() = b * sigma - mu * A * u;
    d(2) = sigma;
    d.segment<2>(3) = -mu * u;
    d(5) = b.dot(d.segment<2>(3)) + c * sigma;
    d(6) = x(5) * sigma;
    return d;
  };
  State x = State::Zero();
  x.head<2>() = s0;
  for (int i = 0; i < 10000000 && x.head<2>().norm() > 1e-14; ++i) {
    const State k1 = rate(x), k2 = rate(x + 0.5 * h * k1), k3 = rate(x + 0.5 * h * k2),
                k4 = rate(x + h * k3);
    x += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
  }
  Reference out;
  out.p = x(2);
  out.P_t = x.segment<2>(3);
  out.rise = x(5);
  out.rise_integral = x(6);
  return out;
}

// Random anisotropic K_tt, coupling K_tn and friction; every slip that turns to a direction that
// stops it, starting where the series converge, against the reference: impulses, friction impulse,
// rise of u_n and the work's drop to 1e-9 of the impulse scale (the reference's error is ~1e-12).
TEST(StickApproach, RemainingAgreesWithIndependentIntegration) {
  std::mt19937_64 rng(20261124);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  int compared = 0, tried = 0;
  for (int i = 0; i < 400 && compared < 40; ++i) {
    const SlipCoefficients slip = randomSlip(rng, false);
    const Matrix2d& A = slip.A;
    const Vector2d& b = slip.b;
    const double c = 1.5, mu = slip.mu;
    const double theta0 = kPi * unit(rng);
    const Vector2d s0(std::cos(theta0), std::sin(theta0));
    cr::StickApproach approach;
    if (!approach.build(A, b, c, mu, s0)) continue;
    ++tried;
    const double y0 = approach.distance(s0);
    ASSERT_GE(y0, 0.0);
    if (!approach.converged(y0, 1e-12, 1e-12)) continue;
    const cr::StickApproach::Remaining got = approach.remaining(y0, approach.logScale(y0, 1.0));
    // The step: a thousandth of the fastest rate of the equations (mu times A's largest
    // eigenvalue, plus |b|).
    const Reference ref = integrate(A, b, c, mu, s0, 1e-3 / (mu * slip.lambda_max + b.norm()));
    const double scale = ref.p;
    const double work_drop = ref.rise * ref.p - ref.rise_integral;
    EXPECT_NEAR(got.p, ref.p, 1e-9 * scale) << "case " << i;
    EXPECT_LE((got.P_t - ref.P_t).norm(), 1e-9 * scale) << "case " << i;
    EXPECT_NEAR(got.u_n_rise, ref.rise, 1e-9 * ref.rise) << "case " << i;
    EXPECT_NEAR(got.work_drop, work_drop, 1e-9 * ref.rise * ref.p) << "case " << i;
    EXPECT_LE((got.direction - s0).norm(), 1e-12) << "case " << i;
    // s* is a fixed direction of the slip: du_t/dp = b - mu A s* is along s*.
    const Vector2d s_star = approach.direction(), s_star_perp(-s_star.y(), s_star.x());
    EXPECT_NEAR(s_star_perp.dot(b - mu * A * s_star), 0.0, 1e-12) << "case " << i;
    ++compared;
  }
  std::printf("stick approach: %d slips stopping, %d compared with the series converged\n", tried,
              compared);
  EXPECT_GE(compared, 20);
}

// muDerivatives() (the series' recurrence differentiated term by term) against central differences
// of the series' own sums in mu_d, the slip held fixed (direction s0, speed 1): each side's series
// built at mu_d +- h from the same s0, converged to 1e-14, and summed at its own angle distance
// (theta* moves with mu_d); to 1e-6 of the derivative (and of the impulse scale where it is small).
TEST(StickApproach, MuDerivativesMatchCentralDifferencesOfTheSeries) {
  std::mt19937_64 rng(20261126);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  int compared = 0;
  for (int i = 0; i < 400 && compared < 30; ++i) {
    const SlipCoefficients slip = randomSlip(rng, false);
    const double c = 1.5, mu = slip.mu, h = 1e-5;
    const double theta0 = kPi * unit(rng);
    const Vector2d s0(std::cos(theta0), std::sin(theta0));
    cr::StickApproach at[3];  // mu, mu + h, mu - h
    const double mus[3] = {mu, mu + h, mu - h};
    double p[3], work[3];
    bool ok = true;
    for (int k = 0; k < 3 && ok; ++k) {
      ok = at[k].build(slip.A, slip.b, c, mus[k], s0);
      const double y = ok ? at[k].distance(s0) : -1.0;
      ok = ok && y >= 0.0 && at[k].converged(y, 1e-14, 1e-14);
      if (!ok) break;
      const cr::StickApproach::Remaining r = at[k].remaining(y, at[k].logScale(y, 1.0));
      p[k] = r.p;
      work[k] = r.work_drop;
    }
    if (!ok) continue;
    const cr::StickApproach::MuDerivatives got = at[0].muDerivatives(at[0].distance(s0), 1.0);
    const double want_p = (p[1] - p[2]) / (2.0 * h), want_w = (work[1] - work[2]) / (2.0 * h);
    EXPECT_NEAR(got.p, want_p, 1e-6 * std::max(std::abs(want_p), 1e-3 * p[0])) << "case " << i;
    EXPECT_NEAR(got.work_drop, want_w, 1e-6 * std::max(std::abs(want_w), 1e-3 * work[0]))
        << "case " << i;
    ++compared;
  }
  EXPECT_GE(compared, 20);
}

// radius() against the zeros of the angle equation found directly: g(theta) = s_perp . (b - mu A s)
// with s = (cos theta, sin theta) continued to complex theta, its zeros by Newton's method from a
// grid over one period and |Im theta| <= 4; the nearest other than theta* is the radius. And the
// series diverge beyond it: converged() refuses y = 1.1 radius.
TEST(StickApproach, RadiusIsTheDistanceToTheNearestOtherZeroOfTheAngleEquation) {
  using Complex = std::complex<double>;
  std::mt19937_64 rng(20261125);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  int compared = 0, beyond = 0;
  for (int i = 0; i < 400 && compared < 60; ++i) {
    // Every fourth case isotropic (A = l I: g has only its first harmonic, zeros a half turn
    // apart).
    const SlipCoefficients slip = randomSlip(rng, i % 4 == 0);
    const Matrix2d& A = slip.A;
    const Vector2d& b = slip.b;
    const double c = 1.5, mu = slip.mu;
    const double theta0 = kPi * unit(rng);
    cr::StickApproach approach;
    if (!approach.build(A, b, c, mu, Vector2d(std::cos(theta0), std::sin(theta0)))) continue;
    const double theta_star = std::atan2(approach.direction().y(), approach.direction().x());
    const auto g = [&](Complex t, Complex& slope) {
      const Complex cs = std::cos(t), sn = std::sin(t);
      // s = (cs, sn), s_perp = (-sn, cs); g = s_perp . b - mu s_perp^T A s.
      const Complex as0 = A(0, 0) * cs + A(0, 1) * sn, as1 = A(1, 0) * cs + A(1, 1) * sn;
      const Complex das0 = -A(0, 0) * sn + A(0, 1) * cs, das1 = -A(1, 0) * sn + A(1, 1) * cs;
      slope = -cs * b.x() - sn * b.y() - mu * (-cs * as0 - sn * as1 - sn * das0 + cs * das1);
      return -sn * b.x() + cs * b.y() - mu * (-sn * as0 + cs * as1);
    };
    double nearest = std::numeric_limits<double>::infinity();
    for (int re = 0; re < 48; ++re) {
      for (int im = -12; im <= 12; ++im) {
        Complex t(theta_star - kPi + (re + 0.5) * 2.0 * kPi / 48, im / 3.0);
        Complex slope;
        for (int k = 0; k < 60; ++k) {
          const Complex v = g(t, slope);
          if (std::abs(slope) == 0.0) break;
          t -= v / slope;
          if (std::abs(t.imag()) > 8.0) break;
        }
        if (!(std::abs(g(t, slope)) < 1e-12) || std::abs(t.imag()) > 4.0) continue;
        // The nearest 2 pi image of the zero; theta* itself (distance ~0) is not counted.
        const double re_offset = std::remainder(t.real() - theta_star, 2.0 * kPi);
        const double distance = std::hypot(re_offset, t.imag());
        if (distance > 1e-6) nearest = std::min(nearest, distance);
      }
    }
    const double radius = approach.radius();
    if (std::isfinite(nearest)) {
      EXPECT_NEAR(radius, nearest, 1e-9 * nearest) << "case " << i;
    } else {
      EXPECT_GT(radius, 4.0) << "case " << i;  // no zero within the searched strip
    }
    if (i % 4 == 0) {
      EXPECT_NEAR(radius, kPi, 1e-9) << "case " << i;
    }
    if (std::isfinite(radius)) {
      EXPECT_FALSE(approach.converged(1.1 * radius, 1e-6, 1e-6)) << "case " << i;
      ++beyond;
    }
    ++compared;
  }
  std::printf("stick approach: radius compared in %d cases, divergence beyond it in %d\n", compared,
              beyond);
  EXPECT_GE(compared, 40);
  EXPECT_GE(beyond, 40);
}

}  // namespace
