// Tests of SlipTaylor, the sliding path's Taylor polynomial in the clock xi (docs/physics.md,
// "Rotating slip in 3D: Taylor steps"), on its own, against references computed here:
//   - a central contact (K_tn = 0) on an isotropic body: the slip keeps its direction and decays as
//     exp(-mu c_t xi), so p, P_t and W are closed forms in xi, and so is every Taylor coefficient;
//   - a central contact on an anisotropic body: u_t(xi) = exp(-mu A xi) u0_t, so the friction
//     impulse's coefficients are those of the matrix exponential's series;
//   - general contacts (K_tn != 0, anisotropic): the polynomial against a classical RK4
//     integration of the sliding equations with a small fixed step, inside the series' radius.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <random>

#include "collision_response/core/slip_taylor.h"

namespace cr = collision_response::core;
using Eigen::Matrix2d;
using Eigen::Vector2d;
using Eigen::Vector4d;

namespace {

struct Equations {
  Matrix2d A = Matrix2d::Identity();
  Vector2d b = Vector2d::Zero();
  double c = 1.0;
  Vector2d u0_t = Vector2d(1.0, 0.0);
  double u0_n = -1.0;
  double mu = 0.5;
};

// The sliding equations in xi, written out here (not SlipTaylor's): y = (p, P_t1, P_t2, W).
Vector4d field(const Equations& q, const Vector4d& y) {
  const Vector2d P(y[1], y[2]);
  const Vector2d u_t = q.u0_t + q.A * P + q.b * y[0];
  const double u_n = q.u0_n + q.b.dot(P) + q.c * y[0];
  const double sigma = u_t.norm();
  return Vector4d(sigma, -q.mu * u_t.x(), -q.mu * u_t.y(), sigma * u_n);
}

Vector4d rk4(const Equations& q, Vector4d y, double xi, int steps) {
  const double h = xi / steps;
  for (int i = 0; i < steps; ++i) {
    const Vector4d k1 = field(q, y);
    const Vector4d k2 = field(q, y + 0.5 * h * k1);
    const Vector4d k3 = field(q, y + 0.5 * h * k2);
    const Vector4d k4 = field(q, y + h * k3);
    y += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
  }
  return y;
}

bool expand(cr::SlipTaylor& path, const Equations& q, const Vector4d& y, int n) {
  return path.expand(q.A, q.b, q.c, q.u0_t, q.u0_n, q.mu, y, n);
}

double factorial(int k) {
  double f = 1.0;
  for (int i = 2; i <= k; ++i) f *= i;
  return f;
}

}  // namespace

// Isotropic central contact: sigma(xi) = sigma0 exp(-mu a xi) along a fixed direction s, so
// p = sigma0 (1 - exp(-mu a xi)) / (mu a), P_t = -mu s p (dP_t/dxi = -mu sigma s), and
// W = u0_n p + c p^2 / 2 (dW/dp = u_n = u0_n + c p with K_tn = 0). Coefficient by coefficient:
// p_k = sigma0 (-mu a)^(k-1) / k! for k >= 1.
TEST(SlipTaylor, IsotropicCentralContactMatchesClosedForm) {
  Equations q;
  const double a = 1.7;
  q.A = a * Matrix2d::Identity();
  q.u0_t = Vector2d(0.6, -0.8) * 2.0;  // sigma0 = 2, s = (0.6, -0.8)
  q.u0_n = -1.3;
  q.c = 2.2;
  q.mu = 0.4;
  const double sigma0 = 2.0, rate = q.mu * a;
  cr::SlipTaylor path;
  ASSERT_TRUE(expand(path, q, Vector4d::Zero(), 20));
  ASSERT_EQ(path.order(), 20);
  // Orders up to 14 (the square root's recurrence cancels terms larger than the coefficient, more
  // at each order: 1e-9 relative at order 20, where the coefficient is 1e-21 and weighs nothing in
  // the path, checked below).
  for (int k = 1; k <= 14; ++k) {
    const double p_k = sigma0 * std::pow(-rate, k - 1) / factorial(k);
    EXPECT_NEAR(path.coefficient(k)[0], p_k, 1e-10 * std::abs(p_k)) << "order " << k;
    EXPECT_NEAR(path.coefficient(k)[1], -q.mu * 0.6 * p_k, 1e-10 * std::abs(p_k));
    EXPECT_NEAR(path.coefficient(k)[2], q.mu * 0.8 * p_k, 1e-10 * std::abs(p_k));
  }
  for (const double xi : {0.05, 0.2, 0.5}) {
    const double p = sigma0 * (1.0 - std::exp(-rate * xi)) / rate;
    const Vector4d y = path.at(xi);
    EXPECT_NEAR(y[0], p, 1e-13) << "xi " << xi;
    EXPECT_NEAR(y[1], -q.mu * 0.6 * p, 1e-13);
    EXPECT_NEAR(y[2], q.mu * 0.8 * p, 1e-13);
    EXPECT_NEAR(y[3], q.u0_n * p + 0.5 * q.c * p * p, 1e-13);
  }
}

// Anisotropic central contact: du_t/dxi = -mu A u_t, so u_t = exp(-mu A xi) u0_t and
// P_t's coefficient k >= 1 is -mu (-mu A)^(k-1) u0_t / k!. Exercises the square root's
// recurrence through p (sigma no longer a single exponential), checked against RK4.
TEST(SlipTaylor, AnisotropicCentralContactFollowsMatrixExponential) {
  Equations q;
  q.A << 2.0, 0.7, 0.7, 0.6;
  q.u0_t = Vector2d(0.3, 1.1);
  q.mu = 0.8;
  cr::SlipTaylor path;
  ASSERT_TRUE(expand(path, q, Vector4d::Zero(), 16));
  Vector2d power = q.u0_t;  // (-mu A)^(k-1) u0_t
  for (int k = 1; k <= 16; ++k) {
    const Vector2d expected = -q.mu * power / factorial(k);
    EXPECT_NEAR(path.coefficient(k)[1], expected.x(), 1e-12 * q.mu * power.norm() / factorial(k))
        << "order " << k;
    EXPECT_NEAR(path.coefficient(k)[2], expected.y(), 1e-12 * q.mu * power.norm() / factorial(k));
    power = -q.mu * q.A * power;
  }
  const Vector4d reference = rk4(q, Vector4d::Zero(), 0.15, 20000);
  const Vector4d y = path.at(0.15);
  EXPECT_LT((y - reference).cwiseAbs().maxCoeff(), 1e-12)
      << y.transpose() << " | " << reference.transpose();
}

// General contacts: K_tn != 0 turns the slip, anisotropic K_tt, about a state part-way through
// the impact. A step rule of the integrator's form (impulse_space_integrator.cpp, taylorStep(),
// without its scales and caps): the longest t with the last two orders' terms within eps, times
// 0.9. At that t the polynomial of
// order 15 matches RK4 (steps of 1e-5, error ~1e-16) to within eps of the state's scale, at
// eps = 1e-9 and 1e-12; and a polynomial of order 6 taken as far is off by more (a series, not a
// fit).
TEST(SlipTaylor, RandomContactsMatchReferenceIntegrationAtTheStepRule) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), positive(0.0, 1.0);
  int checked = 0;
  for (int trial = 0; trial < 40; ++trial) {
    Equations q;
    const double angle = 3.14159 * positive(rng);
    const Vector2d e1(std::cos(angle), std::sin(angle)), e2(-e1.y(), e1.x());
    q.A = (0.3 + 2.7 * positive(rng)) * e1 * e1.transpose() +
          (0.3 + 2.7 * positive(rng)) * e2 * e2.transpose();
    q.b = Vector2d(0.5 * unit(rng), 0.5 * unit(rng));
    q.c = 1.0 + 2.0 * positive(rng);
    q.u0_t = Vector2d(unit(rng), unit(rng));
    q.u0_n = -0.2 - positive(rng);
    q.mu = 0.1 + 0.9 * positive(rng);
    // Start from the state after a short slide (reference-integrated), not only from y = 0.
    const Vector4d y0 = rk4(q, Vector4d::Zero(), 0.05 * positive(rng), 2000);
    cr::SlipTaylor path;
    ASSERT_TRUE(expand(path, q, y0, 15));
    const double scale = std::max(1.0, y0.cwiseAbs().maxCoeff());
    for (const double eps : {1e-9, 1e-12}) {
      const double xi = 0.9 * std::min(std::pow(eps * scale / path.size(15, 1.0), 1.0 / 15),
                                       std::pow(eps * scale / path.size(14, 1.0), 1.0 / 14));
      const Vector4d reference = rk4(q, y0, xi, std::max(100, static_cast<int>(xi / 1e-5)));
      const double error = (path.at(xi) - reference).cwiseAbs().maxCoeff() / scale;
      EXPECT_LT(error, eps) << "trial " << trial << " eps " << eps << " xi " << xi;
      cr::SlipTaylor low;
      ASSERT_TRUE(expand(low, q, y0, 6));
      const double error6 = (low.at(xi) - reference).cwiseAbs().maxCoeff() / scale;
      EXPECT_GT(error6, error) << "trial " << trial;
    }
    ++checked;
  }
  EXPECT_EQ(checked, 40);
}

// The event polynomial: grad . y(t) + offset and its slope, against the state polynomial itself.
TEST(SlipTaylor, LinearEventPolynomialAgreesWithState) {
  Equations q;
  q.A << 1.2, -0.3, -0.3, 0.9;
  q.b = Vector2d(0.2, -0.35);
  q.u0_t = Vector2d(-0.7, 0.4);
  cr::SlipTaylor path;
  ASSERT_TRUE(expand(path, q, Vector4d(0.1, 0.02, -0.01, -0.05), 12));
  const Vector4d grad(q.c, q.b.x(), q.b.y(), 0.0);  // u_n
  double e[cr::SlipTaylor::kMaxOrder + 1];
  path.linear(grad, q.u0_n, e);
  for (const double t : {0.0, 0.03, 0.11}) {
    double slope;
    const double v = cr::SlipTaylor::value(e, path.order(), t, slope);
    EXPECT_NEAR(v, grad.dot(path.at(t)) + q.u0_n, 1e-15);
    const double h = 1e-6;
    const double difference =
        (grad.dot(path.at(t + h)) - grad.dot(path.at(t - h))) / (2.0 * h);  // central difference
    EXPECT_NEAR(slope, difference, 1e-8);
  }
}

// The clock: an expansion in s = xi / T is the one in xi with Y_k scaled by T^k; its rate (rate(),
// which the integrator checks against the field at each step's end) is T times the field at the
// start and the central difference of the polynomial elsewhere.
TEST(SlipTaylor, ScaledClockAndRateAgreeWithThePolynomial) {
  Equations q;
  q.A << 1.4, 0.5, 0.5, 0.8;
  q.b = Vector2d(-0.3, 0.25);
  q.u0_t = Vector2d(0.9, -0.6);
  const Vector4d y0(0.05, -0.01, 0.02, -0.04);
  const double T = 0.37;
  cr::SlipTaylor in_xi, in_s;
  ASSERT_TRUE(expand(in_xi, q, y0, 14));
  ASSERT_TRUE(in_s.expand(q.A, q.b, q.c, q.u0_t, q.u0_n, q.mu, y0, 14, T));
  for (int k = 0; k <= 14; ++k) {
    const Vector4d expected = in_xi.coefficient(k) * std::pow(T, k);
    EXPECT_LT((in_s.coefficient(k) - expected).cwiseAbs().maxCoeff(),
              1e-13 * std::max(1e-3, expected.cwiseAbs().maxCoeff()))
        << "order " << k;
  }
  EXPECT_LT((in_s.rate(0.0) - T * field(q, y0)).cwiseAbs().maxCoeff(), 1e-14);
  for (const double s : {0.1, 0.3}) {
    const double h = 1e-5;
    const Vector4d difference = (in_s.at(s + h) - in_s.at(s - h)) / (2.0 * h);
    EXPECT_LT((in_s.rate(s) - difference).cwiseAbs().maxCoeff(), 1e-8) << "s " << s;
    EXPECT_LT((in_s.rate(s) - T * field(q, in_s.at(s))).cwiseAbs().maxCoeff(), 1e-9) << "s " << s;
  }
}

// A zero slip has no expansion (the clock stops): expand() says so and forms nothing.
TEST(SlipTaylor, ZeroSlipHasNoExpansion) {
  Equations q;
  q.u0_t = Vector2d::Zero();
  cr::SlipTaylor path;
  EXPECT_FALSE(expand(path, q, Vector4d::Zero(), 8));
}
