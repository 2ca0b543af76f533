// Resting contacts of robots (docs/robots.md, "Resting contacts"): computeBodyResponse() on an
// island where nothing approaches gives the contact forces of the force-based Coulomb model from
// each body's free acceleration: a robot's M^-1 (tau - C qdot - g) through its Jacobians and
// J-dot qdot, a rigid body's wrench. References derived here by hand: a pendulum's lever statics,
// the planar 2R arm's textbook dynamics (test/support/two_link_arm.h), the composite rigid body of
// a locked floating robot (against the rigid resting analysis), an arm whose torques push on a
// table with a given force, and a box weighing on an arm.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "collision_response/core/body_response.h"
#include "collision_response/core/compute_response.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/robot/articulated_body.h"
#include "collision_response/robot/urdf_loader.h"
#include "two_link_arm.h"

namespace cr = collision_response::core;
namespace rb = collision_response::robot;
using Eigen::Matrix2d;
using Eigen::Matrix3d;
using Eigen::Vector2d;
using Eigen::Vector3d;
using Eigen::VectorXd;

namespace {

const std::string kDir = ROBOT_TEST_DIR;
const std::string kArm7 = ARM7_URDF;  // the shipped arm, urdf/arm7.urdf
constexpr double kG = 9.81;

Vector3d in3d(const Vector2d& v) {
  return Vector3d(v.x(), v.y(), 0.0);
}

}  // namespace

// pendulum.urdf (m = 2 kg, L = 1 m, hinge about z) lies along x; gravity along -y; a support (an
// immovable body) holds the point (d, 0, 0) from below, n = +y. The rod cannot move but about the
// hinge, so the support carries the weight's moment: F d = m g L / 2 - tau, F = (9.81 - tau) / d
// [N] for a hinge torque tau [N m] (lever statics; the rod's inertia drops out). Gravity
// compensation (tau = g(q) = m g L / 2 = 9.81 N m) leaves nothing for the support; a torque
// beyond it lifts the rod off (no force). Friction changes nothing: the rod cannot slide along
// the support (W is singular there: least-norm forces, tangential part 0).
TEST(RobotResting, PendulumOnASupportCarriesTheWeightByTheLever) {
  rb::ArticulatedBody rod = rb::robotFromUrdfFile(kDir + "/pendulum.urdf");
  rod.setState(VectorXd::Zero(1), VectorXd::Zero(1));
  rod.setLoads(VectorXd::Zero(1), Vector3d(0, -kG, 0));
  ASSERT_NEAR(rod.gravityTorques()(0), 2.0 * kG * 0.5, 1e-12);
  cr::RigidBody support;
  for (const double d : {0.5, 0.75, 1.0}) {
    for (const double mu : {0.0, 0.6}) {
      for (const double tau : {0.0, 3.0, kG, 20.0}) {
        rod.setLoads(VectorXd::Constant(1, tau), Vector3d(0, -kG, 0));
        cr::ContactPoint contact(0, 1, Vector3d(d, 0, 0), Vector3d::UnitY(), 0.0, mu, mu);
        contact.part_b = rod.linkIndex("rod");
        const cr::BodyResponse out = cr::computeBodyResponse({&support, &rod}, {contact});
        const cr::ContactImpulse& c = out.impulses[0];
        ASSERT_EQ(out.islands.size(), 1u);
        EXPECT_EQ(out.islands[0].method, cr::SolvedBy::kRestingClosedForm);
        EXPECT_TRUE(c.resting);
        EXPECT_EQ(c.normal_impulse, 0.0);
        const double want = std::max(0.0, (kG - tau) / d);
        EXPECT_NEAR(c.normal_force, want, 1e-12) << "d " << d << ", mu " << mu << ", tau " << tau;
        EXPECT_LE(c.friction_force.norm(), 1e-12);
        // Resting forces change no velocity.
        EXPECT_EQ(rod.jointVelocities()(0), 0.0);
        // Statics about the hinge: the actuator and the support hold the weight's moment.
        const Vector3d on_rod = c.normal_force * Vector3d::UnitY() + c.friction_force;
        const double support_torque =
            rod.jointTorquesOf(rod.linkIndex("rod"), contact.point, on_rod)(0);
        if (tau <= kG) {
          EXPECT_NEAR(tau + support_torque, kG, 1e-12);
        }
      }
    }
  }
}

// The 2R arm of two_link.urdf, moving (q = (0.4, -0.9) rad, qdot = (1.2, -0.5) rad/s), gravity
// along -y, its tip sliding along an immovable surface (n perpendicular to the tip's velocity, so
// u_n = 0, and pointing so that the free acceleration presses the tip into it). Textbook dynamics:
// qddot_free = M^-1 (tau - C qdot - g), the tip's free acceleration a = J qddot_free + J-dot qdot,
// W = J M^-1 J^T (2 x 2, in the plane). Frictionless: F_n = -n.a / (n^T W n). Sliding with mu_d
// (slip s along the tip's velocity): F = F_n (n - mu_d s), F_n = -n.a / (n^T W (n - mu_d s)).
TEST(RobotResting, TwoLinkTipSlidingOnASurfaceTextbookDynamics) {
  const double q1 = 0.4, q2 = -0.9;
  const Vector2d qdot(1.2, -0.5);
  for (const Vector2d& tau : {Vector2d(0, 0), Vector2d(4.0, -1.5)}) {
    const Matrix2d M = two_link::massMatrix(q2);
    const Matrix2d J = two_link::tipJacobian(q1, q2);
    const Vector2d qddot =
        M.inverse() * (tau - two_link::coriolis(q2, qdot) - two_link::gravity(q1, q2, kG));
    const Vector2d a = J * qddot + two_link::tipVelocityProduct(q1, q2, qdot);
    const Vector2d s = (J * qdot).normalized();
    Vector2d n(-s.y(), s.x());
    if (n.dot(a) > 0) n = -n;  // the surface is on the side the tip is pushed to
    const Matrix2d W = J * M.inverse() * J.transpose();

    rb::ArticulatedBody arm = rb::robotFromUrdfFile(kDir + "/two_link.urdf");
    arm.setState(Vector2d(q1, q2), qdot);
    arm.setLoads(tau, Vector3d(0, -kG, 0));
    cr::RigidBody surface;
    for (const double mu : {0.0, 0.3}) {
      const Vector2d direction = n - mu * s;
      const double f_n = -n.dot(a) / n.dot(W * direction);
      ASSERT_GT(f_n, 0.0);
      cr::ContactPoint contact(0, 1, in3d(two_link::tip(q1, q2)), in3d(n), 0.0, mu, mu);
      contact.part_b = arm.linkIndex("fore");
      const cr::BodyResponse out = cr::computeBodyResponse({&surface, &arm}, {contact});
      const cr::ContactImpulse& c = out.impulses[0];
      EXPECT_NEAR(c.normal_velocity_before, 0.0, 1e-15);
      EXPECT_TRUE(c.resting);
      EXPECT_NEAR(c.normal_force, f_n, 1e-11 * f_n) << "tau " << tau.transpose() << ", mu " << mu;
      EXPECT_LE((c.friction_force - in3d(-mu * f_n * s)).norm(), 1e-11 * f_n);
      EXPECT_FALSE(c.sticking);
    }
  }
}

// Both joints of the 2R arm locked on a floating base: the robot is one rigid body (mass 3 kg,
// centre of mass and inertia of two_link::composite()), spinning (w not along a principal axis:
// gyroscopic terms) under gravity along an oblique direction, touching an immovable surface at a
// point of its forearm whose velocity the surface's normal is perpendicular to, sliding with
// friction. Its base accelerates as the composite body does, and its contact force equals the
// rigid resting analysis of that composite body with the weight m g as its wrench
// (computeResponse(), an independent path) to 1e-12.
TEST(RobotResting, LockedFloatingRobotRestsAsItsCompositeRigidBody) {
  const double q1 = 0.3, q2 = 0.7;
  const Vector3d v_o(0.2, -0.1, 0.05), w(0.4, 0.9, -0.6);  // base twist
  const Vector3d g(0.8, -2.0, -9.5);
  rb::ArticulatedBody arm = rb::robotFromUrdfFile(kDir + "/two_link.urdf", rb::BaseType::kFloating);
  for (int j = 0; j < 2; ++j) arm.setJointModel(j, rb::JointModel::kLocked);
  arm.setState(Vector2d(q1, q2), Vector2d::Zero(), Eigen::Isometry3d::Identity(), v_o, w);
  arm.setLoads(Vector2d::Zero(), g);
  const two_link::Composite body = two_link::composite(q1, q2);
  // The base's unknowns accelerate as the composite body's point at the base origin o = 0:
  // alpha = -I^-1 (w x I w) (no torque about the centre of mass), a_o = g + alpha x (o - c) +
  // w x (w x (o - c)).
  const Vector3d alpha = -body.inertia.inverse() * w.cross(body.inertia * w);
  const Vector3d r = -body.com;
  const VectorXd base_acceleration = arm.freeAcceleration();
  ASSERT_EQ(base_acceleration.size(), 6);
  EXPECT_LE((base_acceleration.head<3>() - (g + alpha.cross(r) + w.cross(w.cross(r)))).norm(),
            1e-12);
  EXPECT_LE((base_acceleration.tail<3>() - alpha).norm(), 1e-12);

  cr::Scene scene;
  cr::BodyState surface;
  surface.id = "surface";
  cr::BodyState rigid;
  rigid.id = "robot";
  rigid.mass = body.mass;
  rigid.inertia = body.inertia;  // world axes: orientation identity
  rigid.com = Vector3d::Zero();
  rigid.position = body.com;
  rigid.linear_velocity = v_o + w.cross(body.com);
  rigid.angular_velocity = w;
  rigid.force = body.mass * g;
  scene.bodies = {surface, rigid};

  const Vector3d p = Eigen::AngleAxisd(q1, Vector3d::UnitZ()) * Vector3d(two_link::l1, 0, 0) +
                     Eigen::AngleAxisd(q1 + q2, Vector3d::UnitZ()) * Vector3d(0.6, 0.05, 0.02);
  const Vector3d v_p = rigid.linear_velocity + w.cross(p - body.com);
  for (const Vector3d& side : {Vector3d(0, 0, 1), Vector3d(1, 0, 0)}) {
    Vector3d n = v_p.cross(side).normalized();
    for (const double mu : {0.0, 0.5}) {
      cr::Contact contact;
      contact.body_a = "surface";
      contact.body_b = "robot";
      contact.point = p;
      contact.normal = n;
      contact.static_friction = contact.dynamic_friction = mu;
      scene.contacts = {contact};
      cr::CollisionResult rigid_answer = cr::computeResponse(scene);
      if (rigid_answer.impulses[0].normal_force == 0.0) {
        n = -n;  // press the body into the surface
        scene.contacts[0].normal = n;
        rigid_answer = cr::computeResponse(scene);
      }
      const cr::ContactImpulse& want = rigid_answer.impulses[0];
      ASSERT_TRUE(want.resting);
      ASSERT_GT(want.normal_force, 1.0);

      cr::RigidBody immovable;
      cr::ContactPoint point(0, 1, p, n, 0.0, mu, mu);
      point.part_b = arm.linkIndex("fore");
      const cr::BodyResponse out = cr::computeBodyResponse({&immovable, &arm}, {point});
      const cr::ContactImpulse& got = out.impulses[0];
      EXPECT_TRUE(got.resting);
      EXPECT_NEAR(got.normal_force, want.normal_force, 1e-12 * want.normal_force)
          << "mu " << mu << ", n " << n.transpose();
      EXPECT_LE((got.friction_force - want.friction_force).norm(), 1e-12 * want.normal_force);
    }
  }
}

// The 7-DOF arm at rest (fixed base, gravity -z), its hand on a table (n = +z from the table into
// the hand, friction). Its actuators apply the torques of a push F0 = 20 N into the table on top of
// gravity compensation, tau = g(q) - J(p)^T n F0: in equilibrium the table pushes back with exactly
// F0 along n (statics: M qddot = tau - g + J^T F = 0), no friction needed (sticking). With gravity
// compensation alone the hand rests on the table without pressing: no force.
TEST(RobotResting, ArmPushingOnATableFeelsItsOwnPush) {
  rb::ArticulatedBody arm = rb::robotFromUrdfFile(kArm7);
  VectorXd q(9);
  q << 0.3, 0.8, -0.2, -1.4, 0.1, 1.0, 0.4, 0.02, 0.02;
  arm.setState(q, VectorXd::Zero(9));
  const int hand = arm.linkIndex("hand");
  const Vector3d p = arm.linkPose(hand) * Vector3d(0.0, 0.0, 0.03);
  const Vector3d n = Vector3d::UnitZ();
  const Vector3d g(0, 0, -kG);
  arm.setLoads(VectorXd::Zero(9), g);
  const VectorXd compensation = arm.gravityTorques();
  const double f0 = 20.0;
  cr::RigidBody table;
  cr::ContactPoint contact(0, 1, p, n, 0.0, 0.5, 0.5);
  contact.part_b = hand;

  arm.setLoads(compensation - arm.linkPointJacobian(hand, p).transpose() * n * f0, g);
  cr::BodyResponse out = cr::computeBodyResponse({&table, &arm}, {contact});
  EXPECT_TRUE(out.impulses[0].resting);
  EXPECT_NEAR(out.impulses[0].normal_force, f0, 1e-9);
  EXPECT_LE(out.impulses[0].friction_force.norm(), 1e-9);
  EXPECT_TRUE(out.impulses[0].sticking);

  arm.setLoads(compensation, g);
  out = cr::computeBodyResponse({&table, &arm}, {contact});
  EXPECT_TRUE(out.impulses[0].resting);
  EXPECT_LE(out.impulses[0].normal_force, 1e-9);
}

// A 1.5 kg box (wrench: its weight) resting on the arm's hand, n = +z from the hand into the box.
// Every joint locked: the arm is immovable and the box weighs m g = 14.715 N on it. Every joint
// free under gravity compensation, at rest: the hand yields. The box's free acceleration relative
// to the hand is a = (0, 0, -g), and the two bodies' W = W_box + W_arm: the box's
// I3 / m - [r]x I^-1 [r]x at its lever arm r (along n: only its mass along n), the arm's
// J M^-1 J^T from its M(q) and Jacobian (both checked against KDL in test_articulated_body).
// Frictionless: F = g / (n^T W n) along n. With friction enough to stick: F = -W^-1 a, all three
// components (W_arm couples the normal and the tangents).
TEST(RobotResting, BoxWeighsOnTheArmsHand) {
  rb::ArticulatedBody arm = rb::robotFromUrdfFile(kArm7);
  VectorXd q(9);
  q << -0.5, 0.6, 0.3, -1.2, -0.2, 1.3, 0.0, 0.02, 0.02;
  arm.setState(q, VectorXd::Zero(9));
  const int hand = arm.linkIndex("hand");
  const Vector3d p = arm.linkPose(hand) * Vector3d(0.0, 0.0, 0.03);
  const Vector3d n = Vector3d::UnitZ();
  const double m = 1.5;
  cr::BodyState box_state;
  box_state.id = "box";
  box_state.mass = m;
  box_state.inertia = Vector3d(0.01, 0.01, 0.015).asDiagonal();
  box_state.position = p + Vector3d(0, 0, 0.05);
  box_state.force = Vector3d(0, 0, -m * kG);
  cr::RigidBody box = cr::makeRigidBody(box_state);
  cr::setFreeAcceleration(box_state, box);

  rb::ArticulatedBody locked = arm;
  for (int j = 0; j < locked.jointCount(); ++j) locked.setJointModel(j, rb::JointModel::kLocked);
  locked.setState(q, VectorXd::Zero(9));
  arm.setGravityCompensation(Vector3d(0, 0, -kG));
  const auto J = arm.linkPointJacobian(hand, p);
  // The box's point at lever arm r = (0, 0, -0.05) m from its centre: I3 / m - [r]x I^-1 [r]x.
  const Vector3d r(0, 0, -0.05);
  Matrix3d r_cross;
  r_cross << 0, -r.z(), r.y(), r.z(), 0, -r.x(), -r.y(), r.x(), 0;
  const Matrix3d W_box = Matrix3d::Identity() / m - r_cross * box_state.inertia.inverse() * r_cross;
  const Matrix3d W = W_box + J * arm.massMatrix().inverse() * J.transpose();
  const Vector3d sticking = -W.inverse() * Vector3d(0, 0, -kG);
  ASSERT_LE(sticking.head<2>().norm(), 0.4 * sticking.z());
  for (const double mu : {0.0, 0.4}) {
    cr::ContactPoint contact(0, 1, p, n, 0.0, mu, mu);
    contact.part_a = hand;
    cr::BodyResponse out = cr::computeBodyResponse({&locked, &box}, {contact});
    EXPECT_NEAR(out.impulses[0].normal_force, m * kG, 1e-12);
    EXPECT_LE(out.impulses[0].friction_force.norm(), 1e-12);

    out = cr::computeBodyResponse({&arm, &box}, {contact});
    const cr::ContactImpulse& c = out.impulses[0];
    EXPECT_TRUE(c.resting);
    EXPECT_LT(c.normal_force, m * kG);  // the hand gives way
    if (mu == 0.0) {
      EXPECT_NEAR(c.normal_force, kG / n.dot(W * n), 1e-10);
      EXPECT_LE(c.friction_force.norm(), 1e-12);
    } else {
      EXPECT_TRUE(c.sticking);
      EXPECT_NEAR(c.normal_force, sticking.z(), 1e-10);
      EXPECT_LE((c.friction_force - Vector3d(sticking.x(), sticking.y(), 0)).norm(), 1e-10);
    }
  }
}

// --- The band mu_d N < |L| <= mu_s N for robots (issue 22; docs/physics.md, "Resting contacts"):
// robots go through the same resting solve as rigid bodies, and static friction must hold them
// there too.
//
// The 2R arm on a floating base, both joints locked (q = (0.3, 0.7) rad): one rigid body of 3 kg
// (two_link::composite()), lying on a table (n = +z) on four points of its links (feet 0.3 m to
// either side of each link's axis, 0.1 m along the upper link and 0.6 m along the forearm, 0.02 m
// below the centre of mass, which they surround with 0.18 m to spare: it cannot tip), the table
// inclined by turning gravity: g = 9.81 (sin theta cos phi, sin theta sin phi, -cos theta).
// One-body closed form (Newton's second law for the composite body, by hand): N = m g cos theta,
// the tangential load m g sin theta; with mu_s = 0.6 and mu_d = 0.3 it sticks while
// tan theta <= 0.6 (a = 0, alpha = 0), otherwise it slides down the slope with
// a = g (sin theta - mu_d cos theta), not turning. Each checked on the acceleration the reported
// forces give the composite body: a = g + sum F_i / m, I alpha = sum (p_i - c) x F_i.
// theta = 10 degrees (tan 0.176, below mu_d), 25 (0.466, in the band: must stick), 35 (0.700,
// above mu_s: slides with a = 9.81 (0.5736 - 0.3 x 0.8192) = 3.216 m/s^2).
TEST(RobotRestingBand, LockedFloatingArmOnAnInclinedTableSticksInTheBand) {
  const double q1 = 0.3, q2 = 0.7, mu_s = 0.6, mu_d = 0.3;
  const two_link::Composite body = two_link::composite(q1, q2);
  rb::ArticulatedBody arm = rb::robotFromUrdfFile(kDir + "/two_link.urdf", rb::BaseType::kFloating);
  for (int j = 0; j < 2; ++j) arm.setJointModel(j, rb::JointModel::kLocked);
  arm.setState(Vector2d(q1, q2), Vector2d::Zero(), Eigen::Isometry3d::Identity(), Vector3d::Zero(),
               Vector3d::Zero());
  const int upper = arm.linkIndex("upper"), fore = arm.linkIndex("fore");
  const std::vector<std::pair<int, Vector3d>> points = {{upper, Vector3d(0.1, 0.3, -0.02)},
                                                        {upper, Vector3d(0.1, -0.3, -0.02)},
                                                        {fore, Vector3d(0.6, -0.3, -0.02)},
                                                        {fore, Vector3d(0.6, 0.3, -0.02)}};
  cr::RigidBody table;
  std::vector<cr::ContactPoint> contacts;
  for (const auto& [link, local] : points) {
    cr::ContactPoint contact(0, 1, arm.linkPose(link) * local, Vector3d::UnitZ(), 0.0, mu_s, mu_d);
    contact.part_b = link;
    contacts.push_back(contact);
  }
  cr::SolverOptions options;
  options.tolerance = 1e-14;
  for (const double theta_deg : {10.0, 25.0, 35.0}) {
    for (const double phi : {0.0, 1.0, 2.5, 4.0}) {
      const double theta = theta_deg * M_PI / 180.0;
      const Vector3d down_slope(std::cos(phi), std::sin(phi), 0.0);
      const Vector3d g = kG * (std::sin(theta) * down_slope - std::cos(theta) * Vector3d::UnitZ());
      const bool stick = std::tan(theta) <= mu_s;
      const Vector3d want =
          stick ? Vector3d::Zero()
                : Vector3d(kG * (std::sin(theta) - mu_d * std::cos(theta)) * down_slope);
      arm.setLoads(Vector2d::Zero(), g);
      const cr::BodyResponse out = cr::computeBodyResponse({&table, &arm}, contacts, options);
      SCOPED_TRACE("theta " + std::to_string(theta_deg) + " deg, phi " + std::to_string(phi));
      ASSERT_EQ(out.islands.size(), 1u);
      ASSERT_TRUE(out.islands[0].converged);
      EXPECT_EQ(out.islands[0].method, cr::SolvedBy::kRestingIterative);
      Vector3d total = Vector3d::Zero(), moment = Vector3d::Zero();
      for (std::size_t i = 0; i < contacts.size(); ++i) {
        const cr::ContactImpulse& c = out.impulses[i];
        const Vector3d force = c.normal_force * Vector3d::UnitZ() + c.friction_force;
        total += force;
        moment += (contacts[i].point - body.com).cross(force);
        EXPECT_TRUE(c.resting);
        EXPECT_EQ(c.sticking, stick) << "point " << i;
        if (stick) {
          EXPECT_LE(c.friction_force.norm(), mu_s * c.normal_force * (1.0 + 1e-9) + 1e-12);
        } else {
          EXPECT_NEAR(c.friction_force.norm(), mu_d * c.normal_force, 1e-9 * kG);
        }
      }
      const Vector3d a = g + total / body.mass;
      EXPECT_LE((a - want).norm(), 1e-9 * kG)
          << "a " << a.transpose() << ", closed form " << want.transpose();
      EXPECT_LE((body.inertia.inverse() * moment).norm(), 1e-8 * kG) << "the body turns";
    }
  }
}

// The shipped arm (fixed base, at rest, gravity -z) presses its hand on a table at two points
// 0.09 m apart (mu_s = 0.6, mu_d = 0.3), its actuators applying gravity compensation and the
// torques of the forces f = F (n + k t) at each point, tau = g(q) - sum J_k^T f, for F = 15 N,
// k = 0.2 (below mu_d), 0.45 and 0.58 (in the band), t a horizontal direction. Statics (by hand:
// M qddot = tau - g + sum J_k^T f_k = 0): the forces f hold the arm still and lie in the static
// cones, so it must stick, the table pushing back with sum f_k = 2 F (n + k t) (the split between
// the points is not unique: a squeeze along the line between them changes nothing; the total is:
// the hand's 6 x 7 Jacobian has full rank here).
TEST(RobotRestingBand, ArmPressingSidewaysOnATableSticksInTheBand) {
  rb::ArticulatedBody arm = rb::robotFromUrdfFile(kArm7);
  VectorXd q(9);
  q << 0.3, 0.8, -0.2, -1.4, 0.1, 1.0, 0.4, 0.02, 0.02;
  arm.setState(q, VectorXd::Zero(9));
  const int hand = arm.linkIndex("hand");
  const Vector3d n = Vector3d::UnitZ();
  const Vector3d g(0, 0, -kG);
  arm.setLoads(VectorXd::Zero(9), g);
  const VectorXd compensation = arm.gravityTorques();
  const double F = 15.0, mu_s = 0.6, mu_d = 0.3;
  cr::RigidBody table;
  std::vector<cr::ContactPoint> contacts;
  std::vector<Vector3d> points;
  const Vector3d centre = arm.linkPose(hand) * Vector3d(0.0, 0.0, 0.03);
  for (const double side : {-0.04, 0.04}) {
    points.push_back(centre + Vector3d(side, side * 0.5, 0.0));
    cr::ContactPoint contact(0, 1, points.back(), n, 0.0, mu_s, mu_d);
    contact.part_b = hand;
    contacts.push_back(contact);
  }
  cr::SolverOptions options;
  options.tolerance = 1e-14;
  for (const double k : {0.2, 0.45, 0.58}) {
    for (const double angle : {0.0, 1.2, 2.4, 3.6, 4.8}) {
      const Vector3d t(std::cos(angle), std::sin(angle), 0.0);
      const Vector3d f = F * (n + k * t);
      VectorXd tau = compensation;
      for (const Vector3d& p : points) tau -= arm.linkPointJacobian(hand, p).transpose() * f;
      arm.setLoads(tau, g);
      const cr::BodyResponse out = cr::computeBodyResponse({&table, &arm}, contacts, options);
      SCOPED_TRACE("k " + std::to_string(k) + ", angle " + std::to_string(angle));
      ASSERT_TRUE(out.islands[0].converged);
      Vector3d total = Vector3d::Zero();
      for (const cr::ContactImpulse& c : out.impulses) {
        EXPECT_TRUE(c.resting);
        EXPECT_TRUE(c.sticking);
        EXPECT_LE(c.friction_force.norm(), mu_s * c.normal_force * (1.0 + 1e-9) + 1e-12);
        total += c.normal_force * n + c.friction_force;
      }
      EXPECT_LE((total - 2.0 * f).norm(), 1e-8 * F)
          << "table force " << total.transpose() << ", statics " << (2.0 * f).transpose();
    }
  }
}
