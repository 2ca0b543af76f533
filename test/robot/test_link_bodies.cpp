// robot::linkBody(), a robot's link as a body of detection, against the pendulum's closed-form
// kinematics: the rod's frame is the base pose composed with a rotation by q about the hinge's z.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <string>

#include "collision_response/robot/articulated_body.h"
#include "collision_response/robot/link_bodies.h"
#include "collision_response/robot/urdf_loader.h"

namespace rb = collision_response::robot;
using Eigen::AngleAxisd;
using Eigen::Isometry3d;
using Eigen::Matrix3d;
using Eigen::Vector3d;
using Eigen::VectorXd;

namespace {
const std::string kDir = ROBOT_TEST_DIR;
}  // namespace

// Pendulum (test/robot/pendulum.urdf): hinge about z at the base's origin. With base pose
// (t, R_base) and angle q the rod's frame is at t, rotated R_base Rz(q); the body is at rest, 1 kg,
// unit inertia, whatever the joint velocity.
TEST(LinkBodies, PendulumRodIsItsFrameAtTheRobotsState) {
  rb::ArticulatedBody rod = rb::robotFromUrdfFile(kDir + "/pendulum.urdf");
  const int link = rod.linkIndex("rod");
  Isometry3d base = Isometry3d::Identity();
  base.translate(Vector3d(1.0, -2.0, 0.5));
  base.rotate(AngleAxisd(M_PI / 2, Vector3d::UnitX()));
  for (const double q : {0.0, 0.4, -2.5}) {
    SCOPED_TRACE("q = " + std::to_string(q));
    rod.setState(VectorXd::Constant(1, q), VectorXd::Constant(1, 3.0), base);
    const collision_response::core::BodyState body = rb::linkBody(rod, link, "pendulum/rod");
    EXPECT_EQ(body.id, "pendulum/rod");
    EXPECT_TRUE(body.position.isApprox(Vector3d(1.0, -2.0, 0.5), 1e-15));
    const Matrix3d expected = AngleAxisd(M_PI / 2, Vector3d::UnitX()).toRotationMatrix() *
                              AngleAxisd(q, Vector3d::UnitZ()).toRotationMatrix();
    EXPECT_TRUE(body.orientation.toRotationMatrix().isApprox(expected, 1e-14));
    // The rod's tip (1, 0, 0) in the link frame: in the world by the closed form.
    const Vector3d tip = base.translation() + expected * Vector3d::UnitX();
    EXPECT_TRUE((body.position + body.orientation * Vector3d::UnitX()).isApprox(tip, 1e-14));
    EXPECT_EQ(body.mass, 1.0);
    EXPECT_TRUE(body.inertia.isApprox(Matrix3d::Identity()));
    EXPECT_TRUE(body.linear_velocity.isZero(0.0));
    EXPECT_TRUE(body.angular_velocity.isZero(0.0));
  }
}
