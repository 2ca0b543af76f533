// Robots in impacts (docs/robots.md): computeBodyResponse() with ArticulatedBody bodies against
// closed forms derived here by hand: a pendulum struck by a free sphere (every law), a planar 2R
// arm's tip impact, every joint locked (immovable / composite rigid body), a floating robot
// striking a free body (momentum, energy, no contact left approaching), armature, and two links of
// one robot striking each other.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "collision_response/core/body_response.h"
#include "collision_response/core/errors.h"
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

// A free solid sphere of mass ms and radius R, centre c, velocity v: I = 2/5 ms R^2.
cr::RigidBody sphere(double ms, double R, const Vector3d& c, const Vector3d& v) {
  cr::RigidBody out;
  out.inverse_mass = 1.0 / ms;
  out.inverse_inertia = Matrix3d::Identity() / (0.4 * ms * R * R);
  out.com = c;
  out.linear_velocity = v;
  return out;
}

cr::SolverOptions withLaw(cr::ImpactLaw law) {
  cr::SolverOptions options;
  options.law = law;
  return options;
}

}  // namespace

// The pendulum of pendulum.urdf (m = 2 kg, L = 1 m, I_hinge = m L^2 / 3 = 2/3 kg m^2) at rest
// along x, struck at p = (d, 0, 0), d = 0.75 m, by a sphere (ms = 0.5 kg, R = 0.1 m, centre
// (d, -R, 0)) moving at V = 3 m/s along +y. Contact: a = sphere, b = rod, n = +y, e = 0.6.
// u_n = n.(0 - V y) = -3 m/s. The rod's point moves only along y: J = (0, d, 0), its part of
// n^T W n is d^2 / I_hinge: effective mass of the rod I_hinge / d^2 = (2/3) / 0.5625 = 1.18519 kg.
// The sphere's lever arm (0, R, 0) is along n: its part is 1 / ms. So
//   P = (1 + e) V / (1 / ms + d^2 / I_hinge) = 1.6 x 3 / (2 + 0.84375) = 1.687912... N s,
//   w' = d P / I_hinge = 1.898901... rad/s,  v_sphere' = V - P / ms = -0.375824... m/s,
// and u_n' = d w' - v' = 1.8 = -e u_n. Frictionless and central: Newton, Poisson, Stronge agree.
TEST(RobotImpacts, PendulumStruckBySphereEveryLaw) {
  const double d = 0.75, V = 3.0, e = 0.6, ms = 0.5, R = 0.1, I_hinge = 2.0 / 3.0;
  const double P = (1 + e) * V / (1 / ms + d * d / I_hinge);
  for (const cr::ImpactLaw law :
       {cr::ImpactLaw::kNewton, cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    SCOPED_TRACE(cr::toString(law));
    rb::ArticulatedBody rod = rb::robotFromUrdfFile(kDir + "/pendulum.urdf");
    cr::RigidBody ball = sphere(ms, R, Vector3d(d, -R, 0), Vector3d(0, V, 0));
    cr::ContactPoint contact(0, 1, Vector3d(d, 0, 0), Vector3d::UnitY(), e, 0.0, 0.0);
    contact.part_b = rod.linkIndex("rod");
    const cr::BodyResponse out = cr::computeBodyResponse({&ball, &rod}, {contact}, withLaw(law));
    EXPECT_NEAR(out.effective_masses[0], 1.0 / (1 / ms + d * d / I_hinge), 1e-12);
    EXPECT_NEAR(out.impulses[0].normal_impulse, P, 1e-9);
    EXPECT_NEAR(rod.jointVelocities()(0), d * P / I_hinge, 1e-9);
    EXPECT_NEAR(ball.linear_velocity.y(), V - P / ms, 1e-9);
    EXPECT_NEAR(out.impulses[0].normal_velocity_after, e * V, 1e-9);
    // The generalized impulse of the joint is J^T P = d P [N m s].
    EXPECT_NEAR(rod.generalizedImpulse(VectorXd::Constant(1, d * P / I_hinge))(0), d * P, 1e-9);
  }
}

// The same rod struck by an immovable bat moving at V along +y (no tangential motion), now with
// friction mu = 0.8. The rod's W = d^2 / I_hinge y y^T is singular (the point cannot move along
// x or z): any tangential impulse lies in W's null space and changes nothing, and the answer is
// the least-norm one, no friction at all. P = (1 + e) V I_hinge / d^2 along n,
// w' = d P / I_hinge = (1 + e) V / d (the contact point leaves at e V faster than the bat).
TEST(RobotImpacts, PendulumWithFrictionIsTheSingularLeastNormCase) {
  const double d = 0.75, V = 3.0, e = 0.6, I_hinge = 2.0 / 3.0;
  for (const cr::ImpactLaw law :
       {cr::ImpactLaw::kNewton, cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    SCOPED_TRACE(cr::toString(law));
    rb::ArticulatedBody rod = rb::robotFromUrdfFile(kDir + "/pendulum.urdf");
    cr::RigidBody bat;  // immovable, prescribed velocity
    bat.com = Vector3d(d, -0.2, 0);
    bat.linear_velocity = Vector3d(0, V, 0);
    cr::ContactPoint contact(0, 1, Vector3d(d, 0, 0), Vector3d::UnitY(), e, 0.8, 0.8);
    contact.part_b = 1;
    const cr::BodyResponse out = cr::computeBodyResponse({&bat, &rod}, {contact}, withLaw(law));
    EXPECT_NEAR(out.effective_masses[0], I_hinge / (d * d), 1e-12);
    EXPECT_NEAR(out.impulses[0].normal_impulse, (1 + e) * V * I_hinge / (d * d), 1e-9);
    EXPECT_NEAR(out.impulses[0].friction_impulse.norm(), 0.0, 1e-9);
    EXPECT_NEAR(rod.jointVelocities()(0), (1 + e) * V / d, 1e-9);
  }
}

// The 2R arm of two_link.urdf at q = (0.4, 1.1), qdot = (0.5, -0.3), its tip (the end of link 2)
// against an immovable wall with normal n (from the wall to the arm), frictionless, e = 0.5.
// Closed form, independent of the code: tip position x = l1 (c1, s1) + l2 (c12, s12), Jacobian
//   J = [ -l1 s1 - l2 s12   -l2 s12 ]
//       [  l1 c1 + l2 c12    l2 c12 ]
// M(q) from the textbook (test_articulated_body.cpp). u_n = n.J qdot; the impulse along n is
// P = -(1 + e) u_n / (n^T J M^-1 J^T n), and dq = M^-1 J^T n P.
TEST(RobotImpacts, TwoLinkTipImpactClosedForm) {
  const double l1 = 1.0, l2 = 0.8;
  const double q1 = 0.4, q2 = 1.1, e = 0.5;
  const Vector2d qdot(0.5, -0.3);
  const Matrix2d M = two_link::massMatrix(q2);
  Matrix2d J;
  J << -l1 * std::sin(q1) - l2 * std::sin(q1 + q2), -l2 * std::sin(q1 + q2),
      l1 * std::cos(q1) + l2 * std::cos(q1 + q2), l2 * std::cos(q1 + q2);
  const Vector2d tip(l1 * std::cos(q1) + l2 * std::cos(q1 + q2),
                     l1 * std::sin(q1) + l2 * std::sin(q1 + q2));
  // A wall the tip runs into: n against the tip's velocity.
  const Vector2d n2 = -(J * qdot).normalized();
  const double u_n = n2.dot(J * qdot);
  const Vector2d Jtn = J.transpose() * n2;
  const double P = -(1 + e) * u_n / Jtn.dot(M.inverse() * Jtn);
  const Vector2d qdot_after = qdot + M.inverse() * Jtn * P;

  rb::ArticulatedBody arm = rb::robotFromUrdfFile(kDir + "/two_link.urdf");
  arm.setState(Vector2d(q1, q2), qdot);
  cr::RigidBody wall;
  cr::ContactPoint contact(0, 1, Vector3d(tip.x(), tip.y(), 0), Vector3d(n2.x(), n2.y(), 0), e, 0.0,
                           0.0);
  contact.part_b = arm.linkIndex("fore");
  const VectorXd before = arm.jointVelocities();
  const cr::BodyResponse out = cr::computeBodyResponse({&wall, &arm}, {contact});
  EXPECT_NEAR(out.impulses[0].normal_velocity_before, u_n, 1e-12);
  EXPECT_NEAR(out.impulses[0].normal_impulse, P, 1e-12);
  EXPECT_NEAR(out.effective_masses[0], 1.0 / Jtn.dot(M.inverse() * Jtn), 1e-12);
  EXPECT_LE((arm.jointVelocities() - qdot_after).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_NEAR(out.impulses[0].normal_velocity_after, -e * u_n, 1e-12);
  // Generalized impulse J^T n P per joint [N m s].
  EXPECT_LE(
      (arm.generalizedImpulse(arm.jointVelocities() - before) - Jtn * P).cwiseAbs().maxCoeff(),
      1e-12);
}

// Every joint locked, fixed base: the arm has no unknowns and acts as an immovable body (here at
// rest): a sphere struck centrally leaves at -e times its normal velocity.
TEST(RobotImpacts, LockedFixedRobotIsImmovable) {
  rb::ArticulatedBody arm = rb::robotFromUrdfFile(kArm7);
  for (int j = 0; j < arm.jointCount(); ++j) arm.setJointModel(j, rb::JointModel::kLocked);
  EXPECT_EQ(arm.velocityCount(), 0);
  const int hand = arm.linkIndex("hand");
  const Vector3d p = arm.linkPose(hand).translation();
  cr::RigidBody ball = sphere(0.3, 0.05, p + Vector3d(0.05, 0, 0), Vector3d(-2, 0, 0));
  cr::ContactPoint contact(0, 1, p, Vector3d::UnitX(), 0.7, 0.5, 0.5);
  contact.part_a = hand;
  const cr::BodyResponse out = cr::computeBodyResponse({&arm, &ball}, {contact});
  EXPECT_NEAR(ball.linear_velocity.x(), 1.4, 1e-12);
  EXPECT_NEAR(out.impulses[0].normal_impulse, 0.3 * 3.4, 1e-12);
  EXPECT_NEAR(out.effective_masses[0], 0.3, 1e-12);
}

// Every joint locked, floating base: the 2R arm moves as one rigid body with the composite mass
// m = m1 + m2 = 3 kg, centre of mass c = (m1 c1 + m2 c2) / m and inertia about c
//   I = sum_i ( R_i I_i R_i^T + m_i (|r_i|^2 1 - r_i r_i^T) ),  r_i = c_i - c,
// all computed here from the URDF's numbers. Struck off-centre by a sphere with friction, the
// robot's answer (base twist, converted to the velocity of c) equals that of a RigidBody with these
// properties, to 1e-12.
TEST(RobotImpacts, LockedFloatingRobotIsTheCompositeRigidBody) {
  const double q1 = 0.3, q2 = 0.7;
  const Vector3d v_o(0.2, -0.1, 0.05), w(0.1, 0.3, -0.2);  // base twist
  // The base link is massless and the shoulder turns about the base's z through its origin: with
  // both free, M is singular (the shoulder adds no motion the base does not give); locked, it is
  // not.
  rb::ArticulatedBody arm = rb::robotFromUrdfFile(kDir + "/two_link.urdf", rb::BaseType::kFloating);
  EXPECT_NE(arm.singularJoint().find("'shoulder'"), std::string::npos) << arm.singularJoint();
  for (int j = 0; j < 2; ++j) arm.setJointModel(j, rb::JointModel::kLocked);
  ASSERT_EQ(arm.velocityCount(), 6);

  // Composite body from the URDF numbers.
  const two_link::Composite composite = two_link::composite(q1, q2);
  const double m = composite.mass;
  const Vector3d c = composite.com;
  const Matrix3d I = composite.inertia;
  const Matrix3d R2 = Eigen::AngleAxisd(q1 + q2, Vector3d::UnitZ()).toRotationMatrix();
  const Vector3d c2 = R2 * Vector3d(two_link::lc2, 0, 0) +
                      Eigen::AngleAxisd(q1, Vector3d::UnitZ()) * Vector3d(two_link::l1, 0, 0);
  // Joint rates are kept (locked: they move with the parent), so the composite body is the robot
  // only when they are 0 as well: reset them.
  arm.setState(Vector2d(q1, q2), Vector2d::Zero(), Eigen::Isometry3d::Identity(), v_o, w);
  cr::RigidBody body;
  body.inverse_mass = 1 / m;
  body.inverse_inertia = I.inverse();
  body.com = c;
  body.linear_velocity = v_o + w.cross(c);
  body.angular_velocity = w;

  const Vector3d p = c2 + R2 * Vector3d(0.1, 0, 0);
  const auto strike = [&](cr::BodyModel& target) {
    cr::RigidBody ball = sphere(0.8, 0.05, p + Vector3d(0, 0.05, 0), Vector3d(0.5, -2, 0.3));
    cr::ContactPoint contact(0, 1, p, Vector3d::UnitY(), 0.5, 0.4, 0.3);
    contact.part_a = 2;  // "fore" for the robot; ignored by the rigid body
    cr::computeBodyResponse({&target, &ball}, {contact}, withLaw(cr::ImpactLaw::kNewton));
    return ball.linear_velocity;
  };
  const Vector3d ball_robot = strike(arm);
  const Vector3d ball_rigid = strike(body);
  EXPECT_LE((ball_robot - ball_rigid).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LE((arm.baseAngularVelocity() - body.angular_velocity).cwiseAbs().maxCoeff(), 1e-12);
  const Vector3d com_velocity = arm.baseLinearVelocity() + arm.baseAngularVelocity().cross(c);
  EXPECT_LE((com_velocity - body.linear_velocity).cwiseAbs().maxCoeff(), 1e-12);
}

// The 7-DOF arm on a floating base (the base link's 4 kg included), in a random state, strikes a
// free box with its hand and its forearm (two contacts, friction, Stronge). No external impulse:
// the total linear and angular momentum (about the world origin) are conserved to round-off; the
// kinetic energy does not increase; no contact is left approaching.
TEST(RobotImpacts, FloatingRobotStrikingAFreeBodyConservesMomentum) {
  rb::ArticulatedBody arm = rb::robotFromUrdfFile(kArm7, rb::BaseType::kFloating);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 10; ++trial) {
    VectorXd q(9), qdot(9);
    for (int i = 0; i < 9; ++i) {
      q(i) = 2 * u(rng);
      qdot(i) = u(rng);
    }
    q(7) = q(8) = 0.02;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = Eigen::AngleAxisd(u(rng), Vector3d(u(rng), u(rng), 1).normalized()).matrix();
    pose.translation() = Vector3d(u(rng), u(rng), u(rng));
    arm.setState(q, qdot, pose, Vector3d(u(rng), u(rng), u(rng)), Vector3d(u(rng), u(rng), u(rng)));
    const Vector3d hand = arm.linkPose(arm.linkIndex("hand")).translation();
    const Vector3d fore = arm.linkPose(arm.linkIndex("link5")).translation();
    // The box: 1.5 kg, 0.2 x 0.1 x 0.3 m, rotated; it approaches both points fast.
    cr::RigidBody box;
    const double mb = 1.5;
    const Matrix3d Rb = Eigen::AngleAxisd(0.4, Vector3d(1, 2, 3).normalized()).matrix();
    const Matrix3d Ib =
        Vector3d(mb * (0.01 + 0.09) / 12, mb * (0.04 + 0.09) / 12, mb * (0.04 + 0.01) / 12)
            .asDiagonal();
    box.inverse_mass = 1 / mb;
    box.inverse_inertia = Rb * Ib.inverse() * Rb.transpose();
    box.com = 0.5 * (hand + fore) + Vector3d(0.1, 0, 0);
    const Vector3d n = Vector3d(1, 0.2, -0.1).normalized();
    box.linear_velocity = -5.0 * n;
    box.angular_velocity = Vector3d(0.5, -0.2, 0.3);

    const auto momentum = [&] {
      Eigen::Matrix<double, 6, 1> total = arm.momentum();
      total.head<3>() += mb * box.linear_velocity;
      total.tail<3>() += box.com.cross(mb * box.linear_velocity) +
                         (box.inverse_inertia.inverse() * box.angular_velocity);
      return total;
    };
    const auto energy = [&] {
      return arm.kineticEnergy() + 0.5 * mb * box.linear_velocity.squaredNorm() +
             0.5 * box.angular_velocity.dot(box.inverse_inertia.inverse() * box.angular_velocity);
    };
    const Eigen::Matrix<double, 6, 1> before = momentum();
    const double energy_before = energy();
    std::vector<cr::ContactPoint> contacts = {cr::ContactPoint(0, 1, hand, n, 0.8, 0.6, 0.5),
                                              cr::ContactPoint(0, 1, fore, n, 0.8, 0.6, 0.5)};
    contacts[0].part_a = arm.linkIndex("hand");
    contacts[1].part_a = arm.linkIndex("link5");
    const cr::BodyResponse out =
        cr::computeBodyResponse({&arm, &box}, contacts, withLaw(cr::ImpactLaw::kStronge));
    ASSERT_GT(out.impulses[0].normal_impulse + out.impulses[1].normal_impulse, 0.0);
    const Eigen::Matrix<double, 6, 1> after = momentum();
    EXPECT_LE((after - before).cwiseAbs().maxCoeff(), 1e-12 * (1 + before.cwiseAbs().maxCoeff()))
        << "trial " << trial;
    EXPECT_LE(energy(), energy_before * (1 + 1e-12)) << "trial " << trial;
    for (const cr::ContactImpulse& impulse : out.impulses) {
      EXPECT_GE(impulse.normal_velocity_after, -1e-9) << "trial " << trial;
    }
  }
}

// Armature on the pendulum's joint: the joint's inertia is I_hinge + I_a, so the effective mass at
// d is (I_hinge + I_a) / d^2 and, struck by an immovable bat at V (e = 0.6), w' = (1 + e) V / d
// still (the bat imposes the point's velocity) but the impulse grows with the inertia:
// P = (1 + e) V (I_hinge + I_a) / d^2.
TEST(RobotImpacts, ArmatureAddsToTheJointInertia) {
  const double d = 0.75, V = 3.0, e = 0.6, I_hinge = 2.0 / 3.0, I_a = 0.3;
  rb::ArticulatedBody rod = rb::robotFromUrdfFile(kDir + "/pendulum.urdf");
  rod.setJointModel(0, rb::JointModel::kArmature, I_a);
  cr::RigidBody bat;
  bat.linear_velocity = Vector3d(0, V, 0);
  cr::ContactPoint contact(0, 1, Vector3d(d, 0, 0), Vector3d::UnitY(), e, 0.0, 0.0);
  contact.part_b = 1;
  const cr::BodyResponse out = cr::computeBodyResponse({&bat, &rod}, {contact});
  EXPECT_NEAR(out.effective_masses[0], (I_hinge + I_a) / (d * d), 1e-12);
  EXPECT_NEAR(out.impulses[0].normal_impulse, (1 + e) * V * (I_hinge + I_a) / (d * d), 1e-9);
  EXPECT_NEAR(rod.jointVelocities()(0), (1 + e) * V / d, 1e-9);
}

// Two links of one robot striking each other (twin_pendulums.urdf): rod_a, hinged at the origin
// along +x, turns at w_a = 4 rad/s, so its point p = (d, 0, 0), d = 0.75 m, moves at d w_a = 3 m/s
// along +y into rod_b (hinged at (1.5, 0, 0) along -x, at rest), whose point p is also d from its
// hinge. n = +y from rod_a to rod_b, e = 0.6, frictionless. rod_b's point moves as
// w_b z x (-d x) = -d w_b y. Each rod reflects I_hinge / d^2 along y, so
//   u_n = -d w_a = -3 m/s,  n^T W n = 2 d^2 / I_hinge,  P = (1 + e) 3 / (2 d^2 / I_hinge),
//   w_a' = w_a - d P / I_hinge,  w_b' = -d P / I_hinge,  u_n' = -e u_n.
// The joints are coupled only through the contact: W is the sum of the two rods' parts, which the
// robot's one M(q) must give through the cross terms of the two links' Jacobians.
TEST(RobotImpacts, TwoLinksOfOneRobotStrikeEachOther) {
  const double d = 0.75, w_a = 4.0, e = 0.6, I_hinge = 2.0 / 3.0;
  const double P = (1 + e) * d * w_a / (2 * d * d / I_hinge);
  for (const cr::ImpactLaw law :
       {cr::ImpactLaw::kNewton, cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    SCOPED_TRACE(cr::toString(law));
    rb::ArticulatedBody twins = rb::robotFromUrdfFile(kDir + "/twin_pendulums.urdf");
    twins.setState(VectorXd::Zero(2), (VectorXd(2) << w_a, 0.0).finished());
    cr::ContactPoint contact(0, 0, Vector3d(d, 0, 0), Vector3d::UnitY(), e, 0.0, 0.0);
    contact.part_a = twins.linkIndex("rod_a");
    contact.part_b = twins.linkIndex("rod_b");
    const cr::BodyResponse out = cr::computeBodyResponse({&twins}, {contact}, withLaw(law));
    EXPECT_NEAR(out.impulses[0].normal_velocity_before, -d * w_a, 1e-12);
    EXPECT_NEAR(out.effective_masses[0], I_hinge / (2 * d * d), 1e-12);
    EXPECT_NEAR(out.impulses[0].normal_impulse, P, 1e-9);
    EXPECT_NEAR(twins.jointVelocities()(twins.jointIndex("hinge_a")), w_a - d * P / I_hinge, 1e-9);
    EXPECT_NEAR(twins.jointVelocities()(twins.jointIndex("hinge_b")), -d * P / I_hinge, 1e-9);
    EXPECT_NEAR(out.impulses[0].normal_velocity_after, e * d * w_a, 1e-9);
  }
  // One link cannot strike itself, and a rigid body has no parts to do so.
  rb::ArticulatedBody twins = rb::robotFromUrdfFile(kDir + "/twin_pendulums.urdf");
  cr::ContactPoint self(0, 0, Vector3d(d, 0, 0), Vector3d::UnitY(), e, 0.0, 0.0);
  self.part_a = self.part_b = twins.linkIndex("rod_a");
  EXPECT_THROW(cr::computeBodyResponse({&twins}, {self}), cr::InvalidInput);
  cr::RigidBody ball = sphere(1.0, 0.1, Vector3d::Zero(), Vector3d::UnitX());
  cr::ContactPoint parts(0, 0, Vector3d(d, 0, 0), Vector3d::UnitY(), e, 0.0, 0.0);
  parts.part_a = 0;
  parts.part_b = 1;
  EXPECT_THROW(cr::computeBodyResponse({&ball}, {parts}), cr::InvalidInput);
}

// The 2R arm of two_link.urdf at q = (0.4, 1.1), qdot = (0.5, -0.3): a point p of link 2 ("fore")
// strikes link 1 ("upper") at the same world point, n (from upper to fore) in the plane,
// frictionless, e = 0.5. At one point the shoulder moves both links alike, so the relative
// velocity comes from the elbow alone: u = v_fore - v_upper = qdot_2 z x (p - o_elbow) = j qdot_2.
// So n^T W n = (M^-1)_22 (n.j)^2, P = -(1 + e) u_n / (n^T W n), dq = M^-1 (0, n.j) P: only the
// elbow's column of the Jacobians, which takes W's cross terms (-J_a M^-1 J_b^T - J_b M^-1 J_a^T)
// to get; without them W would be J_a M^-1 J_a^T + J_b M^-1 J_b^T.
TEST(RobotImpacts, TwoLinkSelfContactClosedForm) {
  const double l1 = 1.0;
  const double q1 = 0.4, q2 = 1.1, e = 0.5;
  const Vector2d qdot(0.5, -0.3);
  const Matrix2d M = two_link::massMatrix(q2);
  const Vector2d elbow(l1 * std::cos(q1), l1 * std::sin(q1));
  // p: 0.3 m along link 2 from the elbow, 0.05 m off its axis.
  const Vector2d along(std::cos(q1 + q2), std::sin(q1 + q2)), across(-along.y(), along.x());
  const Vector2d p = elbow + 0.3 * along + 0.05 * across;
  const Vector2d j(-(p - elbow).y(), (p - elbow).x());  // z x (p - o_elbow)
  const Vector2d n2 = -(j * qdot(1)).normalized();      // they approach
  const double u_n = n2.dot(j) * qdot(1);
  const Matrix2d Mi = M.inverse();
  const double w = Mi(1, 1) * n2.dot(j) * n2.dot(j);
  const double P = -(1 + e) * u_n / w;
  const Vector2d qdot_after = qdot + Mi.col(1) * n2.dot(j) * P;

  rb::ArticulatedBody arm = rb::robotFromUrdfFile(kDir + "/two_link.urdf");
  arm.setState(Vector2d(q1, q2), qdot);
  cr::ContactPoint contact(0, 0, Vector3d(p.x(), p.y(), 0), Vector3d(n2.x(), n2.y(), 0), e, 0.0,
                           0.0);
  contact.part_a = arm.linkIndex("upper");
  contact.part_b = arm.linkIndex("fore");
  const cr::BodyResponse out = cr::computeBodyResponse({&arm}, {contact});
  EXPECT_NEAR(out.impulses[0].normal_velocity_before, u_n, 1e-12);
  EXPECT_NEAR(out.effective_masses[0], 1.0 / w, 1e-12);
  EXPECT_NEAR(out.impulses[0].normal_impulse, P, 1e-12);
  EXPECT_LE((arm.jointVelocities() - qdot_after).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_NEAR(out.impulses[0].normal_velocity_after, -e * u_n, 1e-12);
}

// A floating robot whose hand strikes its own forearm (arm7, random states, friction, Stronge):
// an internal impulse pair changes neither the robot's linear nor its angular momentum (to
// round-off), gains no energy, and leaves the contact not approaching.
TEST(RobotImpacts, SelfContactOfAFloatingRobotConservesMomentum) {
  rb::ArticulatedBody arm = rb::robotFromUrdfFile(kArm7, rb::BaseType::kFloating);
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int struck = 0;
  for (int trial = 0; trial < 20; ++trial) {
    VectorXd q(9), qdot(9);
    for (int i = 0; i < 9; ++i) {
      q(i) = 2 * u(rng);
      qdot(i) = 2 * u(rng);
    }
    q(7) = q(8) = 0.02;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = Eigen::AngleAxisd(u(rng), Vector3d(u(rng), u(rng), 1).normalized()).matrix();
    arm.setState(q, qdot, pose, Vector3d(u(rng), u(rng), u(rng)), Vector3d(u(rng), u(rng), u(rng)));
    const int hand = arm.linkIndex("hand"), fore = arm.linkIndex("link3");
    const Vector3d p = 0.5 * (arm.linkPose(hand).translation() + arm.linkPose(fore).translation());
    // The normal against the relative velocity of the two links' points at p: they approach.
    const Vector3d relative = arm.partPointVelocity(fore, p) - arm.partPointVelocity(hand, p);
    if (relative.norm() < 1e-3) continue;
    const Vector3d n =
        (-relative.normalized() + 0.3 * Vector3d(u(rng), u(rng), u(rng))).normalized();
    if (n.dot(relative) >= -1e-3) continue;
    cr::ContactPoint contact(0, 0, p, n, 0.5, 0.6, 0.4);
    contact.part_a = hand;
    contact.part_b = fore;
    const Eigen::Matrix<double, 6, 1> before = arm.momentum();
    const double energy_before = arm.kineticEnergy();
    const cr::BodyResponse out =
        cr::computeBodyResponse({&arm}, {contact}, withLaw(cr::ImpactLaw::kStronge));
    ASSERT_GT(out.impulses[0].normal_impulse, 0.0) << "trial " << trial;
    ++struck;
    const Eigen::Matrix<double, 6, 1> after = arm.momentum();
    EXPECT_LE((after - before).cwiseAbs().maxCoeff(), 1e-12 * (1 + before.cwiseAbs().maxCoeff()))
        << "trial " << trial;
    EXPECT_LT(arm.kineticEnergy(), energy_before) << "trial " << trial;
    EXPECT_GE(out.impulses[0].normal_velocity_after, -1e-9) << "trial " << trial;
  }
  EXPECT_GE(struck, 15);
}

// A robot whose joint moves no mass (a massless rod) cannot answer M^-1 J^T: the call throws. The
// next call on the same thread (computeBodyResponse() reuses its contact problem) must give the
// pendulum's closed form of PendulumStruckBySphereEveryLaw, untouched by the failed build.
TEST(RobotImpacts, AFailedBuildLeavesNoTraceInTheNextCall) {
  const std::string massless = R"(<robot name="massless">
    <link name="base"/>
    <joint name="hinge" type="continuous"><parent link="base"/><child link="rod"/>
      <axis xyz="0 0 1"/></joint>
    <link name="rod"/>
  </robot>)";
  const double d = 0.75, V = 3.0, e = 0.6, ms = 0.5, R = 0.1, I_hinge = 2.0 / 3.0;
  {
    rb::ArticulatedBody limp = rb::robotFromUrdfString(massless);
    ASSERT_FALSE(limp.singularJoint().empty());
    cr::RigidBody ball = sphere(ms, R, Vector3d(d, -R, 0), Vector3d(0, V, 0));
    cr::ContactPoint contact(0, 1, Vector3d(d, 0, 0), Vector3d::UnitY(), e, 0.0, 0.0);
    contact.part_b = limp.linkIndex("rod");
    EXPECT_THROW(cr::computeBodyResponse({&ball, &limp}, {contact}), cr::InvalidInput);
  }
  rb::ArticulatedBody rod = rb::robotFromUrdfFile(kDir + "/pendulum.urdf");
  cr::RigidBody ball = sphere(ms, R, Vector3d(d, -R, 0), Vector3d(0, V, 0));
  cr::ContactPoint contact(0, 1, Vector3d(d, 0, 0), Vector3d::UnitY(), e, 0.0, 0.0);
  contact.part_b = rod.linkIndex("rod");
  const cr::BodyResponse out = cr::computeBodyResponse({&ball, &rod}, {contact});
  const double P = (1 + e) * V / (1 / ms + d * d / I_hinge);
  EXPECT_NEAR(out.impulses[0].normal_impulse, P, 1e-9);
  EXPECT_NEAR(rod.jointVelocities()(0), d * P / I_hinge, 1e-9);
  EXPECT_NEAR(ball.linear_velocity.y(), V - P / ms, 1e-9);
}
