// Outcome distributions of impacts with uncertain coefficients (uncertainty.h,
// docs/uncertainty.md). References, each computed here independently of the code under test:
// a plain Monte Carlo loop over computeResponse() with std::mt19937 draws (truncation by
// rejection, the mu_d cap by hand), the stick condition of a sphere landing on its pole derived
// in closed form, and erf-based values of the standard normal.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "collision_response/core/compute_response.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/halton_sequence.h"
#include "collision_response/core/percent_text.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/standard_normal.h"
#include "collision_response/core/uncertainty.h"
#include "collision_response/core/worker_pool.h"
#include "scenes.h"
#include "uncertainty_options.h"

namespace core = collision_response::core;
using core::CoefficientDistribution;
using core::ContactUncertainty;
using core::UncertaintyMethod;

using collision_response::testing::errorField;
using collision_response::testing::linear;
using collision_response::testing::newton;
using collision_response::testing::sampled;

namespace {

// A box struck off-centre on the ground (u = (1, 0.3, -2) m/s at the contact): it slides for
// mu_s = 0.2, far from sticking.
core::Scene slidingBox() {
  return collision_response::testing::struckBox(
      {1.0, 0.3, -2.0}, {0.5, -1.0, 0.2}, Eigen::Vector3d::Zero(), {0.0, 0.0, 1.0}, 0.5, 0.2, 0.16);
}

// A uniform sphere (mass m, radius r, no spin) landing on its pole with velocity (u_t, 0, -u_n).
// The contact lies below the centre: normal and tangential directions decouple, with
// K_n = 1/m and K_t = 1/m + r^2 / (2/5 m r^2) = 7 / (2 m). Newton's law: P_n = (1 + e) m u_n;
// sticking needs P_t = u_t / K_t = 2 m u_t / 7, inside the static cone iff
//   mu_s >= 2 u_t / (7 (1 + e) u_n) =: k / (1 + e),  k = 2 u_t / (7 u_n).
constexpr double kSphereMass = 2.0;
constexpr double kSphereRadius = 0.1;
constexpr double kUt = 0.5;
constexpr double kUn = 2.0;
constexpr double kStickK = 2.0 * kUt / (7.0 * kUn);

core::Scene sphere(double e, double mu_s, double mu_d) {
  core::BodyState ground;
  ground.id = "ground";
  core::BodyState ball;
  ball.id = "ball";
  ball.mass = kSphereMass;
  ball.inertia = Eigen::Matrix3d::Identity() * 0.4 * kSphereMass * kSphereRadius * kSphereRadius;
  ball.position = {0.0, 0.0, kSphereRadius};
  ball.linear_velocity = {kUt, 0.0, -kUn};
  core::Contact contact;
  contact.body_a = "ground";
  contact.body_b = "ball";
  contact.normal = {0.0, 0.0, 1.0};
  contact.restitution = e;
  contact.static_friction = mu_s;
  contact.dynamic_friction = mu_d;
  core::Scene scene;
  scene.bodies = {ground, ball};
  scene.contacts = {contact};
  return scene;
}

core::BodyState groundBody() {
  core::BodyState ground;
  ground.id = "ground";
  return ground;
}

// A box (1 kg, body-frame inertia diag(0.05, 0.08, 0.1) kg m^2) at (0, 0, 0.25) m, falling at
// (1, 0.5, -2) m/s and turning at (0.3, -0.2, 0.1) rad/s: the landings of the multi-contact tests.
core::BodyState landingBox() {
  core::BodyState box;
  box.id = "box";
  box.mass = 1.0;
  box.inertia = Eigen::Vector3d(0.05, 0.08, 0.1).asDiagonal();
  box.position = {0.0, 0.0, 0.25};
  box.linear_velocity = {1.0, 0.5, -2.0};
  box.angular_velocity = {0.3, -0.2, 0.1};
  return box;
}

// A uniform ball of radius 0.1 m named "ball", not turning.
core::BodyState solidBall(double mass, const Eigen::Vector3d& position,
                          const Eigen::Vector3d& velocity) {
  core::BodyState ball;
  ball.id = "ball";
  ball.mass = mass;
  ball.inertia = Eigen::Matrix3d::Identity() * 0.4 * mass * 0.1 * 0.1;
  ball.position = position;
  ball.linear_velocity = velocity;
  return ball;
}

// A contact of `body` on the ground at `point`, normal +z, e = 0.5.
core::Contact groundContact(const char* body, const Eigen::Vector3d& point, double mu_s,
                            double mu_d) {
  core::Contact c;
  c.body_a = "ground";
  c.body_b = body;
  c.point = point;
  c.normal = {0.0, 0.0, 1.0};
  c.restitution = 0.5;
  c.static_friction = mu_s;
  c.dynamic_friction = mu_d;
  return c;
}

// The landing box on two contacts and a ball on a third, all three sliding far from sticking.
core::Scene threeSlidingContacts() {
  core::Scene scene;
  scene.bodies = {groundBody(), landingBox(), solidBall(2.0, {3.0, 0.0, 0.1}, {2.5, -0.8, -1.5})};
  scene.contacts = {groundContact("box", {-0.3, 0.0, 0.0}, 0.2, 0.16),
                    groundContact("box", {0.3, 0.0, 0.0}, 0.2, 0.16),
                    groundContact("ball", {3.0, 0.0, 0.0}, 0.15, 0.12)};
  return scene;
}

bool hasWarning(const core::OutcomeDistribution& outcome, const std::string& field) {
  return std::any_of(outcome.warnings.begin(), outcome.warnings.end(),
                     [&](const core::Warning& w) { return w.field == field; });
}

}  // namespace

TEST(StandardNormal, QuantileInvertsTheCdfAndKnownValues) {
  EXPECT_NEAR(core::standardNormalQuantile(0.975), 1.959963984540054, 1e-12);
  EXPECT_NEAR(core::standardNormalQuantile(0.05), -1.6448536269514722, 1e-12);
  for (const double p : {1e-12, 1e-6, 0.01, 0.3, 0.5, 0.77, 0.999, 1.0 - 1e-9}) {
    const double x = core::standardNormalQuantile(p);
    // Phi from erfc, written out here.
    EXPECT_NEAR(0.5 * std::erfc(-x / std::sqrt(2.0)), p, 1e-12 * std::min(p, 1.0 - p)) << p;
  }
}

// The far tail, down to subnormal probabilities (where Phi's Halley step used to overflow into
// NaN): against the asymptotic series log Phi(x) = -x^2/2 - log(|x| sqrt(2 pi)) + log(1 - 1/x^2
// + 3/x^4 - 15/x^6), written here (its next term is below 1e-8 at |x| > 30), to the
// approximation's accuracy in x (1e-9 relative: about x^2 1e-9 in log p). And a normal truncated
// 38 standard deviations from its lower bound (Phi(alpha) subnormal) has a finite quantile at 0.
TEST(StandardNormal, QuantileInTheFarTailDownToSubnormalProbabilities) {
  for (const double p : {1e-280, 1e-300, 1e-310, 1e-320, 4.9e-324}) {
    const double x = core::standardNormalQuantile(p);
    ASSERT_TRUE(std::isfinite(x)) << p;
    const double x2 = x * x;
    const double log_phi = -0.5 * x2 - std::log(-x * std::sqrt(2.0 * M_PI)) +
                           std::log(1.0 - 1.0 / x2 + 3.0 / (x2 * x2) - 15.0 / (x2 * x2 * x2));
    EXPECT_NEAR(log_phi, std::log(p), 1e-8 * x2 + 1e-12) << p;
  }
  const core::CheckedDistribution far(core::CoefficientDistribution::normal(0.475, 0.0125), 0.0,
                                      1.0, "e");
  const double lowest = far.quantile(0.0);
  EXPECT_TRUE(lowest >= 0.0 && lowest <= far.quantile(1e-3)) << lowest;
}

TEST(HaltonSequence, CoordinatesAreUniformAndSeeded) {
  const core::HaltonSequence a(5, 7);
  const core::HaltonSequence b(5, 7);
  const core::HaltonSequence c(5, 8);
  const int n = 4096;
  for (std::size_t d = 0; d < 5; ++d) {
    double sum = 0.0;
    int below_tenth = 0;
    for (int i = 0; i < n; ++i) {
      const double x = a.coordinate(i, d);
      ASSERT_GT(x, 0.0);
      ASSERT_LT(x, 1.0);
      EXPECT_EQ(x, b.coordinate(i, d));
      sum += x;
      below_tenth += x < 0.1;
    }
    // A low-discrepancy set: far closer than the 1/sqrt(12 n) = 0.0045 of random points.
    EXPECT_NEAR(sum / n, 0.5, 1e-3) << d;
    EXPECT_NEAR(below_tenth / double(n), 0.1, 2e-3) << d;
  }
  EXPECT_NE(a.coordinate(3, 2), c.coordinate(3, 2));
}

namespace {

// The sampled method against a plain Monte Carlo loop over computeResponse() (Stronge, the
// default law), with a truncated normal restitution (15.9 % of N(0.9, 0.1) lies above 1) and a
// dynamic friction that often exceeds the static one (capped): mu_s ~ U[a, b],
// mu_d ~ N(mean_d, sd_d).
void expectSampledMatchesMonteCarlo(const core::Scene& scene, double a, double b, double mean_d,
                                    double sd_d, bool both_modes) {
  core::SolverOptions options;  // Stronge
  // The whole sampling's budget (1 s by default) is not what this test checks: 4,096 samples took
  // 1.0 s under AddressSanitizer on the loaded 2-core machine.
  options.time_budget = 60.0;
  ContactUncertainty u;
  u.contact = 0;
  u.restitution = CoefficientDistribution::normal(0.9, 0.1);
  u.static_friction = CoefficientDistribution::interval(a, b);
  u.dynamic_friction = CoefficientDistribution::normal(mean_d, sd_d);
  core::WorkerPool pool(2);
  const std::size_t ns = 4096;
  const core::OutcomeDistribution outcome =
      core::computeOutcomeDistribution(scene, {u}, options, sampled(ns), &pool);
  ASSERT_EQ(outcome.mean.size(), 10);
  EXPECT_EQ(outcome.samples, ns);
  EXPECT_EQ(outcome.labels[0], "bodies[1].twist.linear.x");
  EXPECT_EQ(outcome.labels[6], "impulses[0].normal_impulse");
  EXPECT_TRUE(hasWarning(outcome, "uncertainties[0].restitution"));
  EXPECT_TRUE(hasWarning(outcome, "uncertainties[0].dynamic_friction"));

  // The reference: pseudo-random draws, truncation by rejection, the cap by hand.
  std::mt19937 random(12345);
  std::normal_distribution<double> e_draw(0.9, 0.1);
  std::uniform_real_distribution<double> mu_s_draw(a, b);
  std::normal_distribution<double> mu_d_draw(mean_d, sd_d);
  const int nm = 20000;
  Eigen::MatrixXd values(10, nm);
  std::vector<double> sticks(nm);
  for (int i = 0; i < nm; ++i) {
    double e = 0.0, mu_d = 0.0;
    do e = e_draw(random);
    while (e < 0.0 || e > 1.0);
    const double mu_s = mu_s_draw(random);
    do mu_d = mu_d_draw(random);
    while (mu_d < 0.0);
    core::Scene sample = scene;
    sample.contacts[0].restitution = e;
    sample.contacts[0].static_friction = mu_s;
    sample.contacts[0].dynamic_friction = std::min(mu_d, mu_s);
    const core::CollisionResult result = core::computeResponse(sample, options);
    values.col(i) << result.bodies[1].linear_velocity, result.bodies[1].angular_velocity,
        result.impulses[0].normal_impulse, result.impulses[0].friction_impulse;
    sticks[i] = result.impulses[0].sticking ? 1.0 : 0.0;
  }
  const Eigen::VectorXd mean = values.rowwise().mean();
  const Eigen::MatrixXd centred = values.colwise() - mean;
  const Eigen::MatrixXd cov = centred * centred.transpose() / (nm - 1);
  const double weight = 1.0 / nm + 1.0 / ns;  // both treated as Monte Carlo (conservative)
  for (int r = 0; r < 10; ++r) {
    SCOPED_TRACE(outcome.labels[r]);
    EXPECT_NEAR(outcome.mean(r), mean(r), 4.0 * std::sqrt(cov(r, r) * weight) + 1e-12);
    for (int c = 0; c < 10; ++c) {
      // Standard error of a sample covariance (normal approximation), and of the variance from
      // the fourth central moment.
      double se = std::sqrt((cov(r, r) * cov(c, c) + cov(r, c) * cov(r, c)) * weight);
      if (r == c) {
        const double m4 = centred.row(r).array().pow(4).mean();
        se = std::sqrt(std::max(0.0, m4 - cov(r, r) * cov(r, r)) * weight);
      }
      EXPECT_NEAR(outcome.covariance(r, c), cov(r, c), 4.0 * se + 1e-12) << c;
    }
    // The quantiles: q is a p-quantile of the reference if at most p of it lies below q and at
    // least p at or below (atoms, e.g. every sticking sample's v_x, make both matter).
    for (const auto& [q, level] :
         {std::pair{outcome.q05(r), 0.05}, std::pair{outcome.q95(r), 0.95}}) {
      const double tolerance = 4.0 * std::sqrt(level * (1 - level) * weight);
      EXPECT_LE((values.row(r).array() < q).cast<double>().mean(), level + tolerance) << level;
      EXPECT_GE((values.row(r).array() <= q).cast<double>().mean(), level - tolerance) << level;
    }
  }
  double p = 0.0;
  for (const double s : sticks) p += s;
  p /= nm;
  if (both_modes) {
    EXPECT_GT(p, 0.05);
    EXPECT_LT(p, 0.95);
  }
  EXPECT_NEAR(outcome.stick_probability[0], p, 4.0 * std::sqrt(p * (1.0 - p) * weight) + 1e-12);
}

}  // namespace

TEST(Uncertainty, SampledMatchesPlainMonteCarloOnASlidingBox) {
  expectSampledMatchesMonteCarlo(slidingBox(), 0.15, 0.3, 0.15, 0.05, false);
}

TEST(Uncertainty, SampledMatchesPlainMonteCarloOnASphereThatSticksOrSlides) {
  expectSampledMatchesMonteCarlo(sphere(0.5, 0.05, 0.03), 0.02, 0.08, 0.03, 0.02, true);
}

// The same answer, bit for bit, on 1 and 2 threads and from the same seed.
TEST(Uncertainty, SampledIsDeterministic) {
  ContactUncertainty u;
  u.restitution = CoefficientDistribution::interval(0.2, 0.6);
  u.static_friction = CoefficientDistribution::normal(0.2, 0.05);
  const core::Scene scene = slidingBox();
  core::WorkerPool pool(2);
  const auto one = core::computeOutcomeDistribution(scene, {u}, newton(), sampled(500));
  const auto two = core::computeOutcomeDistribution(scene, {u}, newton(), sampled(500), &pool);
  EXPECT_EQ(one.mean, two.mean);
  EXPECT_EQ(one.covariance, two.covariance);
  EXPECT_EQ(one.q05, two.q05);
  EXPECT_EQ(one.stick_probability, two.stick_probability);
}

// Stick probability of the sphere: e ~ U[e1, e2], mu_s ~ U[a, b], independent; the threshold
// k / (1 + e) stays inside [a, b], so P = (1 / (e2 - e1)) int (b - k / (1 + e)) / (b - a) de
//   = (b - k ln((1 + e2) / (1 + e1)) / (e2 - e1)) / (b - a).
TEST(Uncertainty, StickProbabilityOfASphereMatchesTheClosedForm) {
  const double e1 = 0.2, e2 = 0.6, a = 0.03, b = 0.08;
  ASSERT_GT(kStickK / (1 + e1), a);
  ASSERT_LT(kStickK / (1 + e2), b);
  ASSERT_LT(kStickK / (1 + e1), b);
  const double exact = (b - kStickK * std::log((1 + e2) / (1 + e1)) / (e2 - e1)) / (b - a);
  ContactUncertainty u;
  u.restitution = CoefficientDistribution::interval(e1, e2);
  u.static_friction = CoefficientDistribution::interval(a, b);
  const auto outcome =
      core::computeOutcomeDistribution(sphere(0.4, 0.05, 0.02), {u}, newton(), sampled(8192));
  EXPECT_NEAR(outcome.stick_probability[0], exact, 5e-3);
  EXPECT_FALSE(hasWarning(outcome, "uncertainties[0].dynamic_friction"));  // mu_d < a
}

// With e fixed and mu_s ~ N(m, s), the sphere sticks with probability Phi((m - t) / s),
// t = k / (1 + e): exactly linear in mu_s on both sides (sticking, the margin mu_s P_n - |P_t|;
// sliding, under Newton's law, the same margin of the sticking impulse, the answer with the
// contact held), so the linear method gives it exactly from either mode.
TEST(Uncertainty, LinearStickProbabilityOfASphereIsExactInMuS) {
  const double e = 0.4;
  const double t = kStickK / (1.0 + e);
  // The one-pass law (a central contact: the frictionless impulse, then the friction that stops
  // the slip if mu_s allows it) has the same condition; its sliding margin is mu_s - mu*, mu* =
  // mu_d - s / s_mu = k / (1 + e), linear in mu_s too.
  for (const core::ImpactLaw law : {core::ImpactLaw::kNewton, core::ImpactLaw::kSeedOnePass}) {
    SCOPED_TRACE(core::toString(law));
    core::SolverOptions options = newton();
    options.law = law;
    for (const double m : {t + 0.009, t - 0.006}) {
      const double s = 0.005;
      ContactUncertainty u;
      u.static_friction = CoefficientDistribution::normal(m, s);
      const double exact = 0.5 * std::erfc(-((m - t) / s) / std::sqrt(2.0));
      const auto lin = core::computeOutcomeDistribution(sphere(e, m, 0.01), {u}, options, linear());
      EXPECT_NEAR(lin.stick_probability[0], exact, 1e-6) << m;
      const auto smp =
          core::computeOutcomeDistribution(sphere(e, m, 0.01), {u}, options, sampled(4096));
      EXPECT_NEAR(smp.stick_probability[0], exact, 5e-3) << m;
    }
  }
}

// The distributions' means, not the request's own coefficients, are what the outcome is centred
// on: the request says e 0.9, mu_s 0.8, mu_d 0.7 (the sphere sticks), the distributions e 0.4,
// mu_s 0.02, mu_d 0.015 (it slides: mu_s < k / (1 + e) = 0.0255); a coefficient with no
// distribution keeps the request's value. The reference is the prediction of a scene written with
// those values by hand. Both methods: the linear mean is that prediction exactly; so is the sampled
// method's with every spread zero.
TEST(Uncertainty, OutcomeIsCentredOnTheDistributionsMeansNotOnTheRequestsValues) {
  auto rows = [](const core::CollisionResult& r) {
    Eigen::VectorXd v(10);
    v << r.bodies[1].linear_velocity, r.bodies[1].angular_velocity, r.impulses[0].normal_impulse,
        r.impulses[0].friction_impulse;
    return v;
  };
  const core::CollisionResult at_means = core::computeResponse(sphere(0.4, 0.02, 0.015), newton());
  ASSERT_FALSE(at_means.impulses[0].sticking);
  ASSERT_TRUE(core::computeResponse(sphere(0.9, 0.8, 0.7), newton()).impulses[0].sticking);
  {
    ContactUncertainty u;
    u.restitution = CoefficientDistribution::normal(0.4, 0.01);
    u.static_friction = CoefficientDistribution::interval(0.015, 0.025);
    u.dynamic_friction = CoefficientDistribution::normal(0.015, 0.001);
    const core::Scene request = sphere(0.9, 0.8, 0.7);
    const auto lin = core::computeOutcomeDistribution(request, {u}, newton(), linear());
    const Eigen::VectorXd expected = rows(at_means);
    for (Eigen::Index r = 0; r < 10; ++r) EXPECT_NEAR(lin.mean(r), expected(r), 1e-12) << r;
    EXPECT_EQ(request.contacts[0].restitution, 0.9);  // the request itself is left as it was
  }
  {
    // Only e has a distribution (its mean differs); mu_s and mu_d are the request's.
    ContactUncertainty u;
    u.restitution = CoefficientDistribution::interval(0.4, 0.4);
    const core::Scene request = sphere(0.9, 0.02, 0.015);
    const Eigen::VectorXd expected = rows(at_means);
    for (const auto& options : {linear(), sampled(16)}) {
      const auto outcome = core::computeOutcomeDistribution(request, {u}, newton(), options);
      for (Eigen::Index r = 0; r < 10; ++r) EXPECT_NEAR(outcome.mean(r), expected(r), 1e-12) << r;
    }
  }
}

// Small spreads on a smooth scene (one contact sliding far from sticking): the linear
// distribution agrees with the sampled one to a few percent of the spreads.
TEST(Uncertainty, LinearMatchesSampledForSmallSpreads) {
  ContactUncertainty u;
  u.restitution = CoefficientDistribution::normal(0.5, 0.01);
  u.static_friction = CoefficientDistribution::normal(0.2, 0.005);
  u.dynamic_friction = CoefficientDistribution::normal(0.16, 0.006);
  const core::Scene scene = slidingBox();
  const auto lin = core::computeOutcomeDistribution(scene, {u}, newton(), linear());
  const auto smp = core::computeOutcomeDistribution(scene, {u}, newton(), sampled(4096));
  EXPECT_EQ(lin.labels, smp.labels);
  const Eigen::VectorXd sd = smp.covariance.diagonal().cwiseSqrt();
  ASSERT_GT(sd.maxCoeff(), 1e-3);
  for (Eigen::Index r = 0; r < sd.size(); ++r) {
    SCOPED_TRACE(lin.labels[r]);
    EXPECT_NEAR(lin.mean(r), smp.mean(r), 0.02 * sd(r) + 1e-12);
    EXPECT_NEAR(lin.q05(r), smp.q05(r), 0.05 * sd(r) + 1e-12);
    EXPECT_NEAR(lin.q95(r), smp.q95(r), 0.05 * sd(r) + 1e-12);
    for (Eigen::Index c = 0; c < sd.size(); ++c)
      EXPECT_NEAR(lin.covariance(r, c), smp.covariance(r, c), 0.03 * sd(r) * sd(c) + 1e-14);
  }
  // mu_s would have to reach the tail beyond ~4 standard deviations.
  EXPECT_LT(lin.stick_probability[0], 1e-3);
  EXPECT_LT(smp.stick_probability[0], 1e-3);
  EXPECT_TRUE(lin.warnings.empty());
}

// Where the linear method stops matching: the sphere with mu_s spread across its stick/slip
// switch. At the mean it sticks, where the twist does not depend on mu_s: the linear variance of
// the post-impact v_x is 0, while the samples that slide (with mu_d well below mu_s) leave a
// spread. The stick probability (a linear margin) still matches.
TEST(Uncertainty, LinearMissesTheSpreadAcrossAStickSlipSwitch) {
  const double e = 0.4;
  const double t = kStickK / (1.0 + e);
  ContactUncertainty u;
  u.static_friction = CoefficientDistribution::normal(t + 0.001, 0.01);
  const core::Scene scene = sphere(e, t + 0.001, 0.02);
  const auto lin = core::computeOutcomeDistribution(scene, {u}, newton(), linear());
  const auto smp = core::computeOutcomeDistribution(scene, {u}, newton(), sampled(4096));
  EXPECT_NEAR(lin.covariance(0, 0), 0.0, 1e-20);
  // Sliding samples: v_x' = u_t - mu_d (1 + e) u_n against 5/7 u_t sticking.
  const double jump = (kUt - 0.02 * (1 + e) * kUn) - 5.0 / 7.0 * kUt;
  const double p_slide = 1.0 - smp.stick_probability[0];
  EXPECT_NEAR(smp.covariance(0, 0), jump * jump * p_slide * (1 - p_slide), 0.02 * jump * jump);
  EXPECT_GT(smp.covariance(0, 0), 0.01 * jump * jump);
  EXPECT_NEAR(lin.stick_probability[0], smp.stick_probability[0], 0.02);
  EXPECT_TRUE(hasWarning(lin, "contacts[0]"));  // the spread reaches the switch
}

TEST(Uncertainty, BadInputNamesTheField) {
  const core::Scene scene = slidingBox();
  auto field = [&](const ContactUncertainty& u, const core::UncertaintyOptions& o = sampled(10)) {
    return errorField([&] { core::computeOutcomeDistribution(scene, {u}, newton(), o); });
  };
  ContactUncertainty u;
  u.restitution = CoefficientDistribution::normal(0.5, -0.1);
  EXPECT_EQ(field(u), "uncertainties[0].restitution.std_dev");
  u.restitution = CoefficientDistribution::interval(0.6, 0.4);
  EXPECT_EQ(field(u), "uncertainties[0].restitution.min");
  u.restitution = CoefficientDistribution::interval(0.5, 1.2);
  EXPECT_EQ(field(u), "uncertainties[0].restitution.max");
  u.restitution = CoefficientDistribution::normal(1.1, 0.1);
  EXPECT_EQ(field(u), "uncertainties[0].restitution.mean");
  u.restitution.reset();
  u.static_friction = CoefficientDistribution::interval(-0.1, 0.2);
  EXPECT_EQ(field(u), "uncertainties[0].static_friction.min");
  u.static_friction = CoefficientDistribution::normal(0.1, 0.01);
  u.dynamic_friction = CoefficientDistribution::normal(0.15, 0.01);
  EXPECT_EQ(field(u), "uncertainties[0].dynamic_friction");
  u.dynamic_friction.reset();
  u.static_friction = CoefficientDistribution::normal(0.3, 0.01);
  EXPECT_EQ(field(u, sampled(core::kMaxUncertaintySamples + 1)), "options.uncertainty_samples");
  EXPECT_EQ(field(u, sampled(0)), "options.uncertainty_samples");
  u.contact = 1;
  EXPECT_EQ(field(u), "uncertainties[0].contact");
  u.contact = 0;
  EXPECT_EQ(errorField([&] {
              core::computeOutcomeDistribution(scene, {u, u}, newton(), linear());
            }),
            "uncertainties[1].contact");
  core::UncertaintyOptions none;
  none.method = UncertaintyMethod::kNone;
  EXPECT_EQ(field(u, none), "options.uncertainty");
}

// An answer too large to hold is refused before anything is solved: rows x samples over the cap
// (101 contacts: 6 + 4 x 101 = 410 rows, x 100,000 samples > 2^25), and more than 2048 rows
// (513 contacts: 2058 rows) for either method.
TEST(Uncertainty, OversizedOutcomeIsRefusedNamingTheField) {
  auto boxWithContacts = [](int count) {
    core::Scene scene = slidingBox();
    const core::Contact first = scene.contacts[0];
    scene.contacts.clear();
    for (int c = 0; c < count; ++c) {
      core::Contact contact = first;
      contact.point = {0.1 + 0.001 * c, -0.05, 0.0};
      scene.contacts.push_back(contact);
    }
    return scene;
  };
  ContactUncertainty u;
  u.restitution = CoefficientDistribution::interval(0.3, 0.7);
  const core::Scene many = boxWithContacts(101);
  EXPECT_EQ(errorField([&] {
              core::computeOutcomeDistribution(many, {u}, newton(),
                                               sampled(core::kMaxUncertaintySamples));
            }),
            "options.uncertainty_samples");
  const core::Scene too_many = boxWithContacts(513);
  EXPECT_EQ(
      errorField([&] { core::computeOutcomeDistribution(too_many, {u}, newton(), sampled(10)); }),
      "uncertainties");
  EXPECT_EQ(
      errorField([&] { core::computeOutcomeDistribution(too_many, {u}, newton(), linear()); }),
      "uncertainties");
}

// The truncated normal's moments and quantiles against a quadrature of the density written here:
// N(0.9, 0.1) conditioned on [0, 1].
TEST(CoefficientDistribution, TruncatedNormalMomentsMatchQuadrature) {
  std::optional<core::Warning> warning;
  const core::CheckedDistribution d(CoefficientDistribution::normal(0.9, 0.1), 0.0, 1.0,
                                    "uncertainties[0].restitution", &warning);
  ASSERT_TRUE(warning.has_value());
  EXPECT_EQ(warning->field, "uncertainties[0].restitution");
  const int n = 200000;  // midpoint rule on [0, 1]
  double mass = 0.0, first = 0.0, second = 0.0;
  for (int i = 0; i < n; ++i) {
    const double x = (i + 0.5) / n;
    const double density = std::exp(-0.5 * std::pow((x - 0.9) / 0.1, 2));
    mass += density;
    first += x * density;
    second += x * x * density;
  }
  const double mean = first / mass;
  EXPECT_NEAR(d.mean(), mean, 1e-9);
  EXPECT_NEAR(d.variance(), second / mass - mean * mean, 1e-9);
  // The median: half the mass below it.
  const double median = d.quantile(0.5);
  double below = 0.0;
  for (int i = 0; i < n; ++i) {
    const double x = (i + 0.5) / n;
    if (x < median) below += std::exp(-0.5 * std::pow((x - 0.9) / 0.1, 2));
  }
  EXPECT_NEAR(below / mass, 0.5, 1e-4);
  EXPECT_NEAR(d.truncatedMass(), 0.5 * std::erfc(1.0 / std::sqrt(2.0)), 1e-12);  // P(Z > 1)
}

// Far truncation bounds (9 or more standard deviations from the mean) skip the truncated normal's
// moment formulas: the answers must be those formulas' own, bit for bit. Reference: the formulas
// written here (the density of the normal renormalised on [lower, upper], erfc-based Phi), at
// means and spreads whose bounds lie from 6 to 60 standard deviations away, on [0, 1] (e) and
// [0, infinity) (friction). Nearer bounds (not skipped) agree to round-off.
TEST(CoefficientDistribution, FarTruncationBoundsGiveTheFullFormulasMomentsBitForBit) {
  auto Phi = [](double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); };
  auto phi = [](double x) {
    return std::isinf(x) ? 0.0 : std::exp(-0.5 * x * x) / std::sqrt(2.0 * M_PI);
  };
  int far = 0;
  for (const double upper : {1.0, std::numeric_limits<double>::infinity()}) {
    for (const double mean : {0.3, 0.4, 0.5, 0.55, 0.7}) {
      for (const double sigmas : {6.0, 8.0, 8.99, 9.0, 9.01, 10.0, 13.3, 20.0, 38.0, 60.0}) {
        const double s = std::min(mean, upper - mean) / sigmas;
        const core::CheckedDistribution d(CoefficientDistribution::normal(mean, s), 0.0, upper,
                                          "f");
        const double a = (0.0 - mean) / s, b = (upper - mean) / s;
        const double kept = Phi(b) - Phi(a);
        const double shift = (phi(a) - phi(b)) / kept;
        const double a_term = a * phi(a), b_term = std::isinf(b) ? 0.0 : b * phi(b);
        const double reference_mean = mean + s * shift;
        const double reference_variance =
            s * s * std::max(0.0, 1.0 + (a_term - b_term) / kept - shift * shift);
        SCOPED_TRACE(testing::Message()
                     << "mean " << mean << " sigmas " << sigmas << " upper " << upper);
        if (a <= -9.0 && b >= 9.0) {
          ++far;
          EXPECT_EQ(d.mean(), reference_mean);
          EXPECT_EQ(d.variance(), reference_variance);
          EXPECT_EQ(d.truncatedMass(), 1.0 - kept);
        } else {
          EXPECT_NEAR(d.mean(), reference_mean, 1e-15);
          EXPECT_NEAR(d.variance(), reference_variance, 1e-15 * s * s);
          EXPECT_NEAR(d.truncatedMass(), 1.0 - kept, 1e-15);
        }
        // The quantile function and the CDF keep the lower bound's tail mass Phi(a) (the sampled
        // method's draws), however small: at probabilities it shifts and at ones it cannot.
        for (const double u : {0.0, 1e-22, 1e-19, 1e-12, 1e-3, 1.0 / 512, 1.0 / 256, 0.3, 1.0}) {
          const double x =
              std::clamp(mean + s * core::standardNormalQuantile(Phi(a) + u * kept), 0.0, upper);
          // (Equal infinities, and the NaN both give at u = 0 when Phi(a) is subnormal.)
          const double q = d.quantile(u);
          if ((std::isnan(q) && std::isnan(x)) || q == x) continue;
          if (a <= -9.0 && b >= 9.0)
            EXPECT_EQ(q, x) << "u " << u;
          else
            EXPECT_NEAR(q, x, 1e-12 * s) << "u " << u;
        }
        for (const double z : {-8.5, -7.0, -6.0, -3.0, -0.5, 0.0, 1.0, 2.5}) {
          const double x = mean + z * s;
          const double p = (Phi((x - mean) / s) - Phi(a)) / kept;
          if (x <= 0.0 || x >= upper) continue;
          if (a <= -9.0 && b >= 9.0)
            EXPECT_EQ(d.cdf(x), p) << "z " << z;
          else
            EXPECT_NEAR(d.cdf(x), p, 1e-15) << "z " << z;
        }
      }
    }
  }
  EXPECT_GE(far, 40);  // the bit-for-bit cases were reached
}

// The warnings' percentages (writePercent()) are printf's "%.3g %" of 100 * fraction: against
// std::to_chars (general, 3 digits, the exact binary value rounded) at every millionth in [0, 1],
// log-uniform fractions from 1e-12 to 10, negative and non-finite ones, and the doubles next to
// every rounding tie n.5 * 10^k (n of 3 digits) of the fast path's range.
TEST(PercentText, MatchesPrintfsThreeSignificantDigits) {
  auto reference = [](double fraction) {
    char text[64];
    char* end =
        std::to_chars(text, text + sizeof text, 100.0 * fraction, std::chars_format::general, 3)
            .ptr;
    return std::string(text, end) + " %";
  };
  auto written = [](double fraction) {
    char text[core::kPercentTextSize];
    return std::string(text, core::writePercent(fraction, text));
  };
  std::vector<double> fractions;
  for (int k = 0; k <= 1000000; ++k) fractions.push_back(k / 1e6);
  std::mt19937 random(26);
  std::uniform_real_distribution<double> exponent(-12.0, 1.0);
  for (int k = 0; k < 200000; ++k) fractions.push_back(std::pow(10.0, exponent(random)));
  for (const double special :
       {0.0, -0.25, 1.0, 9.995, 1e-300, 5e-324, 1e300, std::numeric_limits<double>::infinity(),
        std::numeric_limits<double>::quiet_NaN()})
    fractions.push_back(special);
  for (int power = -6; power <= 1; ++power) {
    for (int n = 100; n < 1000; ++n) {
      const double tie = (n + 0.5) * std::pow(10.0, power) / 100.0;
      for (double x = std::nextafter(std::nextafter(tie, 0.0), 0.0), k = 0; k < 5;
           ++k, x = std::nextafter(x, 1e9))
        fractions.push_back(x);
    }
  }
  int mismatches = 0;
  for (const double fraction : fractions) {
    if (written(fraction) != reference(fraction) && ++mismatches <= 10)
      ADD_FAILURE() << "fraction " << std::hexfloat << fraction << std::defaultfloat << ": "
                    << written(fraction) << " against " << reference(fraction);
  }
  EXPECT_EQ(mismatches, 0);
  EXPECT_EQ(written(0.123), "12.3 %");
  EXPECT_EQ(written(0.5), "50 %");
  EXPECT_EQ(written(0.0005), "0.05 %");
}

// The whole sampling is bounded by options.time_budget.
TEST(Uncertainty, SamplingStopsAtTheTimeBudget) {
  core::SolverOptions options = newton();
  options.time_budget = 1e-3;
  ContactUncertainty u;
  u.restitution = CoefficientDistribution::interval(0.2, 0.6);
  EXPECT_THROW(core::computeOutcomeDistribution(slidingBox(), {u}, options,
                                                sampled(core::kMaxUncertaintySamples)),
               core::SolverTimeout);
}

// A sample whose mu_d exceeds its mu_s is capped and reported under the coefficient that was
// uncertain: here only mu_s ~ U[0.1, 0.3], mu_d the contact's own 0.16, so the draws below 0.16
// are capped, a fraction (0.16 - 0.1) / (0.3 - 0.1) = 0.3 of them in closed form, and the warning
// names static_friction (dynamic_friction was not given as uncertain).
TEST(Uncertainty, CappingWarningNamesTheCoefficientThatWasUncertain) {
  ContactUncertainty u;
  u.contact = 0;
  u.static_friction = CoefficientDistribution::interval(0.1, 0.3);
  const core::Scene scene = slidingBox();
  ASSERT_EQ(scene.contacts[0].dynamic_friction, 0.16);
  const std::size_t n = 2000;
  const core::OutcomeDistribution outcome =
      core::computeOutcomeDistribution(scene, {u}, newton(), sampled(n));
  EXPECT_FALSE(hasWarning(outcome, "uncertainties[0].dynamic_friction"));
  const auto warning = std::find_if(
      outcome.warnings.begin(), outcome.warnings.end(),
      [](const core::Warning& w) { return w.field == "uncertainties[0].static_friction"; });
  ASSERT_NE(warning, outcome.warnings.end());
  // "... in <count> of <n> samples ...": the count of a low-discrepancy sequence in [0, 0.3).
  const std::size_t at = warning->reason.find(" in ");
  ASSERT_NE(at, std::string::npos) << warning->reason;
  const double count = std::stod(warning->reason.substr(at + 4));
  EXPECT_NEAR(count / static_cast<double>(n), 0.3, 0.01) << warning->reason;

  // The linear method's warning (the normal approximation's probability) names it too.
  const core::OutcomeDistribution approximate =
      core::computeOutcomeDistribution(scene, {u}, newton(), linear());
  EXPECT_TRUE(hasWarning(approximate, "uncertainties[0].static_friction"));
  EXPECT_FALSE(hasWarning(approximate, "uncertainties[0].dynamic_friction"));

  // Both uncertain: mu_d is the one capped, and named.
  u.dynamic_friction = CoefficientDistribution::normal(0.16, 0.02);
  const core::OutcomeDistribution both =
      core::computeOutcomeDistribution(scene, {u}, newton(), sampled(n));
  EXPECT_TRUE(hasWarning(both, "uncertainties[0].dynamic_friction"));
  EXPECT_FALSE(hasWarning(both, "uncertainties[0].static_friction"));
}

// With mu_s fixed and e ~ N(m, s), the sphere sticks iff mu_s (1 + e) >= k, i.e. e >= t =
// k / mu_s - 1: probability Phi((m - t) / s). Sticking at the mean, the margin mu_s P_n - |P_t| =
// mu_s (1 + e) m u_n - 2 m u_t / 7 is linear in e, so the linear method gives it exactly; only e
// is uncertain, so no gradient in mu_s may enter (a fixed mu_s has no sampling dimension).
TEST(Uncertainty, LinearStickProbabilityOfASphereIsExactInE) {
  const double m = 0.5, s = 0.05, threshold = 0.48;
  const double mu_s = kStickK / (1.0 + threshold);
  ContactUncertainty u;
  u.restitution = CoefficientDistribution::normal(m, s);
  const double exact = 0.5 * std::erfc(-((m - threshold) / s) / std::sqrt(2.0));
  const auto lin = core::computeOutcomeDistribution(sphere(m, mu_s, 0.01), {u}, newton(), linear());
  EXPECT_NEAR(lin.stick_probability[0], exact, 1e-6);
  const auto smp =
      core::computeOutcomeDistribution(sphere(m, mu_s, 0.01), {u}, newton(), sampled(4096));
  EXPECT_NEAR(smp.stick_probability[0], exact, 5e-3);
}

// Sliding at the mean, with e ~ N(m, s) and mu_s > mu_d: under Newton's law the sphere sticks iff
// its sticking impulse lies in the static cone, mu_s (1 + e) m u_n >= 2 m u_t / 7, i.e. iff
// e >= t = k / mu_s - 1: exactly Phi((m - t) / s). The linear method takes a sliding contact's
// margin from its sticking impulse (the answer with the contact held), mu_s P_n - |P_t|, which is
// linear in e: exact. (The margin of the slip speed, mu_s - mu* with mu* = k / (1 + e) the mu_d at
// which the slip would stop, is not linear in e: its first order gives 0.167, and 0.106 with the
// change of ds/dmu_d with e left out.)
TEST(Uncertainty, LinearStickProbabilityOfASlidingSphereIsExactInE) {
  const double m = 0.5, s = 0.05, t = 0.55;
  const double mu_s = kStickK / (1.0 + t), mu_d = 0.8 * mu_s;
  ContactUncertainty u;
  u.restitution = CoefficientDistribution::normal(m, s);
  const core::Scene scene = sphere(m, mu_s, mu_d);
  ASSERT_FALSE(core::computeResponse(scene, newton()).impulses[0].sticking);
  const double exact = 0.5 * std::erfc(-((m - t) / s) / std::sqrt(2.0));
  const auto lin = core::computeOutcomeDistribution(scene, {u}, newton(), linear());
  EXPECT_NEAR(lin.stick_probability[0], exact, 1e-6);
  const auto smp = core::computeOutcomeDistribution(scene, {u}, newton(), sampled(4096));
  EXPECT_NEAR(smp.stick_probability[0], exact, 5e-3);
}

// Poisson and Stronge slide with mu_d until the slip stops, then hold: the sphere, sliding at the
// means with mu_s = 1.3 mu_d (the band between mu_d N and mu_s N), ends sticking iff its slip stops
// within the impact, 3.5 mu_d (1 + e) u_n >= u_t, i.e. iff mu_d (1 + e) >= k; mu_s does not enter.
// With e ~ N(m, s): exactly Phi((m - t) / s), t = k / mu_d - 1; with mu_d ~ N(m_d, s_d) and e
// fixed: exactly Phi((m_d - k / (1 + e)) / s_d). The linear method's margin, the slip speed s =
// u_t - 3.5 mu_d (1 + e) u_n over its rate in mu_d at the means, is affine in both: exact. (Before,
// the margin was mu_s - mu* under every law: the linear method said 1.0 in both cases;
// linearising mu* = mu_d - s / s_mu in e, s_mu = -3.5 (1 + e) u_n moving too, gives 0.1666.)
TEST(Uncertainty, LinearStickProbabilityOfASphereUnderImpulseSpaceLawsIsWhetherItsSlipStops) {
  for (const core::ImpactLaw law : {core::ImpactLaw::kPoisson, core::ImpactLaw::kStronge}) {
    SCOPED_TRACE(core::toString(law));
    core::SolverOptions options;
    options.law = law;
    const double m = 0.5, s = 0.05, t = 0.55;
    const double mu_d = kStickK / (1.0 + t), mu_s = 1.3 * mu_d;
    const core::Scene scene = sphere(m, mu_s, mu_d);
    ASSERT_FALSE(core::computeResponse(scene, options).impulses[0].sticking);
    ContactUncertainty in_e;
    in_e.restitution = CoefficientDistribution::normal(m, s);
    const double exact = 0.5 * std::erfc(-((m - t) / s) / std::sqrt(2.0));
    const auto lin = core::computeOutcomeDistribution(scene, {in_e}, options, linear());
    EXPECT_NEAR(lin.stick_probability[0], exact, 1e-6);
    const auto smp = core::computeOutcomeDistribution(scene, {in_e}, options, sampled(4096));
    EXPECT_NEAR(smp.stick_probability[0], exact, 5e-3);

    const double s_d = 0.002;
    ContactUncertainty in_mu_d;
    in_mu_d.dynamic_friction = CoefficientDistribution::normal(mu_d, s_d);
    const double exact_d = 0.5 * std::erfc(-((mu_d - kStickK / (1.0 + m)) / s_d) / std::sqrt(2.0));
    ASSERT_GT(exact_d, 0.05);
    const auto lin_d = core::computeOutcomeDistribution(scene, {in_mu_d}, options, linear());
    EXPECT_NEAR(lin_d.stick_probability[0], exact_d, 1e-6);
    const auto smp_d = core::computeOutcomeDistribution(scene, {in_mu_d}, options, sampled(4096));
    EXPECT_NEAR(smp_d.stick_probability[0], exact_d, 5e-3);
  }
}

// The linear distribution of a multi-contact scene against its definition computed here: a box
// landing on an edge (2 contacts, one island of the exact solver) and a sphere landing apart (its
// own island, Newton's closed form), every contact sliding. Reference: the prediction at the means
// (computeResponse()), the Jacobian of its outputs w.r.t. each uncertain coefficient by central
// differences of computeResponse(), covariance = sum_k J_k J_k^T var_k with the variances of the
// distributions in closed form (normal: s^2, its truncation far out of reach; interval: w^2 / 12),
// quantiles mean -/+ 1.645 sd. With e and mu_d uncertain at the 3 contacts, 6 columns enter the
// covariance (more than the 4 its kernel sums at once).
TEST(Uncertainty, LinearDistributionOfSeveralContactsIsJSJtOfCentralDifferences) {
  core::Scene scene = threeSlidingContacts();
  // Outputs in the layout of OutcomeDistribution: the movable bodies' twists, then 4 per contact.
  auto outputs = [](const core::Scene& s) {
    const core::CollisionResult r = core::computeResponse(s, newton());
    Eigen::VectorXd y(12 + 4 * static_cast<Eigen::Index>(s.contacts.size()));
    for (int b = 0; b < 2; ++b) {
      y.segment<3>(6 * b) = r.bodies[b + 1].linear_velocity;
      y.segment<3>(6 * b + 3) = r.bodies[b + 1].angular_velocity;
    }
    for (std::size_t c = 0; c < s.contacts.size(); ++c) {
      const auto row = 12 + 4 * static_cast<Eigen::Index>(c);
      y(row) = r.impulses[c].normal_impulse;
      y.segment<3>(row + 1) = r.impulses[c].friction_impulse;
      EXPECT_FALSE(r.impulses[c].sticking) << c;  // sliding, far from the switch
    }
    return y;
  };
  for (const bool friction : {false, true}) {
    SCOPED_TRACE(friction ? "e, mu_s, mu_d" : "e");
    std::vector<ContactUncertainty> all;
    // (contact, which coefficient: 0 e, 1 mu_s, 2 mu_d, variance), the reference's columns.
    std::vector<std::tuple<std::size_t, int, double>> columns;
    for (std::size_t c = 0; c < scene.contacts.size(); ++c) {
      ContactUncertainty u;
      u.contact = c;
      const double e = 0.45 + 0.05 * static_cast<double>(c);  // a different mean per contact
      const double e_sd = 0.02 + 0.01 * static_cast<double>(c);
      u.restitution = CoefficientDistribution::normal(e, e_sd);
      scene.contacts[c].restitution = e;
      columns.emplace_back(c, 0, e_sd * e_sd);
      if (friction) {
        const double mu_s = scene.contacts[c].static_friction;
        const double mu_d = scene.contacts[c].dynamic_friction;
        u.static_friction = CoefficientDistribution::interval(mu_s - 0.01, mu_s + 0.01);
        u.dynamic_friction = CoefficientDistribution::normal(mu_d, 0.01);
        columns.emplace_back(c, 1, 0.02 * 0.02 / 12.0);
        columns.emplace_back(c, 2, 0.01 * 0.01);
      }
      all.push_back(u);
    }
    const core::OutcomeDistribution lin =
        core::computeOutcomeDistribution(scene, all, newton(), linear());
    const Eigen::VectorXd mean = outputs(scene);
    const Eigen::Index m = mean.size();
    ASSERT_EQ(lin.mean.size(), m);
    Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(m, m);
    const double h = 1e-6;
    for (const auto& [c, which, variance] : columns) {
      core::Scene plus = scene, minus = scene;
      double* value_plus[] = {&plus.contacts[c].restitution, &plus.contacts[c].static_friction,
                              &plus.contacts[c].dynamic_friction};
      double* value_minus[] = {&minus.contacts[c].restitution, &minus.contacts[c].static_friction,
                               &minus.contacts[c].dynamic_friction};
      *value_plus[which] += h;
      *value_minus[which] -= h;
      const Eigen::VectorXd column = (outputs(plus) - outputs(minus)) / (2.0 * h);
      covariance += variance * column * column.transpose();
    }
    const Eigen::VectorXd sd = covariance.diagonal().cwiseSqrt();
    ASSERT_GT(sd.segment<6>(0).maxCoeff(), 1e-3);  // both bodies spread
    ASSERT_GT(sd.segment<6>(6).maxCoeff(), 1e-3);
    const double scale = sd.maxCoeff();
    for (Eigen::Index r = 0; r < m; ++r) {
      SCOPED_TRACE(lin.labels[static_cast<std::size_t>(r)]);
      EXPECT_NEAR(lin.mean(r), mean(r), 1e-12);
      EXPECT_NEAR(lin.q05(r), mean(r) - 1.6448536269514722 * sd(r), 1e-6 * scale);
      EXPECT_NEAR(lin.q95(r), mean(r) + 1.6448536269514722 * sd(r), 1e-6 * scale);
      for (Eigen::Index k = 0; k < m; ++k) {
        EXPECT_NEAR(lin.covariance(r, k), covariance(r, k), 1e-6 * scale * scale);
        EXPECT_EQ(lin.covariance(r, k), lin.covariance(k, r));
      }
    }
  }
}

// A box landing on the ground (contact 0) while a ball strikes its top (contact 1): one island of
// Newton's exact solver, two contacts on different bodies (no redundancy: the sticking impulses are
// unique), contact 0 first sliding at the means with mu_s just below where it would stick (mu_s >
// mu_d), e of both contacts uncertain. Contact 0 sticks iff its sticking impulse P (the answer with
// it held: its friction raised to 100, which no impulse reaches; the ball's contact as it is) lies
// inside the static bound the solver decides on (docs/uncertainty.md, "Linear"):
//  - the ball's contact frictionless: the solver's all-sticking answer (no pivot) holds contact 0,
//    and it tests the static cone, margin g = mu_s P_n - |P_t|;
//  - the ball's contact sliding (mu 0.05): the all-sticking answer fails there, the solver pivots
//    on its LCP, whose static friction is the pyramid of 8 directions turned to contact 0's slip
//    before the impact (d_0 along it), margin g = cos(pi / 8) mu_s P_n - m . P_t with m the
//    outward normal of the facet around P_t (up to 7.6 % inside the cone; with the cone's margin
//    the linear method said 1.0 where the samples say 0.147, and on the edge of a box 0.40
//    against 0.03).
// Then contact 0 just inside its bound, sticking at the means: its margin is the prediction's.
// Reference: g from the test's own solves (held ones where contact 0 slides), its gradient in the
// two e's by central differences, Phi(g / sd(g)); and samples of the solver (4096). The general-
// body path (free rigid BodyModels) gives the same.
TEST(Uncertainty, LinearStickProbabilityInAnIslandIsOnTheBoundTheSolverDecidesOn) {
  const core::BodyState ground = groundBody(), box = landingBox();
  const core::BodyState ball = solidBall(0.5, {0.2, 0.0, 0.6}, {-0.5, 0.3, -4.0});
  core::Contact ground_box;
  ground_box.body_a = "ground";
  ground_box.body_b = "box";
  ground_box.point = {-0.3, 0.1, 0.0};
  ground_box.normal = {0.0, 0.0, 1.0};
  ground_box.restitution = 0.5;
  core::Contact box_ball = ground_box;
  box_ball.body_a = "box";
  box_ball.body_b = "ball";
  box_ball.point = {0.2, 0.0, 0.5};
  // Contact 0's relative velocity before the impact (the ground at rest) and its pyramid's first
  // direction: along its slip.
  const Eigen::Vector3d u0 =
      box.linear_velocity + box.angular_velocity.cross(ground_box.point - box.position);
  const Eigen::Vector3d n = ground_box.normal;
  const Eigen::Vector3d t1 = (u0 - u0.dot(n) * n).normalized(), t2 = n.cross(t1);
  const double e_sd = 0.05, kSector = 2.0 * M_PI / 8.0;
  for (const bool pyramid : {false, true}) {
    SCOPED_TRACE(pyramid ? "the ball's contact sliding: the pyramid" : "frictionless: the cone");
    core::Scene scene;
    scene.bodies = {ground, box, ball};
    scene.contacts = {ground_box, box_ball};
    scene.contacts[1].static_friction = scene.contacts[1].dynamic_friction = pyramid ? 0.05 : 0.0;
    auto held = [&](double d0, double d1) {
      core::Scene moved = scene;
      moved.contacts[0].restitution += d0;
      moved.contacts[1].restitution += d1;
      moved.contacts[0].static_friction = moved.contacts[0].dynamic_friction = 100.0;
      return core::computeResponse(moved, newton());
    };
    const core::CollisionResult at_mean = held(0.0, 0.0);
    ASSERT_EQ(at_mean.islands.size(), 1u);
    ASSERT_TRUE(at_mean.impulses[0].sticking);
    ASSERT_FALSE(at_mean.impulses[1].sticking);
    // No pivot: the all-sticking answer; pivots: the LCP.
    ASSERT_EQ(at_mean.islands[0].iterations > 0, pyramid);
    // The facet around the held friction at the means (the pyramid's margin is affine in P there).
    const Eigen::Vector3d P_t = at_mean.impulses[0].friction_impulse;
    double angle = std::atan2(P_t.dot(t2), P_t.dot(t1));
    if (angle < 0.0) angle += 2.0 * M_PI;
    const double middle = (std::floor(angle / kSector) + 0.5) * kSector;
    const Eigen::Vector3d facet = std::cos(middle) * t1 + std::sin(middle) * t2;
    const double share = pyramid ? std::cos(M_PI / 8.0) : 1.0;
    auto bound = [&](const core::ContactImpulse& p) {  // what mu_s P_n must reach
      return pyramid ? facet.dot(p.friction_impulse) / share : p.friction_impulse.norm();
    };
    // Just below the bound at the means (sliding there, sticking for larger e: the held answer's
    // margin decides), then just above it (sticking there: the prediction's own margin decides).
    for (const double factor : {0.99, 1.01}) {
      const bool sticks = factor > 1.0;
      SCOPED_TRACE(sticks ? "sticking at the means" : "sliding at the means");
      const double mu_s = factor * bound(at_mean.impulses[0]) / at_mean.impulses[0].normal_impulse;
      scene.contacts[0].static_friction = mu_s;
      scene.contacts[0].dynamic_friction = 0.8 * mu_s;
      ASSERT_EQ(core::computeResponse(scene, newton()).impulses[0].sticking, sticks);
      auto margin = [&](double d0, double d1) {
        core::Scene moved = scene;
        moved.contacts[0].restitution += d0;
        moved.contacts[1].restitution += d1;
        const core::ContactImpulse p =
            sticks ? core::computeResponse(moved, newton()).impulses[0] : held(d0, d1).impulses[0];
        return share * (mu_s * p.normal_impulse - bound(p));
      };
      const double h = 1e-6;
      const double g0 = (margin(h, 0.0) - margin(-h, 0.0)) / (2.0 * h);
      const double g1 = (margin(0.0, h) - margin(0.0, -h)) / (2.0 * h);
      const double reference =
          0.5 * std::erfc(-margin(0.0, 0.0) / (e_sd * std::hypot(g0, g1)) / std::sqrt(2.0));
      ASSERT_GT(reference, sticks ? 0.5 : 0.05);
      ASSERT_LT(reference, sticks ? 0.95 : 0.5);
      std::vector<ContactUncertainty> both(2);
      for (std::size_t c = 0; c < 2; ++c) {
        both[c].contact = c;
        both[c].restitution = CoefficientDistribution::normal(0.5, e_sd);
      }
      const auto lin = core::computeOutcomeDistribution(scene, both, newton(), linear());
      EXPECT_NEAR(lin.stick_probability[0], reference, 1e-6);
      // (4096 samples of a pivoting island: about 0.35 s in CI's ASan build, past the default
      // 1 s budget under load.)
      core::SolverOptions patient = newton();
      patient.time_budget = 60.0;
      const auto smp = core::computeOutcomeDistribution(scene, both, patient, sampled(4096));
      EXPECT_NEAR(smp.stick_probability[0], reference, 0.02);
      // The same bodies through the general-body path (the robots'), as free rigid BodyModels.
      std::vector<core::RigidBody> models;
      for (const core::BodyState& body : scene.bodies) models.push_back(core::makeRigidBody(body));
      const std::vector<core::BodyModel*> set = {&models[0], &models[1], &models[2]};
      std::vector<core::ContactPoint> points;
      for (std::size_t c = 0; c < 2; ++c) {
        const core::Contact& k = scene.contacts[c];
        points.emplace_back(static_cast<int>(c), static_cast<int>(c) + 1, k.point, k.normal,
                            k.restitution, k.static_friction, k.dynamic_friction);
      }
      const auto body_lin = core::computeBodyOutcomeDistribution(
          {set}, points, both, Eigen::VectorXd::Constant(12, 1e3), newton(), linear());
      EXPECT_NEAR(body_lin.stick_probability[0], reference, 1e-6);
    }
  }
}

// The linear method keeps its derivatives, island system and prepared lists in storage per thread
// (docs/uncertainty.md, "Cost"). A thread that answered other requests before, of other sizes and
// other solver paths (a face of 4 sticking corners: the exact solver's all-sticking body-space
// solve; one sphere: the closed form; three sliding contacts on two bodies: the exact solver's
// pivots), must give each answer bit for bit as a fresh thread does: nothing of an earlier request
// may leak into a later one. It fails if a reused list or matrix is not cleared or resized.
TEST(Uncertainty, LinearAnswersDoNotDependOnTheThreadsEarlierRequests) {
  core::Scene face;
  face.bodies = {groundBody(), landingBox()};
  for (const double x : {-0.3, 0.3})
    for (const double y : {-0.2, 0.2})
      face.contacts.push_back(groundContact("box", {x, y, 0.0}, 0.8, 0.6));
  const core::Scene three = threeSlidingContacts();
  const core::Scene ball = sphere(0.5, 0.3, 0.25);
  // A ball rolling on the ground (u_n = 0: its contact flagged at a switch) beside one landing.
  core::Scene touch;
  core::BodyState rolling = solidBall(1.0, {0.0, 0.0, 0.1}, {1.0, 0.0, 0.0});
  rolling.id = "rolling";
  touch.bodies = {groundBody(), rolling, solidBall(2.0, {3.0, 0.0, 0.1}, {0.5, 0.0, -1.5})};
  touch.contacts = {groundContact("rolling", {0.0, 0.0, 0.0}, 0.3, 0.25),
                    groundContact("ball", {3.0, 0.0, 0.0}, 0.3, 0.25)};
  auto uncertain = [](const core::Scene& scene) {
    std::vector<ContactUncertainty> all;
    for (std::size_t c = 0; c < scene.contacts.size(); ++c) {
      const core::Contact& k = scene.contacts[c];
      ContactUncertainty u;
      u.contact = c;
      u.restitution = CoefficientDistribution::normal(k.restitution, 0.05);
      u.static_friction =
          CoefficientDistribution::interval(k.static_friction - 0.05, k.static_friction + 0.05);
      u.dynamic_friction = CoefficientDistribution::normal(k.dynamic_friction, 0.03);
      all.push_back(u);
    }
    return all;
  };
  const std::vector<const core::Scene*> scenes = {&face, &ball, &three, &touch};
  auto solve = [&](std::size_t k) {
    return core::computeOutcomeDistribution(*scenes[k], uncertain(*scenes[k]), newton(), linear());
  };
  // Each scene on a thread of its own (nothing before it there).
  std::vector<core::OutcomeDistribution> fresh(scenes.size());
  for (std::size_t k = 0; k < scenes.size(); ++k)
    std::thread([&, k] { fresh[k] = solve(k); }).join();
  auto expectSame = [](const core::OutcomeDistribution& a, const core::OutcomeDistribution& b) {
    EXPECT_EQ(a.labels, b.labels);
    EXPECT_TRUE(a.mean == b.mean);
    EXPECT_TRUE(a.covariance == b.covariance);
    EXPECT_TRUE(a.q05 == b.q05);
    EXPECT_TRUE(a.q95 == b.q95);
    EXPECT_EQ(a.stick_probability, b.stick_probability);
    ASSERT_EQ(a.warnings.size(), b.warnings.size());
    for (std::size_t w = 0; w < a.warnings.size(); ++w) {
      EXPECT_EQ(a.warnings[w].field, b.warnings[w].field);
      EXPECT_EQ(a.warnings[w].reason, b.warnings[w].reason);
    }
  };
  // The face's corners stick (the body-space path is the one exercised) and the three slide.
  for (const double p : fresh[0].stick_probability) EXPECT_GT(p, 0.5);
  for (const double p : fresh[2].stick_probability) EXPECT_LT(p, 0.5);
  // The rolling ball's contact is reported linearised at its switch; the face's first corner is
  // not (a later answer that did would carry the earlier request's flag).
  auto atSwitch = [](const core::OutcomeDistribution& outcome) {
    return std::any_of(
        outcome.warnings.begin(), outcome.warnings.end(), [](const core::Warning& w) {
          return w.field == "contacts[0]" && w.reason.find("linearised at a mode switch") == 0;
        });
  };
  EXPECT_TRUE(atSwitch(fresh[3]));
  EXPECT_FALSE(atSwitch(fresh[0]));
  // All of them one after another on one thread, in an order that changes every size between
  // consecutive calls, twice.
  std::thread([&] {
    for (const std::size_t k : {0, 1, 2, 3, 0, 2, 1, 3, 1, 0}) {
      SCOPED_TRACE(k);
      expectSame(solve(k), fresh[k]);
    }
  }).join();
}
