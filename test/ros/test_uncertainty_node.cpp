// Integration test: uncertain contact coefficients through the node's ~compute service
// (options.uncertainty, request.uncertainties, response.outcome_distribution; docs/uncertainty.md).
// The reference is the stick condition of a sphere landing on its pole, in closed form: with
// K_n = 1/m and K_t = 7 / (2 m), Newton's law sticks iff mu_s >= 2 u_t / (7 (1 + e) u_n).
#include <collision_response/ComputeBatch.h>
#include <collision_response/ComputeResponse.h>
#include <gtest/gtest.h>
#include <ros/ros.h>

#include <cmath>

#include "node_test_messages.h"

namespace cr = collision_response;
using namespace collision_response::testing;

namespace {

constexpr double kUt = 0.5;
constexpr double kUn = 2.0;
constexpr double kE = 0.4;
const double kThreshold = 2.0 * kUt / (7.0 * (1.0 + kE) * kUn);

cr::Distribution normal(double mean, double std_dev) {
  cr::Distribution d;
  d.type = cr::Distribution::TYPE_NORMAL;
  d.mean = mean;
  d.std_dev = std_dev;
  return d;
}

cr::Distribution interval(double min, double max) {
  cr::Distribution d;
  d.type = cr::Distribution::TYPE_INTERVAL;
  d.min = min;
  d.max = max;
  return d;
}

// A 2 kg sphere of radius 0.1 m landing at (0.5, 0, -2) m/s on the ground, Newton's law; mu_s
// uncertain ~ N(mean, 0.005), mu_d = 0.01.
cr::ComputeResponse landingSphere(std::uint8_t method, double mean) {
  cr::ComputeResponse srv;
  srv.request.header.frame_id = "world";
  cr::BodyState ground;
  ground.id = "ground";
  ground.pose.orientation.w = 1.0;
  cr::BodyState ball = sphere("ball", 2.0, 0.1, pose(0, 0, 0.1));
  ball.twist.linear.x = kUt;
  ball.twist.linear.z = -kUn;
  srv.request.bodies = {ground, ball};
  srv.request.contacts = {contact("ground", "ball", 0, 0, 0, 0, 0, 1, kE, mean, 0.01)};
  srv.request.options.law = cr::SolverOptions::LAW_NEWTON;
  srv.request.options.uncertainty = method;
  srv.request.options.uncertainty_samples = 4096;
  cr::ContactUncertainty u;
  u.contact = 0;
  u.static_friction = normal(mean, 0.005);
  srv.request.uncertainties = {u};
  return srv;
}

class UncertaintyNodeTest : public ServiceTest {};

TEST_F(UncertaintyNodeTest, StickProbabilityMatchesTheClosedForm) {
  for (const double mean : {kThreshold + 0.004, kThreshold - 0.006}) {
    const double exact = 0.5 * std::erfc(-((mean - kThreshold) / 0.005) / std::sqrt(2.0));
    for (const std::uint8_t method :
         {cr::SolverOptions::UNCERTAINTY_LINEAR, cr::SolverOptions::UNCERTAINTY_SAMPLED}) {
      SCOPED_TRACE(std::to_string(mean) + " method " + std::to_string(method));
      const auto response = call(landingSphere(method, mean));
      ASSERT_TRUE(response.success) << response.message;
      const cr::OutcomeDistribution& d = response.outcome_distribution;
      EXPECT_EQ(d.method, method == cr::SolverOptions::UNCERTAINTY_LINEAR ? "linear" : "sampled");
      EXPECT_EQ(d.samples, method == cr::SolverOptions::UNCERTAINTY_LINEAR ? 0u : 4096u);
      ASSERT_EQ(d.labels.size(), 10u);
      EXPECT_EQ(d.labels[0], "bodies[1].twist.linear.x");
      EXPECT_EQ(d.labels[6], "impulses[0].normal_impulse");
      EXPECT_EQ(d.mean.size(), 10u);
      EXPECT_EQ(d.covariance.size(), 100u);
      EXPECT_EQ(d.q05.size(), 10u);
      EXPECT_EQ(d.q95.size(), 10u);
      ASSERT_EQ(d.stick_probability.size(), 1u);
      EXPECT_NEAR(d.stick_probability[0], exact,
                  method == cr::SolverOptions::UNCERTAINTY_LINEAR ? 1e-6 : 5e-3);
      // The normal impulse (1 + e) m u_n does not depend on mu_s.
      EXPECT_NEAR(d.mean[6], (1 + kE) * 2.0 * kUn, 1e-9);
      EXPECT_NEAR(d.covariance[6 * 10 + 6], 0.0, 1e-12);
      // The answer itself stays the prediction with the contact's own coefficients.
      EXPECT_EQ(response.impulses[0].sticking, mean >= kThreshold);
    }
  }
}

TEST_F(UncertaintyNodeTest, NoMethodNoDistribution) {
  const auto response = call(landingSphere(cr::SolverOptions::UNCERTAINTY_NONE, 0.05));
  ASSERT_TRUE(response.success) << response.message;
  EXPECT_TRUE(response.outcome_distribution.method.empty());
  EXPECT_TRUE(response.outcome_distribution.mean.empty());
  bool warned = false;
  for (const std::string& w : response.warnings) warned |= w.rfind("uncertainties:", 0) == 0;
  EXPECT_TRUE(warned);
}

TEST_F(UncertaintyNodeTest, BadInputIsRejectedNamingTheField) {
  const auto sampled = cr::SolverOptions::UNCERTAINTY_SAMPLED;
  auto rejected = [&](const cr::ComputeResponse& srv, const std::string& field) {
    const auto response = expectRejected(srv, field);
    EXPECT_TRUE(response.outcome_distribution.mean.empty());
  };
  cr::ComputeResponse srv = landingSphere(sampled, 0.05);
  srv.request.uncertainties[0].static_friction.std_dev = -0.01;
  rejected(srv, "uncertainties[0].static_friction.std_dev");
  srv = landingSphere(sampled, 0.05);
  srv.request.uncertainties[0].restitution = interval(0.6, 0.4);
  rejected(srv, "uncertainties[0].restitution.min");
  srv = landingSphere(sampled, 0.05);
  srv.request.uncertainties[0].restitution = interval(0.5, 1.1);
  rejected(srv, "uncertainties[0].restitution.max");
  srv = landingSphere(sampled, 0.05);
  srv.request.uncertainties[0].restitution.type = 7;
  rejected(srv, "uncertainties[0].restitution.type");
  srv = landingSphere(sampled, 0.05);
  srv.request.options.uncertainty_samples = 100001;
  rejected(srv, "options.uncertainty_samples");
  srv = landingSphere(sampled, 0.05);
  srv.request.options.uncertainty = 9;
  rejected(srv, "options.uncertainty");
  srv = landingSphere(sampled, 0.05);
  srv.request.uncertainties[0].contact = 3;
  rejected(srv, "uncertainties[0].contact");
  EXPECT_TRUE(call(landingSphere(sampled, 0.05)).success) << "node stopped serving";
}

// The same sphere falling straight down at 2 m/s, frictionless, its contact normal uncertain
// (normal_std_dev = sigma, sampled, then linear). Closed form (test_geometry_uncertainty.cpp
// derives it): with the normal (a, b, 1) / s and the point under the centre, v_x = (1 + e) V a / (1
// + 3.5 (a^2 + b^2)), so Var(v_x) = Var(v_y) = ((1 + e) V sigma)^2 (1 - 28 sigma^2) + O(sigma^6),
// mean 0.
TEST_F(UncertaintyNodeTest, UncertainNormalSpreadsTheTangentialVelocity) {
  const double sigma = 0.02, speed = 2.0;
  cr::ComputeResponse srv = landingSphere(cr::SolverOptions::UNCERTAINTY_SAMPLED, 0.0);
  srv.request.bodies[1].twist.linear.x = 0.0;
  srv.request.bodies[1].twist.linear.z = -speed;
  srv.request.contacts[0].static_friction = 0.0;
  srv.request.contacts[0].dynamic_friction = 0.0;
  cr::ContactUncertainty u;
  u.contact = 0;
  u.normal_std_dev = sigma;
  srv.request.uncertainties = {u};
  const auto response = call(srv);
  ASSERT_TRUE(response.success) << response.message;
  const cr::OutcomeDistribution& d = response.outcome_distribution;
  ASSERT_EQ(d.mean.size(), 10u);
  const double variance = std::pow((1 + kE) * speed * sigma, 2) * (1.0 - 28.0 * sigma * sigma);
  EXPECT_NEAR(d.covariance[0 * 10 + 0], variance, 0.01 * variance);
  EXPECT_NEAR(d.covariance[1 * 10 + 1], variance, 0.01 * variance);
  EXPECT_NEAR(d.mean[0], 0.0, 0.01 * std::sqrt(variance));
  // The answer itself is the prediction at the contact's own normal: straight back up.
  EXPECT_NEAR(response.bodies[1].twist.linear.x, 0.0, 1e-12);

  // The linear method: the first-order variance, ((1 + e) V sigma)^2, and the prediction as mean.
  srv.request.options.uncertainty = cr::SolverOptions::UNCERTAINTY_LINEAR;
  const auto linear = call(srv);
  ASSERT_TRUE(linear.success) << linear.message;
  const cr::OutcomeDistribution& l = linear.outcome_distribution;
  ASSERT_EQ(l.mean.size(), 10u);
  const double leading = std::pow((1 + kE) * speed * sigma, 2);
  EXPECT_NEAR(l.covariance[0 * 10 + 0], leading, 1e-6 * leading);
  EXPECT_NEAR(l.covariance[1 * 10 + 1], leading, 1e-6 * leading);
  EXPECT_NEAR(l.mean[0], 0.0, 1e-12);

  // A negative spread is refused naming the field, under either method.
  srv.request.uncertainties[0].point_std_dev.y = -0.01;
  expectRejected(srv, "uncertainties[0].point_std_dev.y");
  srv.request.options.uncertainty = cr::SolverOptions::UNCERTAINTY_SAMPLED;
  expectRejected(srv, "uncertainties[0].point_std_dev.y");
}

// Two spheres colliding head-on along x, frictionless: left (1 kg, +2 m/s), right (3 kg, -1 m/s),
// restitution e. Newton's law in closed form: the normal impulse is (1 + e) m_red w with the
// reduced mass m_red = 0.75 kg and the closing speed w = 3 m/s, so
//   v_left(e) = 2 - 2.25 (1 + e),  v_right(e) = -1 + 0.75 (1 + e),  P(e) = 2.25 (1 + e):
// affine in e, whose mean, variance and quantiles carry over exactly.
cr::Scene headOnSpheres(double e) {
  cr::Scene scene;
  cr::BodyState left = sphere("left", 1.0, 0.1, pose(0, 0, 0));
  left.twist.linear.x = 2.0;
  cr::BodyState right = sphere("right", 3.0, 0.1, pose(0.2, 0, 0));
  right.twist.linear.x = -1.0;
  scene.bodies = {left, right};
  scene.contacts = {contact("left", "right", 0.1, 0, 0, 1, 0, 0, e)};
  scene.options.law = cr::SolverOptions::LAW_NEWTON;
  return scene;
}

TEST(UncertaintyBatchTest, BatchSceneCarriesTheDistributionOfAnUncertainRestitution) {
  ros::NodeHandle node;
  ASSERT_TRUE(ros::service::waitForService("/collision_response/compute_batch", ros::Duration(20)));
  constexpr double a = 0.3, b = 0.7;  // e uniform on [a, b]
  cr::ComputeBatch srv;
  srv.request.header.frame_id = "world";
  cr::Scene uncertain = headOnSpheres(0.5 * (a + b));
  uncertain.options.uncertainty = cr::SolverOptions::UNCERTAINTY_SAMPLED;
  uncertain.options.uncertainty_samples = 4096;
  cr::ContactUncertainty u;
  u.contact = 0;
  u.restitution = interval(a, b);
  uncertain.uncertainties = {u};
  const double e_plain = 0.8;
  srv.request.scenes = {uncertain, headOnSpheres(e_plain)};
  ASSERT_TRUE(callService("/collision_response/compute_batch", srv));
  ASSERT_TRUE(srv.response.success) << srv.response.message;
  ASSERT_EQ(srv.response.results.size(), 2u);

  const cr::SceneResult& first = srv.response.results[0];
  ASSERT_TRUE(first.success) << first.message;
  for (const std::string& w : first.warnings)
    EXPECT_EQ(w.find("uncertaint"), std::string::npos) << w;
  const cr::OutcomeDistribution& d = first.outcome_distribution;
  EXPECT_EQ(d.method, "sampled");
  EXPECT_EQ(d.samples, 4096u);
  const std::size_t n = 16;  // two movable bodies' twists, then one contact's 4 impulse values
  ASSERT_EQ(d.labels.size(), n);
  ASSERT_EQ(d.labels[0], "bodies[0].twist.linear.x");
  ASSERT_EQ(d.labels[6], "bodies[1].twist.linear.x");
  ASSERT_EQ(d.labels[12], "impulses[0].normal_impulse");
  ASSERT_EQ(d.mean.size(), n);
  ASSERT_EQ(d.covariance.size(), n * n);
  ASSERT_EQ(d.q05.size(), n);
  ASSERT_EQ(d.q95.size(), n);

  // Slopes of the three affine quantities in e, and their values at e.
  const double slope[3] = {-2.25, 0.75, 2.25};
  auto value = [&](int k, double e) {
    const double at0[3] = {2.0 - 2.25, -1.0 + 0.75, 2.25};
    return at0[k] + slope[k] * e;
  };
  const std::size_t row[3] = {0, 6, 12};
  const double mean_e = 0.5 * (a + b), var_e = (b - a) * (b - a) / 12.0;
  const double e05 = a + 0.05 * (b - a), e95 = a + 0.95 * (b - a);
  for (int k = 0; k < 3; ++k) {
    SCOPED_TRACE(d.labels[row[k]]);
    EXPECT_NEAR(d.mean[row[k]], value(k, mean_e), 1e-3);
    for (int l = 0; l < 3; ++l)
      EXPECT_NEAR(d.covariance[row[k] * n + row[l]], slope[k] * slope[l] * var_e, 1e-3 * 0.09);
    // A decreasing quantity's 5 % quantile is its value at e's 95 % quantile.
    EXPECT_NEAR(d.q05[row[k]], value(k, slope[k] > 0 ? e05 : e95), 2e-3);
    EXPECT_NEAR(d.q95[row[k]], value(k, slope[k] > 0 ? e95 : e05), 2e-3);
  }
  // Nothing else moves: y, z and the spins stay zero in every sample.
  for (std::size_t i : {1u, 2u, 3u, 4u, 5u, 7u, 13u, 14u, 15u}) {
    EXPECT_NEAR(d.mean[i], 0.0, 1e-9) << d.labels[i];
    EXPECT_NEAR(d.covariance[i * n + i], 0.0, 1e-12) << d.labels[i];
  }
  // The answer itself is the prediction at the contact's own restitution (the mean).
  ASSERT_EQ(first.bodies.size(), 2u);
  EXPECT_NEAR(first.bodies[0].twist.linear.x, value(0, mean_e), 1e-9);

  // The scene without uncertainties: its prediction, no distribution.
  const cr::SceneResult& second = srv.response.results[1];
  ASSERT_TRUE(second.success) << second.message;
  EXPECT_TRUE(second.outcome_distribution.method.empty());
  EXPECT_TRUE(second.outcome_distribution.mean.empty());
  ASSERT_EQ(second.bodies.size(), 2u);
  EXPECT_NEAR(second.bodies[0].twist.linear.x, value(0, e_plain), 1e-9);
  EXPECT_NEAR(second.bodies[1].twist.linear.x, value(1, e_plain), 1e-9);
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_uncertainty_node");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  return RUN_ALL_TESTS();
}
