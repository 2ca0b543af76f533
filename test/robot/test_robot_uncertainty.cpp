// Sampled uncertainty of robot impacts (core::computeBodyOutcomeDistribution(),
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

#include "collision_response/core/body_response.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/uncertainty.h"
#include "collision_response/core/worker_pool.h"
#include "collision_response/robot/articulated_body.h"
#include "collision_response/robot/urdf_loader.h"

namespace cr = collision_response::core;
namespace rb = collision_response::robot;
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

cr::SolverOptions newton() {
  cr::SolverOptions options;
  options.law = cr::ImpactLaw::kNewton;
  return options;
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

TEST(RobotUncertainty, LinearIsRefusedNamingTheOption) {
  Strike s = strike(1.0, 0.5);
  cr::ContactUncertainty uncertain;
  uncertain.contact = 0;
  uncertain.restitution = cr::CoefficientDistribution::interval(kA, kB);
  cr::UncertaintyOptions linear;
  linear.method = cr::UncertaintyMethod::kLinear;
  try {
    cr::computeBodyOutcomeDistribution({{&s.arm, &s.wall}}, {s.contact}, {uncertain},
                                       VectorXd::Constant(s.arm.velocityCount(), 1e9), newton(),
                                       linear);
    FAIL() << "linear with general bodies must be refused";
  } catch (const cr::InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("options.uncertainty"), std::string::npos) << e.what();
  }
}

}  // namespace
