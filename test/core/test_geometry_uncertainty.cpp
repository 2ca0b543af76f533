// Outcome distributions of impacts whose contact normal or point is uncertain (ContactUncertainty's
// normal_std_dev and point_std_dev, sampled and linear methods; docs/uncertainty.md). References,
// each computed here independently of the code under test:
// - a frictionless ball landing on its pole with a tilted normal, and a frictionless rod landing
//   flat at a point along its length, both in closed form (derived below) integrated over the
//   Gaussian perturbation by a fine quadrature;
// - a plain Monte Carlo loop over computeResponse() on a frictional, spinning box whose normal and
//   point this test perturbs with std::mt19937 draws and a tangent basis of its own.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "collision_response/core/body_response.h"
#include "collision_response/core/compute_response.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/uncertainty.h"
#include "collision_response/core/worker_pool.h"
#include "scenes.h"
#include "stick_margin.h"
#include "uncertainty_options.h"

namespace core = collision_response::core;
using core::ContactUncertainty;
using core::UncertaintyMethod;
using Eigen::Vector3d;

using collision_response::testing::errorField;
using collision_response::testing::linear;
using collision_response::testing::newton;
using collision_response::testing::sampled;

namespace {

constexpr double kPi = 3.14159265358979323846;

// E[f(z)] for z ~ N(0, 1) in `d` independent dimensions (d = 1 or 2): the trapezoid rule on
// [-9, 9] with 401 nodes per axis (spectrally accurate for these smooth integrands).
template <class F>
double gaussian1(F&& f) {
  constexpr int kNodes = 401;
  constexpr double kHalf = 9.0;
  const double h = 2.0 * kHalf / (kNodes - 1);
  double sum = 0.0;
  for (int i = 0; i < kNodes; ++i) {
    const double z = -kHalf + h * i;
    sum += f(z) * std::exp(-0.5 * z * z);
  }
  return sum * h / std::sqrt(2.0 * kPi);
}

template <class F>
double gaussian2(F&& f) {
  return gaussian1([&](double x) { return gaussian1([&](double y) { return f(x, y); }); });
}

// A uniform ball (mass m, radius R, no spin) falling straight down at V onto the immovable ground
// (body a), the contact point fixed under its centre, the normal z tilted to n = (a, b, 1) / s,
// s = sqrt(1 + a^2 + b^2). Frictionless, one contact: P = (1 + e) V / (s k) along n with the
// arm r = (0, 0, -R), r x n = R (b, -a, 0) / s and
//   k = 1/m + |r x n|^2 / I = (1 + 2.5 (a^2 + b^2) / s^2) / m,   I = 2/5 m R^2;
// after: v = (0, 0, -V) + P n / m, w = P (r x n) / I.
constexpr double kBallMass = 2.0, kBallRadius = 0.1, kBallSpeed = 2.0, kBallE = 0.5;

core::Scene fallingBall() {
  core::BodyState ground;
  ground.id = "ground";
  core::BodyState ball;
  ball.id = "ball";
  ball.mass = kBallMass;
  ball.inertia = Eigen::Matrix3d::Identity() * 0.4 * kBallMass * kBallRadius * kBallRadius;
  ball.position = {0.0, 0.0, kBallRadius};
  ball.linear_velocity = {0.0, 0.0, -kBallSpeed};
  core::Contact contact;
  contact.body_a = "ground";
  contact.body_b = "ball";
  contact.point = {0.0, 0.0, 0.0};
  contact.normal = {0.0, 0.0, 1.0};
  contact.restitution = kBallE;
  core::Scene scene;
  scene.bodies = {ground, ball};
  scene.contacts = {contact};
  return scene;
}

// The ball's (v, w) after, for tangent components (a, b) of the normal, and the normal impulse.
Eigen::Matrix<double, 7, 1> ballAfter(double a, double b) {
  const double s2 = 1.0 + a * a + b * b, s = std::sqrt(s2);
  const double inertia = 0.4 * kBallMass * kBallRadius * kBallRadius;
  const double k = (1.0 + 2.5 * (a * a + b * b) / s2) / kBallMass;
  const double p = (1.0 + kBallE) * kBallSpeed / (s * k);
  Eigen::Matrix<double, 7, 1> out;
  out << p * a / (s * kBallMass), p * b / (s * kBallMass), -kBallSpeed + p / (s * kBallMass),
      p * kBallRadius * b / (s * inertia), -p * kBallRadius * a / (s * inertia), 0.0, p;
  return out;
}

// A rod (mass m, length L along x, centre at height h) falling flat at V onto the ground, struck
// at (x, 0, 0). Frictionless, normal z: r = (x, 0, -h), r x z = (0, -x, 0) (the point's height
// does not enter), k = 1/m + x^2 / I_yy, I_yy = m L^2 / 12, P = (1 + e) V / k;
// after: v_z = -V + P / m, w_y = -x P / I_yy, everything else unchanged (zero).
constexpr double kRodMass = 1.2, kRodLength = 1.0, kRodHeight = 0.02, kRodSpeed = 1.5, kRodE = 0.3;
constexpr double kRodIyy = kRodMass * kRodLength * kRodLength / 12.0;

core::Scene fallingRod(double x) {
  core::BodyState ground;
  ground.id = "ground";
  core::BodyState rod;
  rod.id = "rod";
  rod.mass = kRodMass;
  rod.inertia = Eigen::Vector3d(1e-3, kRodIyy, kRodIyy).asDiagonal();
  rod.position = {0.0, 0.0, kRodHeight};
  rod.linear_velocity = {0.0, 0.0, -kRodSpeed};
  core::Contact contact;
  contact.body_a = "ground";
  contact.body_b = "rod";
  contact.point = {x, 0.0, 0.0};
  contact.normal = {0.0, 0.0, 1.0};
  contact.restitution = kRodE;
  core::Scene scene;
  scene.bodies = {ground, rod};
  scene.contacts = {contact};
  return scene;
}

// (v_z, w_y, P) after, the rod struck at x.
Eigen::Vector3d rodAfter(double x) {
  const double k = 1.0 / kRodMass + x * x / kRodIyy;
  const double p = (1.0 + kRodE) * kRodSpeed / k;
  return {-kRodSpeed + p / kRodMass, -x * p / kRodIyy, p};
}

}  // namespace

TEST(GeometryUncertainty, TiltedNormalOfALandingBallMatchesTheClosedForm) {
  const double sigma = 0.05;  // [rad]
  ContactUncertainty uncertain;
  uncertain.normal_std_dev = sigma;
  const core::OutcomeDistribution outcome =
      core::computeOutcomeDistribution(fallingBall(), {uncertain}, newton(), sampled(8192));
  // Rows: the ball's v (0-2), w (3-5), the contact's normal impulse (6), friction (7-9).
  ASSERT_EQ(outcome.mean.size(), 10);
  const int rows[7] = {0, 1, 2, 3, 4, 5, 6};
  auto mean = [&](int q) {
    return gaussian2([&](double x, double y) { return ballAfter(sigma * x, sigma * y)(q); });
  };
  for (int q = 0; q < 7; ++q) {
    SCOPED_TRACE("quantity " + std::to_string(q));
    const double mu = mean(q);
    const double variance = gaussian2([&](double x, double y) {
      const double d = ballAfter(sigma * x, sigma * y)(q) - mu;
      return d * d;
    });
    const double spread = std::sqrt(variance);
    EXPECT_NEAR(outcome.mean(rows[q]), mu, 2e-3 * spread + 1e-12);
    EXPECT_NEAR(outcome.covariance(rows[q], rows[q]), variance, 1e-2 * variance + 1e-14);
  }
  // Small sigma, from the closed form: s^2 k m = 1 + 3.5 rho (rho = a^2 + b^2), so
  // v_x = (1 + e) V a / (1 + 3.5 rho) and, with E[a^2] = sigma^2, E[a^2 rho] = 4 sigma^4,
  //   Var(v_x) = Var(v_y) = ((1 + e) V sigma)^2 (1 - 28 sigma^2) + O(sigma^6)
  // (leading term: the tilt's tangential velocity (1 + e) V cos(theta) sin(theta) ~ (1 + e) V
  // theta; the next one carries the lever arm). The O(sigma^6) term is about 0.6 % here.
  const double leading = std::pow((1.0 + kBallE) * kBallSpeed * sigma, 2);
  const double second = leading * (1.0 - 28.0 * sigma * sigma);
  EXPECT_NEAR(outcome.covariance(0, 0), second, 0.015 * second);
  EXPECT_NEAR(outcome.covariance(1, 1), second, 0.015 * second);
  // The two tangent axes are independent: v_x and v_y are uncorrelated.
  EXPECT_NEAR(outcome.covariance(0, 1), 0.0, 0.02 * leading);
  // Frictionless: no friction impulse in any sample.
  EXPECT_LT((outcome.covariance.block<3, 3>(7, 7).norm()), 1e-20);
}

TEST(GeometryUncertainty, PointAlongAStruckRodMatchesTheClosedForm) {
  const double x0 = 0.2, sigma_x = 0.05;
  ContactUncertainty uncertain;
  // The height spread is along the normal: frictionless, it changes nothing (r x n ignores it).
  uncertain.point_std_dev = {sigma_x, 0.0, 0.03};
  const core::OutcomeDistribution outcome =
      core::computeOutcomeDistribution(fallingRod(x0), {uncertain}, newton(), sampled(8192));
  ASSERT_EQ(outcome.mean.size(), 10);
  const int rows[3] = {2, 4, 6};  // v_z, w_y, normal impulse
  for (int q = 0; q < 3; ++q) {
    SCOPED_TRACE("quantity " + std::to_string(q));
    const double mu = gaussian1([&](double z) { return rodAfter(x0 + sigma_x * z)(q); });
    const double variance = gaussian1([&](double z) {
      const double d = rodAfter(x0 + sigma_x * z)(q) - mu;
      return d * d;
    });
    const double spread = std::sqrt(variance);
    EXPECT_NEAR(outcome.mean(rows[q]), mu, 2e-3 * spread);
    EXPECT_NEAR(outcome.covariance(rows[q], rows[q]), variance, 1e-2 * variance);
  }
  // The other velocities stay zero in every sample.
  for (const int r : {0, 1, 3, 5}) EXPECT_NEAR(outcome.covariance(r, r), 0.0, 1e-20);
}

TEST(GeometryUncertainty, SampledMatchesPlainMonteCarloOnASlidingSpinningBox) {
  // A box struck off-centre on the ground with friction, spinning: normal, point and restitution
  // all uncertain at once.
  const core::Scene scene =
      collision_response::testing::struckBox({0.6, 0.3, -2.0}, {0.5, -1.0, 0.2}, {0.05, 0.0, 0.0},
                                             Vector3d(0.1, -0.05, 1.0).normalized(), 0.5, 0.4, 0.3);

  const double sigma_n = 0.08, e_sd = 0.05;
  const Vector3d sigma_p(0.03, 0.02, 0.01);
  ContactUncertainty uncertain;
  uncertain.normal_std_dev = sigma_n;
  uncertain.point_std_dev = sigma_p;
  uncertain.restitution = core::CoefficientDistribution::normal(0.5, e_sd);
  core::WorkerPool pool(2);
  const core::OutcomeDistribution outcome =
      core::computeOutcomeDistribution(scene, {uncertain}, newton(), sampled(8192), &pool);

  // The test's own Monte Carlo: its own tangent basis (any orthonormal one gives the same law),
  // e by rejection inside [0, 1].
  const Vector3d n = scene.contacts[0].normal;
  const Vector3d t1 = n.cross(Vector3d(0.3, 1.0, -0.2)).normalized();
  const Vector3d t2 = n.cross(t1);
  std::mt19937 random(20261126);
  std::normal_distribution<double> z(0.0, 1.0);
  constexpr int kDraws = 20000;
  const Eigen::Index m = outcome.mean.size();
  ASSERT_EQ(m, 10);
  Eigen::MatrixXd values(m, kDraws);
  int sticking = 0;
  for (int i = 0; i < kDraws; ++i) {
    core::Scene sample = scene;
    core::Contact& c = sample.contacts[0];
    c.normal = (n + sigma_n * z(random) * t1 + sigma_n * z(random) * t2).normalized();
    for (int axis = 0; axis < 3; ++axis) c.point[axis] += sigma_p[axis] * z(random);
    do {
      c.restitution = 0.5 + e_sd * z(random);
    } while (c.restitution < 0.0 || c.restitution > 1.0);
    const core::CollisionResult result = core::computeResponse(sample, newton());
    const core::BodyState& after = result.bodies[1];
    values.col(i) << after.linear_velocity, after.angular_velocity,
        result.impulses[0].normal_impulse, result.impulses[0].friction_impulse;
    sticking += result.impulses[0].sticking ? 1 : 0;
  }
  const Eigen::VectorXd mc_mean = values.rowwise().mean();
  const Eigen::MatrixXd centred = values.colwise() - mc_mean;
  const Eigen::VectorXd mc_variance = centred.rowwise().squaredNorm() / (kDraws - 1.0);
  for (Eigen::Index r = 0; r < m; ++r) {
    SCOPED_TRACE(outcome.labels[static_cast<std::size_t>(r)]);
    const double spread = std::sqrt(mc_variance(r));
    ASSERT_GT(spread, 1e-4) << "every quantity must move";
    // 5 standard errors of the Monte Carlo mean (the quasi-random one is far tighter).
    EXPECT_NEAR(outcome.mean(r), mc_mean(r), 5.0 * spread / std::sqrt(double(kDraws)));
    // A sample standard deviation of 20000 draws: within 5 % (about 5 of its standard errors for
    // these mildly non-normal outcomes).
    EXPECT_NEAR(std::sqrt(outcome.covariance(r, r)), spread, 0.05 * spread);
  }
  const double p = static_cast<double>(sticking) / kDraws;
  EXPECT_NEAR(outcome.stick_probability[0], p, 5.0 * std::sqrt(p * (1 - p) / kDraws) + 1e-3);
}

TEST(GeometryUncertainty, GeneralBodiesPathPerturbsTheNormalToo) {
  // computeBodyOutcomeDistribution() (robots and free bodies) on the ball of the closed form.
  const core::Scene scene = fallingBall();
  std::vector<core::RigidBody> copy;
  core::makeRigidBodies(scene.bodies, copy);
  std::vector<std::vector<core::BodyModel*>> copies = {{&copy[0], &copy[1]}};
  const core::Contact& c = scene.contacts[0];
  const core::ContactPoint point(0, 1, c.point, c.normal, c.restitution, 0.0, 0.0);
  const double sigma = 0.05;
  ContactUncertainty uncertain;
  uncertain.normal_std_dev = sigma;
  const Eigen::VectorXd limits =
      Eigen::VectorXd::Constant(6, std::numeric_limits<double>::infinity());
  const core::OutcomeDistribution outcome = core::computeBodyOutcomeDistribution(
      copies, {point}, {uncertain}, limits, newton(), sampled(8192));
  ASSERT_EQ(outcome.mean.size(), 10);
  for (int q = 0; q < 7; ++q) {
    SCOPED_TRACE("quantity " + std::to_string(q));
    const double mu =
        gaussian2([&](double x, double y) { return ballAfter(sigma * x, sigma * y)(q); });
    const double variance = gaussian2([&](double x, double y) {
      const double d = ballAfter(sigma * x, sigma * y)(q) - mu;
      return d * d;
    });
    EXPECT_NEAR(outcome.mean(q), mu, 2e-3 * std::sqrt(variance) + 1e-12);
    EXPECT_NEAR(outcome.covariance(q, q), variance, 1e-2 * variance + 1e-14);
  }
  // The copies end at their pre-impact velocities.
  EXPECT_EQ(copy[1].velocity(),
            Eigen::VectorXd((Eigen::VectorXd(6) << 0, 0, -kBallSpeed, 0, 0, 0).finished()));
}

TEST(GeometryUncertainty, ZeroSpreadsLeaveTheCoefficientSamplesUnchanged) {
  // A restitution-only request and the same with explicit zero geometry spreads: bit for bit.
  ContactUncertainty plain;
  plain.restitution = core::CoefficientDistribution::interval(0.2, 0.8);
  ContactUncertainty zero = plain;
  zero.normal_std_dev = 0.0;
  zero.point_std_dev = Vector3d::Zero();
  const auto a = core::computeOutcomeDistribution(fallingRod(0.2), {plain}, newton(), sampled(256));
  const auto b = core::computeOutcomeDistribution(fallingRod(0.2), {zero}, newton(), sampled(256));
  EXPECT_EQ(a.mean, b.mean);
  EXPECT_EQ(a.covariance, b.covariance);
}

// The linear method with an uncertain normal or point (differences of the solver along each of
// its dimensions, docs/uncertainty.md): the covariance is J S J^T with J the derivative of the
// closed forms above at the mean geometry.
TEST(GeometryUncertainty, LinearTiltedNormalOfALandingBallIsTheClosedFormsFirstOrder) {
  const double sigma = 0.05;
  ContactUncertainty uncertain;
  uncertain.normal_std_dev = sigma;
  const core::OutcomeDistribution outcome =
      core::computeOutcomeDistribution(fallingBall(), {uncertain}, newton(), linear());
  ASSERT_EQ(outcome.mean.size(), 10);
  EXPECT_EQ(outcome.method, UncertaintyMethod::kLinear);
  // At a = b = 0 (s = 1, k = 1/m): P0 = (1 + e) V m. To first order in (a, b):
  // v_x = P0 a / m, v_y = P0 b / m, w_x = P0 R b / I, w_y = -P0 R a / I; v_z and P are even in
  // (a, b) (no first-order change). With a, b independent N(0, sigma^2):
  const double inertia = 0.4 * kBallMass * kBallRadius * kBallRadius;
  const double p0 = (1.0 + kBallE) * kBallSpeed * kBallMass;
  const double dv = p0 / kBallMass, dw = p0 * kBallRadius / inertia;
  const double s2 = sigma * sigma;
  Eigen::MatrixXd expected = Eigen::MatrixXd::Zero(10, 10);
  expected(0, 0) = expected(1, 1) = dv * dv * s2;
  expected(3, 3) = expected(4, 4) = dw * dw * s2;
  expected(0, 4) = expected(4, 0) = -dv * dw * s2;  // v_x and w_y both move with a
  expected(1, 3) = expected(3, 1) = dv * dw * s2;   // v_y and w_x both move with b
  EXPECT_LT((outcome.covariance - expected).cwiseAbs().maxCoeff(), 1e-6 * dw * dw * s2)
      << "linear:\n"
      << outcome.covariance << "\nexpected:\n"
      << expected;
  // The mean is the prediction at the mean normal: straight back up at e V, no spin.
  const Eigen::Matrix<double, 7, 1> at_mean = ballAfter(0.0, 0.0);
  for (int q = 0; q < 7; ++q) EXPECT_NEAR(outcome.mean(q), at_mean(q), 1e-12) << q;
  EXPECT_NEAR(outcome.q95(0), 1.6448536269514722 * dv * sigma, 1e-6 * dv * sigma);
  // Against the sampled method at a small spread, where the terms of order sigma^2 beyond it are
  // small (28 sigma^2 = 0.07 % of Var(v_x) at sigma = 0.005): variances within 1 %.
  ContactUncertainty small;
  small.normal_std_dev = 0.005;
  const auto lin = core::computeOutcomeDistribution(fallingBall(), {small}, newton(), linear());
  const auto smp =
      core::computeOutcomeDistribution(fallingBall(), {small}, newton(), sampled(8192));
  for (const int r : {0, 1, 3, 4}) {
    SCOPED_TRACE(r);
    EXPECT_NEAR(lin.covariance(r, r), smp.covariance(r, r), 0.01 * smp.covariance(r, r));
  }
  // No mode changes along the geometry's differences (only the frictionless contact's one-sided
  // friction columns are warned of, as for coefficients).
  for (const core::Warning& warning : outcome.warnings)
    EXPECT_EQ(warning.field.rfind("uncertainties", 0), std::string::npos) << warning.reason;
}

TEST(GeometryUncertainty, LinearPointAlongAStruckRodIsTheClosedFormsFirstOrder) {
  const double x0 = 0.2, sigma_x = 0.05;
  ContactUncertainty uncertain;
  uncertain.point_std_dev = {sigma_x, 0.0, 0.03};  // the height moves nothing (frictionless)
  const core::OutcomeDistribution outcome =
      core::computeOutcomeDistribution(fallingRod(x0), {uncertain}, newton(), linear());
  ASSERT_EQ(outcome.mean.size(), 10);
  // d/dx of rodAfter(x) (k = 1/m + x^2 / I, P = (1 + e) V / k): dP/dx = -P (2 x / I) / k,
  // dv_z/dx = (dP/dx) / m, dw_y/dx = -(P + x dP/dx) / I.
  const double k = 1.0 / kRodMass + x0 * x0 / kRodIyy;
  const double p = (1.0 + kRodE) * kRodSpeed / k;
  const double dp = -p * (2.0 * x0 / kRodIyy) / k;
  const Eigen::Vector3d d(dp / kRodMass, -(p + x0 * dp) / kRodIyy, dp);
  const int rows[3] = {2, 4, 6};  // v_z, w_y, normal impulse
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const double expected = d(i) * d(j) * sigma_x * sigma_x;
      EXPECT_NEAR(outcome.covariance(rows[i], rows[j]), expected,
                  1e-6 * d.cwiseAbs().maxCoeff() * d.cwiseAbs().maxCoeff() * sigma_x * sigma_x)
          << i << ", " << j;
    }
  for (const int r : {0, 1, 3, 5}) EXPECT_EQ(outcome.covariance(r, r), 0.0) << r;
}

// The frictional, spinning box of the Monte Carlo test above: the linear method's covariance
// against J S J^T with J the test's own central differences of computeResponse() along its own
// tangent basis (for the isotropic tilt, sum_i (J t_i)(J t_i)^T does not depend on the basis) and
// the point's axes, restitution included; then against the sampled method at small spreads.
TEST(GeometryUncertainty, LinearOnASlidingSpinningBoxMatchesDifferencesAndSamples) {
  const core::Scene scene =
      collision_response::testing::struckBox({0.6, 0.3, -2.0}, {0.5, -1.0, 0.2}, {0.05, 0.0, 0.0},
                                             Vector3d(0.1, -0.05, 1.0).normalized(), 0.5, 0.4, 0.3);
  auto outcomeOf = [](const core::Scene& s) {
    const core::CollisionResult result = core::computeResponse(s, newton());
    Eigen::VectorXd out(10);
    out << result.bodies[1].linear_velocity, result.bodies[1].angular_velocity,
        result.impulses[0].normal_impulse, result.impulses[0].friction_impulse;
    return out;
  };
  const Vector3d n = scene.contacts[0].normal;
  const Vector3d t1 = n.cross(Vector3d(0.3, 1.0, -0.2)).normalized();
  const Vector3d t2 = n.cross(t1);
  // Directions: tilt t1, tilt t2, point x, y, z, restitution; their standard deviations.
  const double sigma_n = 0.01, e_sd = 0.02;
  const Vector3d sigma_p(0.004, 0.003, 0.002);
  const double h = 1e-5;
  Eigen::MatrixXd scaled(10, 6);
  for (int j = 0; j < 6; ++j) {
    auto moved = [&](double s) {
      core::Scene copy = scene;
      core::Contact& c = copy.contacts[0];
      if (j < 2) c.normal = (n + s * (j == 0 ? t1 : t2)).normalized();
      if (j >= 2 && j < 5) c.point[j - 2] += s;
      if (j == 5) c.restitution += s;
      return outcomeOf(copy);
    };
    const double sd = j < 2 ? sigma_n : j < 5 ? sigma_p[j - 2] : e_sd;
    scaled.col(j) = (moved(h) - moved(-h)) / (2.0 * h) * sd;
  }
  const Eigen::MatrixXd reference = scaled * scaled.transpose();
  ContactUncertainty uncertain;
  uncertain.normal_std_dev = sigma_n;
  uncertain.point_std_dev = sigma_p;
  uncertain.restitution = core::CoefficientDistribution::normal(0.5, e_sd);
  const core::OutcomeDistribution outcome =
      core::computeOutcomeDistribution(scene, {uncertain}, newton(), linear());
  ASSERT_EQ(outcome.mean.size(), 10);
  EXPECT_LT((outcome.covariance - reference).cwiseAbs().maxCoeff(),
            1e-5 * reference.diagonal().maxCoeff())
      << "linear:\n"
      << outcome.covariance << "\nreference:\n"
      << reference;
  EXPECT_LT((outcome.mean - outcomeOf(scene)).cwiseAbs().maxCoeff(), 1e-12);
  // Every quantity moves (the test is not vacuous), and the sampled method agrees at these small
  // spreads: means to 0.1 sd (the mean of a curved map moves by its curvature, second order in
  // the spreads, which the linear method leaves out), standard deviations to 2 %.
  core::WorkerPool pool(2);
  const core::OutcomeDistribution samples =
      core::computeOutcomeDistribution(scene, {uncertain}, newton(), sampled(8192), &pool);
  for (Eigen::Index r = 0; r < 10; ++r) {
    SCOPED_TRACE(outcome.labels[static_cast<std::size_t>(r)]);
    const double sd = std::sqrt(samples.covariance(r, r));
    ASSERT_GT(sd, 1e-5);
    EXPECT_NEAR(outcome.mean(r), samples.mean(r), 0.1 * sd);
    EXPECT_NEAR(std::sqrt(outcome.covariance(r, r)), sd, 0.02 * sd);
  }
}

namespace {

// The ball of the closed form sliding in x at vx onto the ground, its normal (a, b, 1) normalised:
// the margin mu_s P_n - |P_t| [N s] of the impulse that stops its slip under Newton's law, P =
// K^-1 (-e u_n n - u) with K = I / m + [r]^T [r] / I_ball (r = (0, 0, -R) from the centre to the
// point, u the ball's velocity there, u_n = u . n). It sticks iff the margin is >= 0.
double ballStickMargin(double a, double b, double vx, double mu_s) {
  const Eigen::Matrix3d r_cross =
      (Eigen::Matrix3d() << 0, kBallRadius, 0, -kBallRadius, 0, 0, 0, 0, 0)
          .finished();  // [r]x for r = (0, 0, -R)
  const double inertia = 0.4 * kBallMass * kBallRadius * kBallRadius;
  const Eigen::Matrix3d k =
      Eigen::Matrix3d::Identity() / kBallMass + r_cross.transpose() * r_cross / inertia;
  const Vector3d u(vx, 0.0, -kBallSpeed);
  const Vector3d n = Vector3d(a, b, 1.0).normalized();
  const Vector3d p = k.ldlt().solve(-kBallE * u.dot(n) * n - u);
  const double p_n = p.dot(n);
  return collision_response::testing::stickMargin(mu_s, p_n, Vector3d(p - p_n * n));
}
}  // namespace

// The stick probability moves with the normal too. The ball sliding in x at vx = 2.7 m/s with
// mu_s = 0.25 > mu_d = 0.2, its normal tilted with sigma = 0.02. At the mean normal it slides (its
// stick impulse 2.9 % beyond the cone: |P_t| = 2.7 / 1.75 = 1.543 N s against mu_s P_n = 1.5 N s);
// the exact probability over the tilt is the Gaussian integral of the stick condition
// (ballStickMargin() >= 0), here by the quadrature above. The linear method must see the margin's
// change with the normal: without it, its stick probability would be 0.
TEST(GeometryUncertainty, LinearStickProbabilityMovesWithTheNormal) {
  core::Scene scene = fallingBall();
  const double vx = 2.7, mu_s = 0.25, mu_d = 0.2, sigma = 0.02;
  scene.bodies[1].linear_velocity.x() = vx;
  scene.contacts[0].static_friction = mu_s;
  scene.contacts[0].dynamic_friction = mu_d;
  ASSERT_FALSE(core::computeResponse(scene, newton()).impulses[0].sticking);
  auto sticks = [&](double a, double b) {
    return ballStickMargin(a, b, vx, mu_s) >= 0.0 ? 1.0 : 0.0;
  };
  ASSERT_EQ(sticks(0.0, 0.0), 0.0);
  const double expected =
      gaussian2([&](double x, double y) { return sticks(sigma * x, sigma * y); });
  ASSERT_GT(expected, 0.2);
  ContactUncertainty uncertain;
  uncertain.normal_std_dev = sigma;
  const auto lin = core::computeOutcomeDistribution(scene, {uncertain}, newton(), linear());
  const auto smp = core::computeOutcomeDistribution(scene, {uncertain}, newton(), sampled(8192));
  EXPECT_NEAR(smp.stick_probability[0], expected, 0.01);
  EXPECT_NEAR(lin.stick_probability[0], expected, 0.02);
}

// The same ball's linear stick probability against the first order of the closed form's margin:
// Phi(g / (sigma |grad g|)), g = ballStickMargin() at the mean normal, its gradient over the tilt
// by central differences (1e-6). Under Newton's law the linear method takes a sliding contact's
// margin from its sticking impulse (the answer with the contact held), as here. (The margin of the
// slip speed that it took before, mu_s - mu*, mu* the mu_d at which the linearised slip would stop,
// gave 0.372 here; this first order is 0.3706, the exact probability 0.358.)
TEST(GeometryUncertainty, LinearStickMarginUnderAnUncertainNormalIsTheClosedFormsFirstOrder) {
  const double vx = 2.7, mu_s = 0.25, mu_d = 0.2, sigma = 0.02;
  const double stick = collision_response::testing::firstOrderStickProbability(
      [&](double a, double b) { return ballStickMargin(a, b, vx, mu_s); }, sigma, 1e-6);
  ASSERT_GT(stick, 0.05) << "the margin must be reachable: the check is weak";

  core::Scene scene = fallingBall();
  scene.bodies[1].linear_velocity.x() = vx;
  scene.contacts[0].static_friction = mu_s;
  scene.contacts[0].dynamic_friction = mu_d;
  ContactUncertainty uncertain;
  uncertain.normal_std_dev = sigma;
  const auto lin = core::computeOutcomeDistribution(scene, {uncertain}, newton(), linear());
  EXPECT_NEAR(lin.stick_probability[0], stick, 1e-4);
}

// Under Poisson's law the ball slides with mu_d until its slip stops: it ends sticking iff the slip
// stops within the impact (mu_s does not enter). The ball sliding at vx = 2.7 m/s with mu_d = 0.25
// < mu_s = 0.3, whose slip just fails to stop at the mean normal (it stops from mu_d = 0.257), its
// normal tilted with sigma = 0.02: the linear probability against the first order of the test's
// own solves, the ball's slip speed at the tilted normal over its rate in mu_d at the mean (central
// differences), to 1e-3, and against 8192 samples to 0.03 (0.371 against 0.350: the stop condition
// curves over the tilt, as Newton's stick condition does for the same ball, 0.3706 against 0.358).
TEST(GeometryUncertainty, LinearStickProbabilityUnderPoissonIsWhetherTheSlipStops) {
  const double vx = 2.7, mu_s = 0.3, mu_d = 0.25, sigma = 0.02;
  core::SolverOptions poisson = newton();
  poisson.law = core::ImpactLaw::kPoisson;
  poisson.time_budget = 60.0;  // (8192 samples of Poisson's integration: past 1 s under ASan)
  auto scene_at = [&](double a, double b, double dynamic) {
    core::Scene scene = fallingBall();
    scene.bodies[1].linear_velocity.x() = vx;
    scene.contacts[0].static_friction = mu_s;
    scene.contacts[0].dynamic_friction = dynamic;
    scene.contacts[0].normal = Vector3d(a, b, 1.0).normalized();
    return scene;
  };
  auto speed = [&](double a, double b, double dynamic) {
    const core::Scene scene = scene_at(a, b, dynamic);
    const core::CollisionResult after = core::computeResponse(scene, poisson);
    EXPECT_FALSE(after.impulses[0].sticking);
    const core::BodyState& ball = after.bodies[1];
    const Vector3d n = scene.contacts[0].normal;
    const Vector3d u =
        ball.linear_velocity + ball.angular_velocity.cross(scene.contacts[0].point - ball.position);
    return (u - n.dot(u) * n).norm();  // the ground does not move
  };
  const double rate = collision_response::testing::slipRateInMuD(
      [&](double dynamic) { return speed(0.0, 0.0, dynamic); }, mu_d);
  ASSERT_LT(rate, 0.0);
  const double stick = collision_response::testing::firstOrderStickProbability(
      [&](double a, double b) { return speed(a, b, mu_d) / rate; }, sigma, 1e-6);
  ASSERT_GT(stick, 0.05) << "the margin must be reachable: the check is weak";
  ContactUncertainty uncertain;
  uncertain.normal_std_dev = sigma;
  const core::Scene scene = scene_at(0.0, 0.0, mu_d);
  const auto lin = core::computeOutcomeDistribution(scene, {uncertain}, poisson, linear());
  EXPECT_NEAR(lin.stick_probability[0], stick, 1e-3);
  const auto smp = core::computeOutcomeDistribution(scene, {uncertain}, poisson, sampled(8192));
  EXPECT_NEAR(lin.stick_probability[0], smp.stick_probability[0], 0.03);
}

// At the stick/slip switch itself the linear distribution holds on one side only, and says so.
// The ball above at vx = 3.5 mu_s (1 + e) V = 2.625 m/s exactly (binary-exact numbers): at the mean
// normal the stick impulse is on the static cone's boundary, so a tilt of either sign along the
// slip sends it into the cone or out of it.
TEST(GeometryUncertainty, LinearWarnsWhereTheNormalsDifferenceCrossesTheStickSlipSwitch) {
  core::Scene scene = fallingBall();
  scene.bodies[1].linear_velocity.x() = 2.625;
  scene.contacts[0].static_friction = 0.25;
  scene.contacts[0].dynamic_friction = 0.2;
  ContactUncertainty uncertain;
  uncertain.normal_std_dev = 0.01;
  const auto lin = core::computeOutcomeDistribution(scene, {uncertain}, newton(), linear());
  int named = 0;
  for (const core::Warning& warning : lin.warnings)
    if (warning.field == "uncertainties[0].normal_std_dev") {
      ++named;
      EXPECT_NE(warning.reason.find("sampled"), std::string::npos) << warning.reason;
    }
  EXPECT_GE(named, 1);
  // Away from it (vx 2.7 m/s, 3 % beyond the cone), nothing is said of the normal.
  scene.bodies[1].linear_velocity.x() = 2.7;
  for (const core::Warning& warning :
       core::computeOutcomeDistribution(scene, {uncertain}, newton(), linear()).warnings)
    EXPECT_NE(warning.field, "uncertainties[0].normal_std_dev") << warning.reason;
}

// A unit cube landing flat on its 4 corners (mu_s 0.5 > mu_d 0.4): how the corners share the
// impulse is not unique, and the solver's split jumps at the slightest tilt of one corner's normal
// (a corner leaves the face's answer). No derivative exists there: a difference over 1e-6 rad
// would report spreads of thousands of N s. The linear method takes the secant over +-1 standard
// deviation instead and says so; its spreads then stay within the physics' bounds (no corner's
// normal impulse can spread by more than the face's whole normal impulse, 1.5 N s) and near the
// sampled method's (the twists within a factor 2).
TEST(GeometryUncertainty, LinearAcrossAJumpOfAFlatFaceTakesTheSecantAndSaysSo) {
  using collision_response::testing::contact;
  core::BodyState cube;
  cube.id = "cube";
  cube.mass = 1.0;
  cube.inertia = Eigen::Matrix3d::Identity() / 6.0;
  cube.position = {0.0, 0.0, 0.5};
  cube.linear_velocity = {0.3, 0.1, -1.0};
  cube.angular_velocity = {0.2, -0.1, 0.3};
  core::Scene scene;
  scene.bodies = {collision_response::testing::ground(), cube};
  for (const double x : {-0.5, 0.5})
    for (const double y : {-0.5, 0.5})
      scene.contacts.push_back(
          contact("ground", "cube", Vector3d(x, y, 0.0), Vector3d::UnitZ(), 0.5, 0.5, 0.4));
  ContactUncertainty uncertain;
  uncertain.normal_std_dev = 0.01;
  // Each tilted face goes to Lemke: under the sanitizers the 4096 samples take longer than the
  // default budget of 1 s.
  core::SolverOptions unhurried = newton();
  unhurried.time_budget = 600.0;
  const auto lin = core::computeOutcomeDistribution(scene, {uncertain}, unhurried, linear());
  const auto smp = core::computeOutcomeDistribution(scene, {uncertain}, unhurried, sampled(4096));
  int secants = 0;
  for (const core::Warning& warning : lin.warnings)
    if (warning.field == "uncertainties[0].normal_std_dev" &&
        warning.reason.find("secant") != std::string::npos)
      ++secants;
  EXPECT_GE(secants, 1);
  double face = 0.0;
  for (int c = 0; c < 4; ++c) face += lin.mean(6 + 4 * c);
  ASSERT_NEAR(face, 1.5, 1e-9);  // (1 + e) m |v_n|: the face stops and rebounds at e |v_n|
  for (int c = 0; c < 4; ++c) {
    SCOPED_TRACE(c);
    EXPECT_LE(std::sqrt(lin.covariance(6 + 4 * c, 6 + 4 * c)), face);
  }
  for (const int r : {0, 1, 2, 4, 5}) {
    SCOPED_TRACE(lin.labels[static_cast<std::size_t>(r)]);
    const double sd = std::sqrt(smp.covariance(r, r));
    ASSERT_GT(sd, 1e-4);
    EXPECT_GT(std::sqrt(lin.covariance(r, r)), 0.5 * sd);
    EXPECT_LT(std::sqrt(lin.covariance(r, r)), 2.0 * sd);
  }
}

TEST(GeometryUncertainty, BadSpreadsAreRefusedNamingTheField) {
  const core::Scene scene = fallingRod(0.2);
  auto field = [&](const ContactUncertainty& u, UncertaintyMethod method) {
    core::UncertaintyOptions options = sampled(64);
    options.method = method;
    return errorField([&] { core::computeOutcomeDistribution(scene, {u}, newton(), options); });
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  // Negative, not finite, or beyond the ranges (a normal spread beyond pi/2 rad, a point spread
  // beyond the length limit of 1e7 m).
  for (const double bad : {-0.01, nan, inf, 1.5708, 1.01e7}) {
    ContactUncertainty u;
    u.normal_std_dev = bad;
    EXPECT_EQ(field(u, UncertaintyMethod::kSampled), "uncertainties[0].normal_std_dev") << bad;
    EXPECT_EQ(field(u, UncertaintyMethod::kLinear), "uncertainties[0].normal_std_dev") << bad;
    if (bad == 1.5708) continue;  // a valid point spread
    for (int axis = 0; axis < 3; ++axis) {
      ContactUncertainty v;
      v.point_std_dev[axis] = bad;
      EXPECT_EQ(field(v, UncertaintyMethod::kSampled),
                std::string("uncertainties[0].point_std_dev.") + "xyz"[axis])
          << bad;
      EXPECT_EQ(field(v, UncertaintyMethod::kLinear),
                std::string("uncertainties[0].point_std_dev.") + "xyz"[axis])
          << bad;
    }
  }
  ContactUncertainty widest;  // the ends of the ranges are taken
  widest.normal_std_dev = 1.5707963267948966;
  EXPECT_EQ(field(widest, UncertaintyMethod::kSampled), "(no error)");
  // Valid spreads are taken by both methods (the linear one differences the solver along them).
  ContactUncertainty normal;
  normal.normal_std_dev = 0.01;
  EXPECT_EQ(field(normal, UncertaintyMethod::kLinear), "(no error)");
  ContactUncertainty point;
  point.restitution = core::CoefficientDistribution::normal(0.3, 0.01);
  point.point_std_dev = {0.0, 0.01, 0.0};
  EXPECT_EQ(field(point, UncertaintyMethod::kLinear), "(no error)");
  EXPECT_EQ(field(point, UncertaintyMethod::kSampled), "(no error)");
}
