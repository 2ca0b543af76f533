// A downstream package calls collision_response's core library through its catkin export.
#include <collision_response/core/compute_response.h>
#include <collision_response/core/errors.h>
#include <gtest/gtest.h>

namespace core = collision_response::core;

// Head-on spheres: m1 = 1 kg at 2 m/s, m2 = 2 kg at -1 m/s, e = 0.5. Momentum 0 and separation
// speed e (v1 - v2) = 1.5 give v1' = -1, v2' = 0.5, normal impulse m2 (v2' - v2) = 3 N s.
TEST(Downstream, HeadOnSpheresMatchClosedForm) {
  core::BodyState left, right;
  left.id = "left";
  left.mass = 1.0;
  left.inertia = Eigen::Matrix3d::Identity() * 0.004;
  left.position = {-0.1, 0.0, 0.0};
  left.linear_velocity = {2.0, 0.0, 0.0};
  right.id = "right";
  right.mass = 2.0;
  right.inertia = Eigen::Matrix3d::Identity() * 0.008;
  right.position = {0.1, 0.0, 0.0};
  right.linear_velocity = {-1.0, 0.0, 0.0};
  core::Contact contact;
  contact.body_a = "left";
  contact.body_b = "right";
  contact.point = {0.0, 0.0, 0.0};
  contact.normal = {1.0, 0.0, 0.0};
  contact.restitution = 0.5;
  core::Scene scene;
  scene.bodies = {left, right};
  scene.contacts = {contact};

  const core::CollisionResult result = core::computeResponse(scene);
  ASSERT_EQ(result.bodies.size(), 2u);
  EXPECT_NEAR(result.bodies[0].linear_velocity.x(), -1.0, 1e-9);
  EXPECT_NEAR(result.bodies[1].linear_velocity.x(), 0.5, 1e-9);
  ASSERT_EQ(result.impulses.size(), 1u);
  EXPECT_NEAR(result.impulses[0].normal_impulse, 3.0, 1e-9);
  EXPECT_NEAR(result.kinetic_energy_before, 3.0, 1e-9);
  EXPECT_NEAR(result.kinetic_energy_after, 0.75, 1e-9);
}

TEST(Downstream, BadInputThrowsNamingTheField) {
  core::Scene scene;
  core::BodyState body;
  body.id = "ball";
  body.mass = -1.0;
  scene.bodies = {body};
  try {
    core::computeResponse(scene);
    FAIL() << "a negative mass must be rejected";
  } catch (const core::InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("bodies[0].inertia.m"), std::string::npos) << e.what();
  }
}
