// Warnings for contacts an answer leaves approaching (approach_warnings.h): the warning appears
// exactly where the bodies' post-impact velocities, recomputed here from the answer's states, make
// a contact approach faster than resting_velocity, and its reason says why.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "collision_response/core/compute_response.h"
#include "scenes.h"

namespace core = collision_response::core;
using namespace collision_response::testing;

namespace {

// A bar (1 kg, half-length L = 0.5 m, I_yy = m L^2 / 3) lands flat on both ends at 1 m/s, e = 0,
// no friction. Each end alone has W = 1/m + L^2/I = 4/m. Contact by contact (the one-pass law): the
// left end's impulse m/4 stops it and drives the right end to -1.5 m/s; the right end's impulse
// 1.5 m/4 stops it and changes the left end by 1.5 m/4 (1/m - L^2/I) = -0.75 m/s.
core::Scene barLandingFlat() {
  core::BodyState bar;
  bar.id = "bar";
  bar.mass = 1.0;
  bar.inertia = Eigen::Vector3d(0.001, 0.25 / 3.0, 0.25 / 3.0).asDiagonal();
  bar.linear_velocity = {0.0, 0.0, -1.0};
  core::Scene scene;
  scene.bodies = {ground(), bar};
  scene.contacts = {contact("ground", "bar", {-0.5, 0, 0}, Eigen::Vector3d::UnitZ(), 0.0),
                    contact("ground", "bar", {0.5, 0, 0}, Eigen::Vector3d::UnitZ(), 0.0)};
  return scene;
}

std::set<std::string> approachWarnings(const core::CollisionResult& result) {
  std::set<std::string> fields;
  for (const core::Warning& warning : result.warnings)
    if (warning.kind == core::Warning::Kind::kLeftApproaching) fields.insert(warning.field);
  return fields;
}

// The contacts whose normal velocity after the answer, from the answer's body states, is below
// -resting_velocity.
std::set<std::string> approachingAfter(const core::Scene& scene,
                                       const core::CollisionResult& result, double resting) {
  std::set<std::string> fields;
  for (std::size_t c = 0; c < scene.contacts.size(); ++c) {
    const core::Contact& contact = scene.contacts[c];
    const auto body = [&](const std::string& id) -> const core::BodyState& {
      for (const core::BodyState& b : result.bodies)
        if (b.id == id) return b;
      throw std::runtime_error("no body " + id);
    };
    const double u =
        contact.normal.normalized().dot(pointVelocity(body(contact.body_b), contact.point) -
                                        pointVelocity(body(contact.body_a), contact.point));
    if (u < -resting) fields.insert("contacts[" + std::to_string(c) + "]");
  }
  return fields;
}

TEST(ApproachWarnings, OnePassLeavesTheFirstEndOfALandingBarApproaching) {
  core::SolverOptions options;
  options.law = core::ImpactLaw::kSeedOnePass;
  const core::CollisionResult result = core::computeResponse(barLandingFlat(), options);
  EXPECT_NEAR(result.impulses[0].normal_impulse, 0.25, 1e-12);
  EXPECT_NEAR(result.impulses[1].normal_impulse, 0.375, 1e-12);
  EXPECT_NEAR(result.impulses[0].normal_velocity_after, -0.75, 1e-12);
  EXPECT_NEAR(result.impulses[1].normal_velocity_after, 0.0, 1e-12);
  ASSERT_EQ(result.warnings.size(), 1u);
  EXPECT_EQ(result.warnings[0].field, "contacts[0]");
  EXPECT_EQ(result.warnings[0].kind, core::Warning::Kind::kLeftApproaching);
  EXPECT_NE(result.warnings[0].reason.find("-0.75 m/s"), std::string::npos)
      << result.warnings[0].reason;
  EXPECT_NE(result.warnings[0].reason.find("seed_one_pass"), std::string::npos)
      << result.warnings[0].reason;
}

TEST(ApproachWarnings, LawsSolvedTogetherLeaveNothingApproaching) {
  for (const core::ImpactLaw law :
       {core::ImpactLaw::kNewton, core::ImpactLaw::kPoisson, core::ImpactLaw::kStronge}) {
    core::SolverOptions options;
    options.law = law;
    const core::CollisionResult result = core::computeResponse(barLandingFlat(), options);
    EXPECT_TRUE(result.warnings.empty())
        << core::toString(law) << ": " << result.warnings[0].text();
    EXPECT_GE(result.impulses[0].normal_velocity_after, -options.resting_velocity);
    EXPECT_GE(result.impulses[1].normal_velocity_after, -options.resting_velocity);
  }
}

// Random islands of one body on 2 to 4 ground contacts plus a second body striking it: the warnings
// are exactly the contacts the answer's states leave approaching, under every law; the laws solved
// together leave none.
TEST(ApproachWarnings, WarnedExactlyWhereTheAnswerLeavesAContactApproaching) {
  RandomSource random(2211);
  int one_pass_warned = 0;
  for (int trial = 0; trial < 120; ++trial) {
    core::Scene scene;
    const core::BodyState box = randomFallingBox(random, true);
    core::BodyState ball =
        sphere("ball", random.uniform(0.1, 2.0), 0.1, {0.0, 0.0, 0.5}, {0.0, 0.0, -2.0});
    scene.bodies = {ground(), box, ball};
    const int ground_contacts = 2 + trial % 3;
    for (int k = 0; k < ground_contacts; ++k) {
      const Eigen::Vector3d p(random.uniform(-0.5, 0.5), random.uniform(-0.5, 0.5), -0.3);
      scene.contacts.push_back(contact("ground", "box", p, Eigen::Vector3d::UnitZ(),
                                       random.uniform(0.0, 1.0), 0.5, 0.4));
    }
    scene.contacts.push_back(contact("box", "ball", {0.0, 0.0, 0.4}, Eigen::Vector3d::UnitZ(),
                                     random.uniform(0.0, 1.0), 0.3, 0.3));
    for (const core::ImpactLaw law :
         {core::ImpactLaw::kSeedOnePass, core::ImpactLaw::kNewton, core::ImpactLaw::kStronge}) {
      core::SolverOptions options;
      options.law = law;
      const core::CollisionResult result = core::computeResponse(scene, options);
      const std::set<std::string> warned = approachWarnings(result);
      EXPECT_EQ(warned, approachingAfter(scene, result, options.resting_velocity))
          << "trial " << trial << " law " << core::toString(law);
      if (law == core::ImpactLaw::kSeedOnePass) {
        one_pass_warned += !warned.empty();
      } else {
        EXPECT_TRUE(warned.empty()) << "trial " << trial << " law " << core::toString(law);
      }
    }
  }
  // The one-pass law must have left contacts approaching in a good share of the trials, or this
  // test checks nothing.
  EXPECT_GT(one_pass_warned, 12);
}

}  // namespace
