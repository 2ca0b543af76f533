// The one island pipeline (solve_islands.h) behind computeResponse() (a Scene) and
// computeBodyResponse() (bodies behind BodyModel): both entry points answer a frictionless
// off-centre impact with the closed form of one contact, P = -(1 + e) u_n m_eff with
// m_eff = 1 / (1/m + (r x n)^T I^-1 (r x n)), and report that effective mass; a normal within the
// one unit-length tolerance (kUnitTolerance) is normalised in both, one beyond it is rejected by
// both with the same field and text.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "collision_response/core/body_response.h"
#include "collision_response/core/compute_response.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/validation.h"
#include "scenes.h"

namespace core = collision_response::core;
using namespace collision_response::testing;
using Eigen::Vector3d;

namespace {

constexpr double kMass = 2.0;
constexpr double kRestitution = 0.5;

// A box (2 kg, principal moments 0.1, 0.2, 0.25 kg m^2, axis-aligned) falling at 1.5 m/s and
// spinning about x, struck by the ground at p = c + r, r = (0.3, -0.2, -0.5), normal +z.
core::Scene boxOnGround(const Vector3d& normal) {
  core::BodyState box;
  box.id = "box";
  box.mass = kMass;
  box.inertia = Vector3d(0.1, 0.2, 0.25).asDiagonal();
  box.position = {0.0, 0.0, 0.5};
  box.linear_velocity = {0.0, 0.0, -1.5};
  box.angular_velocity = {0.4, 0.0, 0.0};
  core::Scene scene;
  scene.bodies = {ground(), box};
  scene.contacts = {contact("ground", "box", {0.3, -0.2, 0.0}, normal, kRestitution)};
  return scene;
}

// The closed form, from the scene's numbers alone.
struct ClosedForm {
  double effective_mass;
  double impulse;
};
ClosedForm closedForm() {
  const Vector3d r(0.3, -0.2, -0.5);
  const Vector3d n = Vector3d::UnitZ();
  const Vector3d rxn = r.cross(n);
  const Vector3d inverse_moments(1.0 / 0.1, 1.0 / 0.2, 1.0 / 0.25);
  const double w = 1.0 / kMass + rxn.dot(inverse_moments.asDiagonal() * rxn);
  const double u_n = -1.5 + Vector3d(0.4, 0.0, 0.0).cross(r).dot(n);  // v + w x r along n
  return {1.0 / w, -(1.0 + kRestitution) * u_n / w};
}

core::BodyResponse throughBodies(const core::Scene& scene) {
  core::RigidBody ground_body = core::makeRigidBody(scene.bodies[0]);
  core::RigidBody box = core::makeRigidBody(scene.bodies[1]);
  const core::Contact& c = scene.contacts[0];
  const core::ContactPoint point(0, 1, c.point, c.normal, c.restitution, c.static_friction,
                                 c.dynamic_friction);
  return core::computeBodyResponse({&ground_body, &box}, {point});
}

TEST(SolveIslands, BothEntryPointsGiveTheClosedFormAndItsEffectiveMass) {
  const ClosedForm expected = closedForm();
  const core::Scene scene = boxOnGround(Vector3d::UnitZ());
  const core::CollisionResult scene_answer = core::computeResponse(scene);
  const core::BodyResponse body_answer = throughBodies(scene);
  for (const core::ContactResponse* answer :
       {static_cast<const core::ContactResponse*>(&scene_answer),
        static_cast<const core::ContactResponse*>(&body_answer)}) {
    ASSERT_EQ(answer->effective_masses.size(), 1u);
    EXPECT_NEAR(answer->effective_masses[0], expected.effective_mass,
                1e-12 * expected.effective_mass);
    EXPECT_NEAR(answer->impulses[0].normal_impulse, expected.impulse, 1e-12 * expected.impulse);
    ASSERT_EQ(answer->islands.size(), 1u);
    EXPECT_EQ(answer->islands[0].contacts, std::vector<int>{0});
  }
}

// |n| = 1 + 5e-4, inside kUnitTolerance: the answer is the unit normal's (normalised), in both
// entry points. Left unnormalised, P and m_eff would be off by about 5e-4 relative.
TEST(SolveIslands, NormalWithinTheUnitToleranceIsNormalisedInBoth) {
  ASSERT_LT(5e-4, core::kUnitTolerance);
  const ClosedForm expected = closedForm();
  const core::Scene scene = boxOnGround(Vector3d(0.0, 0.0, 1.0 + 5e-4));
  const core::CollisionResult scene_answer = core::computeResponse(scene);
  const core::BodyResponse body_answer = throughBodies(scene);
  EXPECT_NEAR(scene_answer.impulses[0].normal_impulse, expected.impulse, 1e-12 * expected.impulse);
  EXPECT_NEAR(body_answer.impulses[0].normal_impulse, expected.impulse, 1e-12 * expected.impulse);
  EXPECT_NEAR(body_answer.effective_masses[0], expected.effective_mass,
              1e-12 * expected.effective_mass);
}

// One validation of contacts: the same bad values are rejected by both entry points, naming the
// same field with the same text.
TEST(SolveIslands, OneValidationOfContactsForBothEntryPoints) {
  const auto errorOf = [](const auto& call) -> std::pair<std::string, std::string> {
    try {
      call();
    } catch (const core::InvalidInput& error) {
      return {error.field(), error.what()};
    }
    return {"", "no error"};
  };
  struct Case {
    Vector3d point, normal;
    double restitution;
    const char* field;
  };
  const double nan = std::nan("");
  for (const Case& bad :
       {Case{{0.3, -0.2, 0.0}, {0.0, 0.0, 1.01}, 0.5, "contacts[0].normal"},
        Case{{0.3, -0.2, 0.0}, {0.0, 0.0, 0.0}, 0.5, "contacts[0].normal"},
        Case{{nan, -0.2, 0.0}, {0.0, 0.0, 1.0}, 0.5, "contacts[0].point.x"},
        Case{{2e7, 0.0, 0.0}, {0.0, 0.0, 1.0}, 0.5, "contacts[0].point"},
        Case{{0.3, -0.2, 0.0}, {0.0, 0.0, 1.0}, 1.5, "contacts[0].restitution"}}) {
    core::Scene scene = boxOnGround(bad.normal);
    scene.contacts[0].point = bad.point;
    scene.contacts[0].restitution = bad.restitution;
    const auto from_scene = errorOf([&] { core::computeResponse(scene); });
    const auto from_bodies = errorOf([&] { throughBodies(scene); });
    EXPECT_EQ(from_scene.first, bad.field) << from_scene.second;
    EXPECT_EQ(from_bodies, from_scene);
  }
}

}  // namespace
