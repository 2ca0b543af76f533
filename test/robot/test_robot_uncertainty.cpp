// Sampled and linear uncertainty of robot impacts (core::computeBodyOutcomeDistribution(),
// docs/uncertainty.md, "Robots"): the shipped arm (urdf/arm7.urdf) striking a fixed wall with its
// hand, frictionless, Newton's law. With one contact that stays active for every e, the impulse is
// -(1 + e) u_n / (J M^-1 J^T) and the joint velocities after are affine in e:
// qdot(e) = qdot(a) + (e - a) / (b - a) (qdot(b) - qdot(a)). With e uniform on [a, b] their mean is
// qdot((a + b) / 2), their covariance d d^T / 12 with d = qdot(b) - qdot(a), and the probability
// that |qdot_j| exceeds joint j's URDF limit L_j is the length of {e : |qdot_j(e)| > L_j} over
// b - a, solved for the crossing e here. The references use two deterministic solves
// (computeBodyResponse() at e = a and e = b) and nothing of the sampler.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "collision_response/core/body_impact_derivatives.h"
#include "collision_response/core/body_response.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/uncertainty.h"
#include "collision_response/core/worker_pool.h"
#include "collision_response/robot/articulated_body.h"
#include "collision_response/robot/urdf_loader.h"
#include "stick_margin.h"
#include "uncertainty_options.h"

namespace cr = collision_response::core;
namespace rb = collision_response::robot;
using collision_response::testing::errorField;
using collision_response::testing::linear;
using collision_response::testing::newton;
using collision_response::testing::sampled;
using Eigen::Vector3d;
using Eigen::VectorXd;

namespace {

const std::string kArm7 = ARM7_URDF;  // the shipped arm
constexpr double kA = 0.2, kB = 0.8;  // e uniform on [kA, kB]

struct Strike {
  rb::ArticulatedBody arm;
  cr::RigidBody wall;  // immovable (inverse mass 0)
  cr::ContactPoint contact;
};

// The arm at a swing scaled by `scale`, the hand's point 4 cm along its z striking a wall whose
// normal is that point's velocity (arm -> wall); restitution e, frictionless.
Strike strike(double scale, double e) {
  Strike s{rb::robotFromUrdfFile(kArm7), cr::RigidBody(), cr::ContactPoint()};
  const int joints = s.arm.jointCount();
  const std::vector<double> q0 = {0.1, 0.6, -0.2, -1.2, 0.3, 0.9, 0.2, 0.01, 0.01};
  const std::vector<double> v0 = {0.2, 0.5, -0.1, -0.6, 0.1, 0.3, 0.05, 0.0, 0.0};
  VectorXd q(joints), qdot(joints);
  for (int i = 0; i < joints; ++i) {
    q(i) = q0[static_cast<std::size_t>(i)];
    qdot(i) = scale * v0[static_cast<std::size_t>(i)];
  }
  s.arm.setState(q, qdot);
  const int hand = s.arm.linkIndex("hand");
  const Vector3d p = s.arm.linkPose(hand) * Vector3d(0, 0, 0.04);
  const Vector3d n = s.arm.partPointVelocity(hand, p).normalized();
  s.contact = cr::ContactPoint(0, 1, p, n, e, 0.0, 0.0);
  s.contact.part_a = hand;
  return s;
}

// The arm's velocity unknowns after a deterministic solve at restitution e.
VectorXd after(double scale, double e) {
  Strike s = strike(scale, e);
  std::vector<cr::BodyModel*> bodies{&s.arm, &s.wall};
  cr::computeBodyResponse(bodies, {s.contact}, newton());
  return s.arm.velocity();
}

// The fraction of e in [a, b] with |x0 + t (x1 - x0)| > limit, t = (e - a) / (b - a): the affine
// map's set above +limit and below -limit, each an interval of t clipped to [0, 1].
double exceedingFraction(double x0, double x1, double limit) {
  const double d = x1 - x0;
  auto measure = [&](double level, bool above) {  // {t in [0, 1]: x(t) > level} or < level
    if (d == 0.0) return (above ? x0 > level : x0 < level) ? 1.0 : 0.0;
    const double t = (level - x0) / d;  // the crossing
    const bool rising = d > 0.0;
    double lo = 0.0, hi = 1.0;
    if (above == rising)
      lo = std::max(lo, t);
    else
      hi = std::min(hi, t);
    return std::max(0.0, hi - lo);
  };
  return measure(limit, true) + measure(-limit, false);
}

TEST(RobotUncertainty, SampledArmStrikeMatchesTheAffineClosedForm) {
  // The swing scaled so that the joint whose velocity moves most with e sits at its limit at
  // e = (a + b) / 2: its limit probability is then well inside (0, 1).
  const VectorXd unit_a = after(1.0, kA), unit_b = after(1.0, kB);
  const VectorXd unit_mid = 0.5 * (unit_a + unit_b);
  rb::ArticulatedBody probe = strike(1.0, kA).arm;
  const int unknowns = probe.velocityCount();
  Eigen::Index pivot = 0;
  (unit_b - unit_a).head(7).cwiseAbs().maxCoeff(&pivot);
  const double limit = probe.velocityLimit(probe.jointOfUnknown(static_cast<int>(pivot)));
  ASSERT_TRUE(std::isfinite(limit));
  ASSERT_GT(std::abs(unit_mid(pivot)), 0.0);
  const double scale = limit / std::abs(unit_mid(pivot));

  const VectorXd qa = after(scale, kA), qb = after(scale, kB);
  const VectorXd d = qb - qa;
  ASSERT_GT(d.norm(), 0.1) << "e must move the joints";

  // The copies: one per thread of a 2-thread pool.
  cr::WorkerPool pool(2);
  std::vector<Strike> copies = {strike(scale, 0.5), strike(scale, 0.5)};
  std::vector<std::vector<cr::BodyModel*>> models;
  for (Strike& s : copies) models.push_back({&s.arm, &s.wall});
  VectorXd limits(unknowns);
  for (int k = 0; k < unknowns; ++k) {
    const int joint = probe.jointOfUnknown(k);
    limits(k) = joint >= 0 ? probe.velocityLimit(joint) : std::numeric_limits<double>::infinity();
  }
  cr::ContactUncertainty uncertain;
  uncertain.contact = 0;
  uncertain.restitution = cr::CoefficientDistribution::interval(kA, kB);
  cr::UncertaintyOptions sampling;
  sampling.method = cr::UncertaintyMethod::kSampled;
  sampling.samples = 4096;
  const VectorXd before = copies[0].arm.velocity();
  const cr::OutcomeDistribution outcome = cr::computeBodyOutcomeDistribution(
      models, {copies[0].contact}, {uncertain}, limits, newton(), sampling, &pool);

  ASSERT_EQ(outcome.mean.size(), unknowns + 4);
  ASSERT_EQ(outcome.labels.front(), "velocities[0]");
  ASSERT_EQ(outcome.labels[static_cast<std::size_t>(unknowns)], "impulses[0].normal_impulse");
  ASSERT_EQ(outcome.limit_probability.size(), static_cast<std::size_t>(unknowns));
  const double range = d.cwiseAbs().maxCoeff();
  const VectorXd mean = 0.5 * (qa + qb);
  const Eigen::MatrixXd covariance = d * d.transpose() / 12.0;
  const double variance_scale = covariance.diagonal().maxCoeff();
  for (int i = 0; i < unknowns; ++i) {
    SCOPED_TRACE("unknown " + std::to_string(i));
    EXPECT_NEAR(outcome.mean(i), mean(i), 1e-3 * range);
    for (int j = 0; j < unknowns; ++j)
      EXPECT_NEAR(outcome.covariance(i, j), covariance(i, j), 2e-3 * variance_scale);
    // Quantiles: the value at e's 5 % / 95 % quantiles, in the quantity's own order.
    const double x05 = qa(i) + 0.05 * d(i), x95 = qa(i) + 0.95 * d(i);
    EXPECT_NEAR(outcome.q05(i), std::min(x05, x95), 2e-3 * range);
    EXPECT_NEAR(outcome.q95(i), std::max(x05, x95), 2e-3 * range);
    const double exact =
        std::isfinite(limits(i)) ? exceedingFraction(qa(i), qb(i), limits(i)) : 0.0;
    EXPECT_NEAR(outcome.limit_probability[static_cast<std::size_t>(i)], exact, 2e-3);
  }
  // The pivot joint really crosses its limit inside [a, b].
  EXPECT_GT(outcome.limit_probability[static_cast<std::size_t>(pivot)], 0.2);
  EXPECT_LT(outcome.limit_probability[static_cast<std::size_t>(pivot)], 0.8);
  // The copies end at their pre-impact velocities.
  EXPECT_LT((copies[0].arm.velocity() - before).norm(), 1e-12);
  EXPECT_LT((copies[1].arm.velocity() - before).norm(), 1e-12);
}

// The arm's strike with its contact's normal and point uncertain (normal_std_dev, point_std_dev;
// docs/uncertainty.md, "Uncertain normal and point"), against a plain Monte Carlo loop over
// computeBodyResponse() that perturbs the contact itself: std::mt19937 normals, the test's own
// tangent basis (the law is isotropic in the tangent plane, so any basis gives the same one).
TEST(RobotUncertainty, UncertainNormalAndPointMatchPlainMonteCarlo) {
  const double sigma_n = 0.05;
  const Vector3d sigma_p(0.01, 0.02, 0.005);
  Strike s = strike(1.0, 0.5);
  const int unknowns = s.arm.velocityCount();
  cr::ContactUncertainty uncertain;
  uncertain.contact = 0;
  uncertain.normal_std_dev = sigma_n;
  uncertain.point_std_dev = sigma_p;
  cr::UncertaintyOptions sampling;
  sampling.method = cr::UncertaintyMethod::kSampled;
  sampling.samples = 4096;
  const cr::OutcomeDistribution outcome = cr::computeBodyOutcomeDistribution(
      {{&s.arm, &s.wall}}, {s.contact}, {uncertain},
      VectorXd::Constant(unknowns, std::numeric_limits<double>::infinity()), newton(), sampling);

  const Vector3d n = s.contact.normal;
  const Vector3d t1 = n.cross(Vector3d(0.7, -0.2, 0.4)).normalized();
  const Vector3d t2 = n.cross(t1);
  std::mt19937 random(7);
  std::normal_distribution<double> z(0.0, 1.0);
  constexpr int kDraws = 8000;
  Eigen::MatrixXd values(unknowns + 1, kDraws);
  const Strike base = strike(1.0, 0.5);
  for (int i = 0; i < kDraws; ++i) {
    Strike draw = base;
    cr::ContactPoint contact = draw.contact;
    contact.normal = (n + sigma_n * z(random) * t1 + sigma_n * z(random) * t2).normalized();
    for (int axis = 0; axis < 3; ++axis) contact.point[axis] += sigma_p[axis] * z(random);
    std::vector<cr::BodyModel*> bodies{&draw.arm, &draw.wall};
    const cr::BodyResponse response = cr::computeBodyResponse(bodies, {contact}, newton());
    values.col(i) << draw.arm.velocity(), response.impulses[0].normal_impulse;
  }
  const VectorXd mc_mean = values.rowwise().mean();
  const Eigen::MatrixXd centred = values.colwise() - mc_mean;
  const VectorXd mc_variance = centred.rowwise().squaredNorm() / (kDraws - 1.0);
  for (int r = 0; r <= unknowns; ++r) {
    const int row = r < unknowns ? r : unknowns;  // the normal impulse follows the unknowns
    SCOPED_TRACE(outcome.labels[static_cast<std::size_t>(row)]);
    const double spread = std::sqrt(mc_variance(r));
    if (spread < 1e-9) {  // a joint the contact does not move (the fingers)
      EXPECT_LT(std::sqrt(outcome.covariance(row, row)), 1e-9);
      continue;
    }
    EXPECT_NEAR(outcome.mean(row), mc_mean(r), 5.0 * spread / std::sqrt(double(kDraws)));
    EXPECT_NEAR(std::sqrt(outcome.covariance(row, row)), spread, 0.06 * spread);
  }
  // The impulse moves with the geometry: the test is not vacuous.
  EXPECT_GT(mc_variance(unknowns), 0.0);
}

// The linear method with robots (docs/uncertainty.md, "Robots"): the arm's strike with friction,
// its normal tilted 30 degrees off the hand point's velocity so that the contact slides, e, mu_s
// and mu_d all uncertain (normals). The map from the coefficients to the outcome is smooth there,
// so for small spreads the linear answer is the sampled one to second order.
constexpr double kE = 0.5, kMuS = 0.3, kMuD = 0.25;

Strike slidingStrike(double e, double mu_s, double mu_d) {
  Strike s = strike(1.0, e);
  const Vector3d v = s.contact.normal;
  const Vector3d t = v.cross(Vector3d(0.3, 0.8, -0.5)).normalized();
  s.contact.normal = (std::cos(0.5236) * v + std::sin(0.5236) * t).normalized();
  s.contact.static_friction = mu_s;
  s.contact.dynamic_friction = mu_d;
  return s;
}

// The stick margin mu_s P_n - |P_t| [N s] of `t`'s sticking impulse under Newton's law: the answer
// with its contact held (friction 100, far above the impulse's ratio of about 0.35), which must
// stick; mu_s is the contact's own.
double heldStickMargin(Strike t) {
  const double mu_s = t.contact.static_friction;
  t.contact.static_friction = t.contact.dynamic_friction = 100.0;
  std::vector<cr::BodyModel*> bodies{&t.arm, &t.wall};
  const cr::BodyResponse response = cr::computeBodyResponse(bodies, {t.contact}, newton());
  EXPECT_TRUE(response.impulses[0].sticking);
  return collision_response::testing::stickMargin(mu_s, response.impulses[0].normal_impulse,
                                                  response.impulses[0].friction_impulse);
}

// The outcome of one deterministic solve at (e, mu_s, mu_d): the arm's unknowns, then the
// contact's normal and friction impulses, in the order of computeBodyOutcomeDistribution().
VectorXd slidingOutcome(const Vector3d& theta) {
  Strike s = slidingStrike(theta(0), theta(1), theta(2));
  std::vector<cr::BodyModel*> bodies{&s.arm, &s.wall};
  const cr::BodyResponse response = cr::computeBodyResponse(bodies, {s.contact}, newton());
  VectorXd out(s.arm.velocityCount() + 4);
  out << s.arm.velocity(), response.impulses[0].normal_impulse,
      response.impulses[0].friction_impulse;
  return out;
}

// The test's own central differences of slidingOutcome() over (e, mu_s, mu_d), h = 1e-6.
Eigen::MatrixXd slidingJacobian() {
  const Vector3d theta(kE, kMuS, kMuD);
  const double h = 1e-6;
  Eigen::MatrixXd jacobian;
  for (int k = 0; k < 3; ++k) {
    const VectorXd column = (slidingOutcome(theta + h * Vector3d::Unit(k)) -
                             slidingOutcome(theta - h * Vector3d::Unit(k))) /
                            (2.0 * h);
    jacobian.conservativeResize(column.size(), 3);
    jacobian.col(k) = column;
  }
  return jacobian;
}

cr::ContactUncertainty coefficientsUncertain(const Vector3d& sigma) {
  cr::ContactUncertainty u;
  u.contact = 0;
  u.restitution = cr::CoefficientDistribution::normal(kE, sigma(0));
  u.static_friction = cr::CoefficientDistribution::normal(kMuS, sigma(1));
  u.dynamic_friction = cr::CoefficientDistribution::normal(kMuD, sigma(2));
  return u;
}

VectorXd noLimits(int unknowns) {
  return VectorXd::Constant(unknowns, std::numeric_limits<double>::infinity());
}

// P(|X| > limit) for X ~ N(mu, sigma^2), from erfc: the test's own closed form.
double normalTail(double mu, double sigma, double limit) {
  const double below = 0.5 * std::erfc(((limit + mu) / sigma) / std::sqrt(2.0));  // X < -limit
  const double above = 0.5 * std::erfc(((limit - mu) / sigma) / std::sqrt(2.0));  // X > limit
  return below + above;
}

TEST(RobotUncertainty, TheSlidingStrikeSlidesAwayFromASwitch) {
  Strike s = slidingStrike(kE, kMuS, kMuD);
  const cr::BodyImpactDerivatives d =
      cr::computeBodyImpactDerivatives({&s.arm, &s.wall}, {s.contact}, newton());
  ASSERT_EQ(d.contacts.size(), 1u);
  EXPECT_EQ(d.contacts[0].mode, cr::ImpactMode::kSliding);
  EXPECT_FALSE(d.contacts[0].at_switch);
  EXPECT_GT(d.result.impulses[0].friction_impulse.norm(), 0.0);
}

// (2) Linear against the test's own central differences of computeBodyResponse() over (e, mu_s,
// mu_d): covariance = J S J^T with S = diag(sigma^2), quantiles = mean -/+ z95 sqrt(diag), mean
// = the deterministic solve at the means. Central differences with h = 1e-6 on a smooth map have
// a truncation error of order h^2 (1e-12) and a round-off of order 1e-16 / h = 1e-10 relative:
// 1e-6 of the covariance's scale leaves room for both.
TEST(RobotUncertainty, LinearMatchesTheTestsOwnFiniteDifferences) {
  const Vector3d sigma(0.02, 0.03, 0.02);
  const VectorXd mean = slidingOutcome(Vector3d(kE, kMuS, kMuD));
  const Eigen::Index m = mean.size();
  const Eigen::MatrixXd jacobian = slidingJacobian();
  ASSERT_GT(jacobian.col(0).norm(), 1e-3) << "e must move the outcome";
  ASSERT_GT(jacobian.col(2).norm(), 1e-3) << "mu_d must move the outcome";
  const Eigen::MatrixXd covariance =
      jacobian * sigma.cwiseAbs2().asDiagonal() * jacobian.transpose();

  Strike s = slidingStrike(kE, kMuS, kMuD);
  const VectorXd before = s.arm.velocity();
  const int unknowns = s.arm.velocityCount();
  const cr::OutcomeDistribution outcome = cr::computeBodyOutcomeDistribution(
      {{&s.arm, &s.wall}}, {s.contact}, {coefficientsUncertain(sigma)}, noLimits(unknowns),
      newton(), linear());
  EXPECT_EQ(outcome.method, cr::UncertaintyMethod::kLinear);
  EXPECT_EQ(outcome.samples, 0u);
  ASSERT_EQ(outcome.mean.size(), m);
  ASSERT_EQ(outcome.covariance.rows(), m);
  EXPECT_EQ(outcome.labels[static_cast<std::size_t>(unknowns)], "impulses[0].normal_impulse");
  const double scale = covariance.diagonal().maxCoeff();
  const double mean_scale = mean.cwiseAbs().maxCoeff();
  constexpr double kZ95 = 1.6448536269514722;  // Phi^-1(0.95)
  for (Eigen::Index i = 0; i < m; ++i) {
    SCOPED_TRACE(outcome.labels[static_cast<std::size_t>(i)]);
    EXPECT_NEAR(outcome.mean(i), mean(i), 1e-12 * mean_scale);
    for (Eigen::Index j = 0; j < m; ++j)
      EXPECT_NEAR(outcome.covariance(i, j), covariance(i, j), 1e-6 * scale);
    const double spread = std::sqrt(covariance(i, i));
    EXPECT_NEAR(outcome.q05(i), mean(i) - kZ95 * spread, 1e-6 * std::sqrt(scale));
    EXPECT_NEAR(outcome.q95(i), mean(i) + kZ95 * spread, 1e-6 * std::sqrt(scale));
  }
  // The stick probability of the sliding contact from the linearised margin (docs/uncertainty.md,
  // "Linear"): under Newton's law g = mu_s P_n - |P_t| of its sticking impulse (heldStickMargin(),
  // the test's own solves), sd(g)^2 = (dg/de)^2 sigma_e^2 + (P_n sigma_mu_s)^2 (mu_d does not
  // enter the sticking impulse), dg/de by central differences (1e-6).
  auto margin = [&](double e, double mu_s) {
    return heldStickMargin(slidingStrike(e, mu_s, kMuD));
  };
  const double h = 1e-6;
  const double g = margin(kE, kMuS);
  const double g_e = (margin(kE + h, kMuS) - margin(kE - h, kMuS)) / (2.0 * h);
  const double p_n = (margin(kE, kMuS + h) - margin(kE, kMuS - h)) / (2.0 * h);  // dg/dmu_s
  ASSERT_LT(g, 0.0) << "it slides";
  ASSERT_GT(std::abs(g_e), 1e-3) << "e must move the margin";
  const double margin_sd = std::hypot(g_e * sigma(0), p_n * sigma(1));
  const double stick = 0.5 * std::erfc(-g / margin_sd / std::sqrt(2.0));
  ASSERT_EQ(outcome.stick_probability.size(), 1u);
  EXPECT_NEAR(outcome.stick_probability[0], stick, 1e-5);
  ASSERT_GT(stick, 1e-3) << "the margin must be reachable: the check is weak";
  // Every limit infinite: never exceeded.
  for (const double p : outcome.limit_probability) EXPECT_EQ(p, 0.0);
  // The bodies end at their pre-impact velocities.
  EXPECT_LT((s.arm.velocity() - before).norm(), 1e-12);
}

// (1) and (3): linear against sampled (8192 scrambled Halton points) for a small spread, and the
// limit probability of the joint that moves most against the closed-form normal tail, its limit
// set half a standard deviation above its mean's magnitude. With sigma = 0.005 the map's
// curvature moves the mean by O(sigma^2) and the spread by O(sigma) relative; the quasi-random
// sampling error for 8192 points in 3 dimensions is well under a hundredth of a standard
// deviation. Tolerances: mean within 0.02 sigma_r, covariance within 0.02 sqrt(C_ii C_jj) (the
// scale of a covariance entry), quantiles within 0.03 sigma_r (an empirical quantile's own
// error is larger than the mean's), the limit probability within 0.01 (the sample fraction moves
// by 1 / 8192 per sample; the normal approximation of a map curved by O(sigma) by less).
TEST(RobotUncertainty, LinearMatchesSampledForASmallSpreadWithRobots) {
  const Vector3d sigma(0.005, 0.005, 0.005);
  Strike s = slidingStrike(kE, kMuS, kMuD);
  const int unknowns = s.arm.velocityCount();
  // The test's own mean and standard deviations (central differences, as above).
  const VectorXd mean = slidingOutcome(Vector3d(kE, kMuS, kMuD));
  const VectorXd spread = (slidingJacobian() * sigma.asDiagonal()).rowwise().norm();
  Eigen::Index pivot = 0;
  spread.head(7).maxCoeff(&pivot);
  ASSERT_GT(spread(pivot), 1e-4);
  VectorXd limits = noLimits(unknowns);
  limits(pivot) = std::abs(mean(pivot)) + 0.5 * spread(pivot);
  const double tail = normalTail(mean(pivot), spread(pivot), limits(pivot));
  ASSERT_GT(tail, 0.1);
  ASSERT_LT(tail, 0.9);

  const cr::OutcomeDistribution lin = cr::computeBodyOutcomeDistribution(
      {{&s.arm, &s.wall}}, {s.contact}, {coefficientsUncertain(sigma)}, limits, newton(), linear());
  cr::WorkerPool pool(2);
  Strike other = slidingStrike(kE, kMuS, kMuD);
  const cr::OutcomeDistribution sam = cr::computeBodyOutcomeDistribution(
      {{&s.arm, &s.wall}, {&other.arm, &other.wall}}, {s.contact}, {coefficientsUncertain(sigma)},
      limits, newton(), sampled(8192), &pool);
  const Eigen::Index m = lin.mean.size();
  ASSERT_EQ(sam.mean.size(), m);
  EXPECT_EQ(lin.labels, sam.labels);
  for (Eigen::Index i = 0; i < m; ++i) {
    SCOPED_TRACE(lin.labels[static_cast<std::size_t>(i)]);
    const double si = std::sqrt(sam.covariance(i, i));
    if (si < 1e-12) {  // a joint the contact does not move
      EXPECT_LT(std::sqrt(lin.covariance(i, i)), 1e-9);
      continue;
    }
    EXPECT_NEAR(lin.mean(i), sam.mean(i), 0.02 * si);
    for (Eigen::Index j = 0; j < m; ++j) {
      const double sj = std::sqrt(sam.covariance(j, j));
      EXPECT_NEAR(lin.covariance(i, j), sam.covariance(i, j), 0.02 * si * sj + 1e-24);
    }
    EXPECT_NEAR(lin.q05(i), sam.q05(i), 0.03 * si);
    EXPECT_NEAR(lin.q95(i), sam.q95(i), 0.03 * si);
  }
  EXPECT_NEAR(lin.stick_probability[0], sam.stick_probability[0], 1e-3);
  // (3) The limit probability: the closed form at the test's own mean and spread, and sampled.
  const auto p = static_cast<std::size_t>(pivot);
  EXPECT_NEAR(lin.limit_probability[p], tail, 1e-6);
  EXPECT_NEAR(lin.limit_probability[p], sam.limit_probability[p], 0.01);
  for (Eigen::Index r = 0; r < unknowns; ++r) {
    if (r == pivot) continue;
    EXPECT_EQ(lin.limit_probability[static_cast<std::size_t>(r)], 0.0);
  }
}

// No spread at all: sigma = 0 for every unknown, the limit probability exactly 1 where the
// prediction's magnitude exceeds the limit and exactly 0 where it does not.
TEST(RobotUncertainty, LinearLimitProbabilityWithoutSpreadIsExact) {
  Strike s = slidingStrike(kE, kMuS, kMuD);
  const int unknowns = s.arm.velocityCount();
  const VectorXd mean = slidingOutcome(Vector3d(kE, kMuS, kMuD));
  VectorXd limits(unknowns);
  for (int r = 0; r < unknowns; ++r)
    limits(r) = r % 2 == 0 ? 0.5 * std::abs(mean(r)) : 2.0 * std::abs(mean(r)) + 1e-9;
  cr::ContactUncertainty exact;  // the contact named, nothing uncertain
  exact.contact = 0;
  const cr::OutcomeDistribution outcome = cr::computeBodyOutcomeDistribution(
      {{&s.arm, &s.wall}}, {s.contact}, {exact}, limits, newton(), linear());
  EXPECT_EQ(outcome.covariance.norm(), 0.0);
  bool some_over = false;
  for (int r = 0; r < unknowns; ++r) {
    SCOPED_TRACE(r);
    const bool over = std::abs(mean(r)) > limits(r);
    some_over |= over;
    EXPECT_EQ(outcome.limit_probability[static_cast<std::size_t>(r)], over ? 1.0 : 0.0);
  }
  EXPECT_TRUE(some_over);
}

// (4) The linear method with the sliding strike's normal and point uncertain as well as its
// coefficients: against J S J^T with J the test's own central differences of computeBodyResponse()
// (the normal tilted along the test's own tangent basis: for the isotropic tilt the covariance
// does not depend on the basis; the point moved along x, y, z; e, mu_s, mu_d as above), and
// against 8192 samples at these small spreads. The arm ends at its pre-impact velocities.
TEST(RobotUncertainty, LinearWithAnUncertainNormalAndPointMatchesDifferencesAndSamples) {
  const Vector3d coefficient_sd(0.005, 0.005, 0.005), point_sd(0.001, 0.0015, 0.0005);
  const double normal_sd = 0.002;
  const Strike base = slidingStrike(kE, kMuS, kMuD);
  const Vector3d n = base.contact.normal;
  const Vector3d t1 = n.cross(Vector3d(0.7, -0.2, 0.4)).normalized();
  const Vector3d t2 = n.cross(t1);
  auto outcomeAt = [&](int direction, double step) {
    Strike s = slidingStrike(kE, kMuS, kMuD);
    cr::ContactPoint& c = s.contact;
    if (direction < 2) c.normal = (n + step * (direction == 0 ? t1 : t2)).normalized();
    if (direction >= 2 && direction < 5) c.point[direction - 2] += step;
    if (direction == 5) c.restitution += step;
    if (direction == 6) c.static_friction += step;
    if (direction == 7) c.dynamic_friction += step;
    std::vector<cr::BodyModel*> bodies{&s.arm, &s.wall};
    const cr::BodyResponse response = cr::computeBodyResponse(bodies, {c}, newton());
    VectorXd out(s.arm.velocityCount() + 4);
    out << s.arm.velocity(), response.impulses[0].normal_impulse,
        response.impulses[0].friction_impulse;
    return out;
  };
  const double sds[8] = {normal_sd,   normal_sd,         point_sd(0),       point_sd(1),
                         point_sd(2), coefficient_sd(0), coefficient_sd(1), coefficient_sd(2)};
  const VectorXd mean = outcomeAt(0, 0.0);
  const Eigen::Index m = mean.size();
  Eigen::MatrixXd scaled(m, 8);
  const double h = 1e-6;
  for (int j = 0; j < 8; ++j)
    scaled.col(j) = (outcomeAt(j, h) - outcomeAt(j, -h)) / (2.0 * h) * sds[j];
  const Eigen::MatrixXd covariance = scaled * scaled.transpose();

  cr::ContactUncertainty uncertain = coefficientsUncertain(coefficient_sd);
  uncertain.normal_std_dev = normal_sd;
  uncertain.point_std_dev = point_sd;
  Strike s = slidingStrike(kE, kMuS, kMuD);
  const VectorXd before = s.arm.velocity();
  const int unknowns = s.arm.velocityCount();
  const cr::OutcomeDistribution outcome = cr::computeBodyOutcomeDistribution(
      {{&s.arm, &s.wall}}, {s.contact}, {uncertain}, noLimits(unknowns), newton(), linear());
  ASSERT_EQ(outcome.mean.size(), m);
  EXPECT_LT((s.arm.velocity() - before).norm(), 1e-12);
  const double scale = covariance.diagonal().maxCoeff();
  EXPECT_LT((outcome.mean - mean).cwiseAbs().maxCoeff(), 1e-12 * mean.cwiseAbs().maxCoeff());
  EXPECT_LT((outcome.covariance - covariance).cwiseAbs().maxCoeff(), 1e-5 * scale)
      << "linear:\n"
      << outcome.covariance << "\ndifferences:\n"
      << covariance;
  // The geometry's share is not small: without it the covariance is far from this one.
  EXPECT_GT((covariance - scaled.rightCols(3) * scaled.rightCols(3).transpose()).norm(),
            0.1 * covariance.norm());
  for (const cr::Warning& warning : outcome.warnings)  // no mode change along the differences
    EXPECT_EQ(warning.field.find("_std_dev"), std::string::npos) << warning.reason;

  Strike t = slidingStrike(kE, kMuS, kMuD);
  const cr::OutcomeDistribution samples = cr::computeBodyOutcomeDistribution(
      {{&t.arm, &t.wall}}, {t.contact}, {uncertain}, noLimits(unknowns), newton(), sampled(8192));
  for (Eigen::Index r = 0; r < m; ++r) {
    SCOPED_TRACE(outcome.labels[static_cast<std::size_t>(r)]);
    const double sd = std::sqrt(samples.covariance(r, r));
    if (sd < 1e-9) {  // a joint the contact does not move (the fingers)
      EXPECT_LT(std::sqrt(outcome.covariance(r, r)), 1e-9);
      continue;
    }
    EXPECT_NEAR(outcome.mean(r), samples.mean(r), 0.05 * sd);
    EXPECT_NEAR(std::sqrt(outcome.covariance(r, r)), sd, 0.03 * sd);
  }
}

// (4b) The stick probability of the robot's sliding contact moves with its normal: the strike
// above with mu_s = 0.345, just below the stick impulse's ratio at the mean normal (0.348: it
// slides), its normal uncertain (0.01 rad), nothing else. The linear method takes the margin of
// the sticking impulse, differenced over the tilt (checked in (4c)): 0.384, against 0.38 from 4096
// samples. (The slip speed's margin that it took before gave 0.18: on this strike the slip turns
// as mu_d grows, and the mu_d at which it would stop, 0.356, is not the sticking threshold 0.348.)
// The spread reaching the switch is warned of.
TEST(RobotUncertainty, LinearStickProbabilityMovesWithAnUncertainNormal) {
  Strike s = slidingStrike(kE, 0.345, kMuD);
  const int unknowns = s.arm.velocityCount();
  {
    Strike probe = slidingStrike(kE, 0.345, kMuD);
    std::vector<cr::BodyModel*> bodies{&probe.arm, &probe.wall};
    const cr::BodyResponse response = cr::computeBodyResponse(bodies, {probe.contact}, newton());
    ASSERT_FALSE(response.impulses[0].sticking);
  }
  cr::ContactUncertainty u;
  u.contact = 0;
  u.normal_std_dev = 0.01;
  const cr::OutcomeDistribution lin = cr::computeBodyOutcomeDistribution(
      {{&s.arm, &s.wall}}, {s.contact}, {u}, noLimits(unknowns), newton(), linear());
  Strike t = slidingStrike(kE, 0.345, kMuD);
  const cr::OutcomeDistribution smp = cr::computeBodyOutcomeDistribution(
      {{&t.arm, &t.wall}}, {t.contact}, {u}, noLimits(unknowns), newton(), sampled(4096));
  EXPECT_GT(smp.stick_probability[0], 0.2);
  EXPECT_NEAR(lin.stick_probability[0], smp.stick_probability[0], 0.03);
  bool warned = false;
  for (const cr::Warning& warning : lin.warnings)
    warned |= warning.field == "contacts[0]" &&
              warning.reason.find("stick/slip switch") != std::string::npos;
  EXPECT_TRUE(warned);
}

// (4c) The sliding contact's stick margin under an uncertain normal, to first order, against the
// test's own solves: g(a, b) = mu_s P_n - |P_t| of the sticking impulse (heldStickMargin()) with
// the normal tilted to normalize(n + a t1 + b t2) (any orthonormal t1, t2: both tilts have the same
// sigma, so the margin's variance sigma^2 |grad g|^2 does not depend on the basis), its gradient by
// central differences (1e-6); P = Phi(g / (sigma |grad g|)).
TEST(RobotUncertainty, LinearStickMarginUnderAnUncertainNormalMatchesTheTestsOwnDifferences) {
  constexpr double kMuSHere = 0.345, sigma = 0.01;
  const Vector3d n0 = slidingStrike(kE, kMuSHere, kMuD).contact.normal;
  const Vector3d t1 = n0.unitOrthogonal();
  const Vector3d t2 = n0.cross(t1);
  const double stick = collision_response::testing::firstOrderStickProbability(
      [&](double a, double b) {
        Strike t = slidingStrike(kE, kMuSHere, kMuD);
        t.contact.normal = (n0 + a * t1 + b * t2).normalized();
        return heldStickMargin(t);
      },
      sigma, 1e-6);
  ASSERT_GT(stick, 0.05) << "the margin must be reachable: the check is weak";

  Strike s = slidingStrike(kE, kMuSHere, kMuD);
  cr::ContactUncertainty u;
  u.contact = 0;
  u.normal_std_dev = sigma;
  const cr::OutcomeDistribution lin = cr::computeBodyOutcomeDistribution(
      {{&s.arm, &s.wall}}, {s.contact}, {u}, noLimits(s.arm.velocityCount()), newton(), linear());
  ASSERT_EQ(lin.stick_probability.size(), 1u);
  EXPECT_NEAR(lin.stick_probability[0], stick, 1e-3);
}

// (4d) The same sliding contact's stick margin along an uncertain e, to first order against the
// test's own solves: g(e) = mu_s P_n - |P_t| of the sticking impulse (heldStickMargin()), dg/de by
// central differences (1e-6). 0.273 here, against 0.271 from 4096 samples (checked to 0.02; the
// slip speed's margin taken before gave 0.035). An uncertain mu_d alone leaves it at 0: under
// Newton's law the sticking impulse does not read mu_d, and this strike sticks at no mu_d (4096
// samples: 0).
TEST(RobotUncertainty, LinearStickMarginAlongAnUncertainEMatchesTheTestsOwnDifferences) {
  constexpr double kMuSHere = 0.345, sigma = 0.12;
  const double stick = collision_response::testing::firstOrderStickProbabilityAlong(
      [&](double de) { return heldStickMargin(slidingStrike(kE + de, kMuSHere, kMuD)); }, sigma,
      1e-6);
  ASSERT_GT(stick, 0.02) << "the margin must be reachable: the check is weak";
  auto linearWith = [&](const cr::ContactUncertainty& u) {
    Strike s = slidingStrike(kE, kMuSHere, kMuD);
    return cr::computeBodyOutcomeDistribution({{&s.arm, &s.wall}}, {s.contact}, {u},
                                              noLimits(s.arm.velocityCount()), newton(), linear());
  };
  cr::ContactUncertainty u;
  u.contact = 0;
  u.restitution = cr::CoefficientDistribution::normal(kE, sigma);
  const cr::OutcomeDistribution lin = linearWith(u);
  ASSERT_EQ(lin.stick_probability.size(), 1u);
  // (1e-3: the library's variance is the truncated normal's, 0.06 % below sigma^2.)
  EXPECT_NEAR(lin.stick_probability[0], stick, 1e-3);
  Strike t = slidingStrike(kE, kMuSHere, kMuD);
  EXPECT_NEAR(
      lin.stick_probability[0],
      cr::computeBodyOutcomeDistribution({{&t.arm, &t.wall}}, {t.contact}, {u},
                                         noLimits(t.arm.velocityCount()), newton(), sampled(4096))
          .stick_probability[0],
      0.02);
  cr::ContactUncertainty only_mu_d;
  only_mu_d.contact = 0;
  only_mu_d.dynamic_friction = cr::CoefficientDistribution::normal(kMuD, 0.04);
  EXPECT_EQ(linearWith(only_mu_d).stick_probability[0], 0.0);
}

// (4e) Under Poisson's law the contact slides with mu_d until its slip stops, then holds: it ends
// sticking iff the slip stops within the impact (mu_s does not enter). The strike above with mu_d
// = 0.37 and mu_s = 0.45 (the band between them), whose slip just fails to stop (it stops from mu_d
// = 0.38 on), with e uncertain, then its normal. The linear method takes the margin s / s_mu, s the
// slip speed after the impact and s_mu = ds/dmu_d at the means, linear in s: against the first
// order of the test's own solves (the hand point's slip speed over e or the tilt, divided by its
// rate in mu_d at the means, all by central differences) to 1e-3, and against 4096 samples to 0.01
// (linear 0.0253 and 0.162, sampled 0.0254 and 0.161; linearising mu* = mu_d - s / s_mu instead,
// s_mu moving too, gave 0.043 and 0.168).
TEST(RobotUncertainty, LinearStickMarginUnderPoissonIsWhetherTheSlipStops) {
  constexpr double kMuDHere = 0.37, kMuSHere = 0.45;
  cr::SolverOptions poisson = newton();
  poisson.law = cr::ImpactLaw::kPoisson;
  poisson.time_budget = 60.0;  // (4096 samples of the arm's Poisson strike: past 1 s under ASan)
  const Vector3d n0 = slidingStrike(kE, kMuSHere, kMuDHere).contact.normal;
  const Vector3d t1 = n0.unitOrthogonal();
  const Vector3d t2 = n0.cross(t1);
  // The hand point's slip speed after a Poisson solve at e, the normal tilted by (a, b), mu_d.
  auto speed = [&](double e, double a, double b, double mu_d) {
    Strike t = slidingStrike(e, kMuSHere, mu_d);
    t.contact.normal = (n0 + a * t1 + b * t2).normalized();
    std::vector<cr::BodyModel*> bodies{&t.arm, &t.wall};
    const cr::BodyResponse response = cr::computeBodyResponse(bodies, {t.contact}, poisson);
    EXPECT_FALSE(response.impulses[0].sticking);
    const Vector3d n = t.contact.normal;
    const Vector3d v = t.arm.partPointVelocity(t.arm.linkIndex("hand"), t.contact.point);
    return (v - n.dot(v) * n).norm();
  };
  const double rate = collision_response::testing::slipRateInMuD(
      [&](double mu) { return speed(kE, 0.0, 0.0, mu); }, kMuDHere);
  ASSERT_LT(rate, 0.0) << "more friction must slow the slip";
  auto margin = [&](double e, double a, double b) { return speed(e, a, b, kMuDHere) / rate; };
  const double sigma_e = 0.1, sigma_n = 0.01;
  const double in_e = collision_response::testing::firstOrderStickProbabilityAlong(
      [&](double de) { return margin(kE + de, 0.0, 0.0); }, sigma_e, 1e-6);
  const double in_normal = collision_response::testing::firstOrderStickProbability(
      [&](double a, double b) { return margin(kE, a, b); }, sigma_n, 1e-6);
  ASSERT_GT(in_e, 0.01) << "the margin must be reachable: the check is weak";
  ASSERT_GT(in_normal, 0.05) << "the margin must be reachable: the check is weak";
  cr::ContactUncertainty u_e;
  u_e.contact = 0;
  u_e.restitution = cr::CoefficientDistribution::normal(kE, sigma_e);
  cr::ContactUncertainty u_n;
  u_n.contact = 0;
  u_n.normal_std_dev = sigma_n;
  for (const auto& [u, reference] : {std::pair{u_e, in_e}, std::pair{u_n, in_normal}}) {
    auto probability = [&](const cr::UncertaintyOptions& method) {
      Strike s = slidingStrike(kE, kMuSHere, kMuDHere);
      return cr::computeBodyOutcomeDistribution({{&s.arm, &s.wall}}, {s.contact}, {u},
                                                noLimits(s.arm.velocityCount()), poisson, method)
          .stick_probability[0];
    };
    const double lin = probability(linear());
    EXPECT_NEAR(lin, reference, 1e-3);
    EXPECT_NEAR(lin, probability(sampled(4096)), 0.01);
  }
}

// (5) Bad spreads are refused naming the field under either method; valid normal and point
// spreads are taken by both. The bodies are left untouched.
TEST(RobotUncertainty, BadSpreadsAreRefusedNamingTheField) {
  Strike s = slidingStrike(kE, kMuS, kMuD);
  const VectorXd before = s.arm.velocity();
  const VectorXd limits = noLimits(s.arm.velocityCount());
  auto field = [&](const cr::ContactUncertainty& u, const cr::UncertaintyOptions& method) {
    return errorField([&] {
      cr::computeBodyOutcomeDistribution({{&s.arm, &s.wall}}, {s.contact}, {u}, limits, newton(),
                                         method);
    });
  };
  cr::ContactUncertainty normal = coefficientsUncertain(Vector3d(0.01, 0.01, 0.01));
  normal.normal_std_dev = 0.05;
  EXPECT_EQ(field(normal, linear()), "(no error)");
  normal.normal_std_dev = -0.05;
  EXPECT_EQ(field(normal, linear()), "uncertainties[0].normal_std_dev");
  cr::ContactUncertainty point;
  point.contact = 0;
  point.point_std_dev = Vector3d(0.0, 0.01, 0.0);
  EXPECT_EQ(field(point, linear()), "(no error)");
  EXPECT_EQ(field(point, sampled(16)), "(no error)");
  point.point_std_dev = Vector3d(0.0, std::numeric_limits<double>::quiet_NaN(), 0.0);
  EXPECT_EQ(field(point, linear()), "uncertainties[0].point_std_dev.y");
  cr::ContactUncertainty negative;
  negative.contact = 0;
  negative.restitution = cr::CoefficientDistribution::normal(kE, -0.1);
  EXPECT_EQ(field(negative, linear()), "uncertainties[0].restitution.std_dev");
  EXPECT_LT((s.arm.velocity() - before).norm(), 1e-12);  // (the sampled call: v' + (v - v'))
}

}  // namespace
