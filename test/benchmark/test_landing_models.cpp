// The real-tosses benchmark's landing models (benchmark/landing_baselines.h, landing_ours.h) on
// landings with closed forms: a cube falling face down (every law and rule gives v_z' = -e v_z on
// the 4 corners at once) and one falling on a single corner without friction (Newton's single
// contact impulse for an isotropic body). Times of contact from the quadratic of the fall.
#include <gtest/gtest.h>

#include <cmath>

#include "landing_baselines.h"
#include "landing_ours.h"

using namespace collision_response;
using namespace collision_response::bench;

namespace {

constexpr double kG = 9.81;
/// The models find the first contact to 1 um of height, i.e. up to about 1e-6 / 1.5 s early: the
/// velocity at the impact differs from the exact one by (1 + e) g times that, under 2e-5 m/s.
constexpr double kTol = 2e-5;

/// The time [s] a point at height z0 [m] falling at vz0 < 0 [m/s] reaches z = 0 under gravity.
double fallTime(double z0, double vz0) {
  return (vz0 + std::sqrt(vz0 * vz0 + 2.0 * kG * z0)) / kG;
}

}  // namespace

TEST(LandingModels, FaceDownLandingBouncesWithMinusEVz) {
  const TossedCube cube;
  CubeState before;
  before.position = Eigen::Vector3d(0.1, -0.2, cube.half_width + 0.03);
  before.linear_velocity = Eigen::Vector3d(0.0, 0.0, -1.5);
  const double e = 0.4, duration = 0.06;
  const double tc = fallTime(0.03, -1.5);
  ASSERT_LT(tc, duration);
  const double vz_contact = -1.5 - kG * tc;
  const double vz_expected = -e * vz_contact - kG * (duration - tc);
  std::vector<std::unique_ptr<LandingModel>> models;
  models.push_back(makeBounceRuleLanding(cube));
  for (auto law :
       {core::ImpactLaw::kNewton, core::ImpactLaw::kPoisson, core::ImpactLaw::kStronge}) {
    models.push_back(makeOneImpactLanding(cube, law, false));
    models.push_back(makeRepeatedImpactsLanding(cube, law, false));
    if (auto episode = makeEpisodeLanding(cube, law, false)) models.push_back(std::move(episode));
  }
  for (auto& model : models) {
    std::vector<double> values{e};
    if (model->parameters().size() == 2) values.push_back(0.3);
    const CubeState after = model->simulate(before, values, duration);
    EXPECT_NEAR(after.linear_velocity.z(), vz_expected, kTol) << model->name();
    EXPECT_NEAR(after.linear_velocity.head<2>().norm(), 0.0, 1e-9) << model->name();
    EXPECT_NEAR(after.angular_velocity.norm(), 0.0, 1e-6) << model->name();
  }
  // 3-factor scaling with a_n = e, and no change (ballistic through the table).
  EXPECT_NEAR(
      makeScalingLanding(cube)->simulate(before, {e, 0.5, 0.5}, duration).linear_velocity.z(),
      vz_expected, kTol);
  EXPECT_NEAR(makeNoChangeLanding(cube)->simulate(before, {}, duration).linear_velocity.z(),
              -1.5 - kG * duration, 1e-12);
}

TEST(LandingModels, FrictionlessCornerLandingIsNewtonsSingleContactImpulse) {
  const TossedCube cube;
  CubeState before;
  before.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitX()) *
                                          Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()));
  const Eigen::Matrix3d R = before.orientation.toRotationMatrix();
  // The lowest corner: signs opposite to the rotation's third row.
  Eigen::Vector3d local;
  for (int i = 0; i < 3; ++i) local[i] = R(2, i) > 0 ? -cube.half_width : cube.half_width;
  const Eigen::Vector3d r = R * local;  // centre to corner, world
  const double height = 0.02;
  before.position = Eigen::Vector3d(0.0, 0.0, height - r.z());
  before.linear_velocity = Eigen::Vector3d(0.7, -0.2, -1.2);
  const double e = 0.3, duration = 0.05;
  const double tc = fallTime(height, -1.2);
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  const double un = -1.2 - kG * tc;  // no spin: the corner's normal velocity is the centre's
  const double k = 1.0 / cube.mass + r.cross(n).squaredNorm() / cube.inertia;
  const double impulse = -(1.0 + e) * un / k;
  const Eigen::Vector3d v_expected =
      before.linear_velocity + Eigen::Vector3d(0, 0, -kG * duration) + impulse * n / cube.mass;
  const Eigen::Vector3d w_expected = impulse * r.cross(n) / cube.inertia;
  for (bool split : {false, true}) {
    auto model = makeOneImpactLanding(cube, core::ImpactLaw::kNewton, split);
    std::vector<double> values{e, 0.0};
    if (split) values.push_back(0.0);
    const CubeState after = model->simulate(before, values, duration);
    EXPECT_LT((after.linear_velocity - v_expected).norm(), kTol) << model->name();
    EXPECT_LT((after.angular_velocity - w_expected).norm(), kTol / 0.05) << model->name();
  }
}

// The same corner landing followed to its end: the spin the first impact gives brings another
// corner down within the 50 ms, so the answer is no closed form. The harness's event-driven
// repetition of impacts (a scan and bisection on the corners' heights) and core::computeEpisode()
// (conservative advancement on the GapQuery of the harness) find the contacts independently; they
// must agree to the effect of their contact tolerances (1e-4 m, 0.1 us).
TEST(LandingModels, EpisodeAgreesWithTheHarnessRepetitionOfImpacts) {
  const TossedCube cube;
  for (const auto law : {core::ImpactLaw::kNewton, core::ImpactLaw::kStronge}) {
    auto episode = makeEpisodeLanding(cube, law, false);
    if (!episode) GTEST_SKIP() << "the core library has no computeEpisode()";
    auto repeated = makeRepeatedImpactsLanding(cube, law, false);
    CubeState before;
    before.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitX()) *
                                            Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()));
    before.position = Eigen::Vector3d(0.0, 0.0, 0.11);
    before.linear_velocity = Eigen::Vector3d(0.7, -0.2, -1.2);
    before.angular_velocity = Eigen::Vector3d(2.0, -1.0, 3.0);
    for (const double mu : {0.0, 0.3}) {
      const std::vector<double> values{0.3, mu};
      const CubeState a = episode->simulate(before, values, 0.08);
      const CubeState b = repeated->simulate(before, values, 0.08);
      EXPECT_LT((a.linear_velocity - b.linear_velocity).norm(), 2e-3) << episode->name() << mu;
      EXPECT_LT((a.angular_velocity - b.angular_velocity).norm(), 5e-2) << episode->name() << mu;
      // More than one impact happened: the one-impact answer is far from both.
      const CubeState c = makeOneImpactLanding(cube, law, false)->simulate(before, values, 0.08);
      EXPECT_GT((c.angular_velocity - b.angular_velocity).norm(), 1.0) << episode->name() << mu;
    }
  }
}
