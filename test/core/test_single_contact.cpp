// Unit tests of single-contact impact responses: closed-form cases derived by hand from
// Newton's restitution law, Coulomb friction and the impulse-momentum equations, plus invariants
// (restitution, friction cone, momentum, energy) checked on randomised contacts.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "collision_response/core/body_state.h"
#include "collision_response/core/compute_response.h"
#include "collision_response/core/constants.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/scene.h"
#include "collision_response/core/single_contact.h"
#include "collision_response/core/solver_options.h"

#include "scene_builders.h"

#include "rigid_contact.h"

namespace cr = collision_response::core;
using collision_response::testing::spaceOf;
using collision_response::testing::velocityAt;
using namespace collision_response::testing;  // NOLINT: shared builders

namespace {

constexpr double kTol = 1e-9;
using collision_response::core::kPi;

cr::BodyState ground(const std::string& id = "ground", const Vector3d& v = Vector3d::Zero()) {
  cr::BodyState b;
  b.id = id;
  b.mass = 0.0;
  b.linear_velocity = v;
  return b;
}

// World-frame quantities computed independently of the library.
Vector3d relVel(const cr::BodyState& a, const cr::BodyState& b, const Vector3d& p) {
  return pointVelocity(b, p) - pointVelocity(a, p);
}
double energy(const cr::BodyState& b) {
  if (b.mass == 0.0) return 0.0;
  return 0.5 * b.mass * b.linear_velocity.squaredNorm() +
         0.5 * b.angular_velocity.dot(worldInertia(b) * b.angular_velocity);
}
// Contact-space inverse mass matrix written out from docs/physics.md ("Symbols and conventions"),
// independent of ContactSpace.
Matrix3d skew(const Vector3d& r) {
  Matrix3d s;
  s << 0, -r.z(), r.y(), r.z(), 0, -r.x(), -r.y(), r.x(), 0;
  return s;
}
Matrix3d contactK(const cr::BodyState& a, const cr::BodyState& b, const Vector3d& p) {
  Matrix3d K = Matrix3d::Zero();
  for (const cr::BodyState* body : {&a, &b}) {
    if (body->mass == 0.0) continue;
    const Matrix3d rx = skew(p - worldCom(*body));
    K += Matrix3d::Identity() / body->mass - rx * worldInertia(*body).inverse() * rx;
  }
  return K;
}

// Random bodies: inertia of a solid box (always obeys the triangle inequality), randomly rotated.
struct Random : collision_response::testing::RandomSource {
  using RandomSource::RandomSource;
  cr::BodyState body(const std::string& id) {
    cr::BodyState b;
    b.id = id;
    b.mass = uniform(0.2, 5.0);
    b.inertia = boxInertia(b.mass, boxSize());
    const Quaterniond Q = rotation();  // principal axes rotated within the body frame
    b.inertia = Q.toRotationMatrix() * b.inertia * Q.toRotationMatrix().transpose();
    b.inertia = 0.5 * (b.inertia + b.inertia.transpose()).eval();
    b.com = vec(-0.3, 0.3);
    b.position = vec(-1.0, 1.0);
    b.orientation = rotation();
    b.linear_velocity = vec(-2.0, 2.0);
    b.angular_velocity = vec(-3.0, 3.0);
    return b;
  }
  // Two bodies and an approaching, off-centre contact between them (b immovable if `fixed_a`).
  cr::Scene scene(bool fixed_a, double mu_max) {
    cr::Scene s;
    s.bodies = {body("a"), body("b")};
    if (fixed_a) s.bodies[0].mass = 0.0;
    cr::Contact c;
    c.body_a = "a";
    c.body_b = "b";
    c.point = vec(-1.0, 1.0);
    c.normal = unit();
    c.restitution = uniform(0.0, 1.0);
    c.static_friction = uniform(0.0, mu_max);
    c.dynamic_friction = uniform(0.0, c.static_friction);
    s.contacts = {c};
    if (relVel(s.bodies[0], s.bodies[1], c.point).dot(c.normal) >= 0.0) {
      for (auto& b : s.bodies) {  // reverse every velocity: u -> -u, approaching
        b.linear_velocity = -b.linear_velocity;
        b.angular_velocity = -b.angular_velocity;
      }
    }
    return s;
  }
};

// Solves a two-body scene with the given law; returns the result.
cr::CollisionResult solve(const cr::Scene& s, cr::ImpactLaw law = cr::ImpactLaw::kNewton) {
  cr::SolverOptions o;
  o.law = law;
  return cr::computeResponse(s, o);
}

// ---------------------------------------------------------------------------------------------
// Head-on spheres.
// Derivation: central impact along x, so no rotation and no tangential impulse. Momentum
// m1 v1 + m2 v2 = m1 v1' + m2 v2' and Newton's law v2' - v1' = -e (v2 - v1) give
//   v1' = (m1 v1 + m2 v2 - m2 e (v1 - v2)) / (m1 + m2),
//   v2' = (m1 v1 + m2 v2 + m1 e (v1 - v2)) / (m1 + m2),
// and the normal impulse j = m1 m2 (1 + e)(v1 - v2) / (m1 + m2).
void checkHeadOn(double m1, double m2, double v1, double v2, double e, double r1, double r2) {
  cr::Scene s;
  s.bodies = {sphere("s1", m1, r1, Vector3d(-r1, 0.3, -0.2), Vector3d(v1, 0, 0)),
              sphere("s2", m2, r2, Vector3d(r2, 0.3, -0.2), Vector3d(v2, 0, 0))};
  s.contacts = {contact("s1", "s2", Vector3d(0, 0.3, -0.2), Vector3d::UnitX(), e)};
  const cr::CollisionResult r = solve(s);
  const double v1p = (m1 * v1 + m2 * v2 - m2 * e * (v1 - v2)) / (m1 + m2);
  const double v2p = (m1 * v1 + m2 * v2 + m1 * e * (v1 - v2)) / (m1 + m2);
  const double j = m1 * m2 * (1 + e) * (v1 - v2) / (m1 + m2);
  expectVecNear(r.bodies[0].linear_velocity, Vector3d(v1p, 0, 0), kTol);
  expectVecNear(r.bodies[1].linear_velocity, Vector3d(v2p, 0, 0), kTol);
  expectVecNear(r.bodies[0].angular_velocity, Vector3d::Zero(), kTol);
  expectVecNear(r.bodies[1].angular_velocity, Vector3d::Zero(), kTol);
  EXPECT_NEAR(r.impulses[0].normal_impulse, j, kTol);
  EXPECT_NEAR(r.impulses[0].friction_impulse.norm(), 0.0, kTol);
  EXPECT_NEAR(r.impulses[0].normal_velocity_before, v2 - v1, kTol);
  EXPECT_NEAR(r.impulses[0].normal_velocity_after, -e * (v2 - v1), kTol);
  ASSERT_EQ(r.islands.size(), 1u);
  EXPECT_EQ(r.islands[0].methodName(), "closed_form");
}

TEST(HeadOnSpheres, EqualMassesElasticExchangeVelocities) {
  // e = 1, m1 = m2: v1' = v2, v2' = v1.
  checkHeadOn(2.0, 2.0, 3.0, -1.0, 1.0, 0.5, 0.5);
}

TEST(HeadOnSpheres, EqualMassesPlasticMoveTogether) {
  // e = 0: both end with the centre-of-mass velocity (3 - 1) / 2 = 1.
  checkHeadOn(2.0, 2.0, 3.0, -1.0, 0.0, 0.5, 0.5);
}

TEST(HeadOnSpheres, EqualMassesHalfRestitution) {
  checkHeadOn(1.5, 1.5, 2.0, 0.0, 0.5, 0.3, 0.3);
}

TEST(HeadOnSpheres, UnequalMassesAllRestitutions) {
  for (const double e : {0.0, 0.5, 1.0}) {
    SCOPED_TRACE(e);
    checkHeadOn(1.0, 3.0, 4.0, -2.0, e, 0.2, 0.7);
    checkHeadOn(5.0, 0.5, 1.0, 0.2, e, 0.4, 0.1);  // a fast heavy sphere catching a light one
  }
}

TEST(HeadOnSpheres, ElasticUnequalMassesHandValues) {
  // m1 = 1, m2 = 3, v1 = 4, v2 = 0, e = 1: v1' = (4 - 3*4)/4 = -2, v2' = (4 + 4)/4 = 2.
  cr::Scene s;
  s.bodies = {sphere("s1", 1.0, 0.5, Vector3d(-0.5, 0, 0), Vector3d(4, 0, 0)),
              sphere("s2", 3.0, 0.5, Vector3d(0.5, 0, 0), Vector3d::Zero())};
  s.contacts = {contact("s1", "s2", Vector3d::Zero(), Vector3d::UnitX(), 1.0)};
  const auto r = solve(s);
  expectVecNear(r.bodies[0].linear_velocity, Vector3d(-2, 0, 0), kTol);
  expectVecNear(r.bodies[1].linear_velocity, Vector3d(2, 0, 0), kTol);
  EXPECT_NEAR(r.kinetic_energy_before, 8.0, kTol);
  EXPECT_NEAR(r.kinetic_energy_after, 8.0, kTol);
}

// ---------------------------------------------------------------------------------------------
// Immovable bodies.
// Derivation: an immovable body has infinite mass, so the relative normal velocity is entirely
// the ball's: u_n' = -e u_n with the ground at rest gives v_y' = -e v_y; frictionless, so v_x, v_z
// and the spin are unchanged; j = m (1 + e) |v_y|.
TEST(ImmovableBody, BallBouncesOnGroundWithMinusEV) {
  for (const double e : {0.0, 0.5, 1.0}) {
    SCOPED_TRACE(e);
    const double m = 0.7, R = 0.1;
    cr::Scene s;
    s.bodies = {ground(), sphere("ball", m, R, Vector3d(1, R, 2), Vector3d(0.3, -2.0, -0.4),
                                 Vector3d(0.5, 1.0, -2.0))};
    s.contacts = {contact("ground", "ball", Vector3d(1, 0, 2), Vector3d::UnitY(), e)};
    const auto r = solve(s);
    expectVecNear(r.bodies[1].linear_velocity, Vector3d(0.3, 2.0 * e, -0.4), kTol);
    expectVecNear(r.bodies[1].angular_velocity, Vector3d(0.5, 1.0, -2.0), kTol);
    expectVecNear(r.bodies[0].linear_velocity, Vector3d::Zero(), 0.0);
    expectVecNear(r.bodies[0].angular_velocity, Vector3d::Zero(), 0.0);
    EXPECT_NEAR(r.impulses[0].normal_impulse, m * (1 + e) * 2.0, kTol);
  }
}

TEST(ImmovableBody, ImmovableAsBodyBAlsoWorks) {
  // Same bounce with the roles swapped: normal from the ball (a) to the ground (b) is -y.
  const double e = 0.8;
  cr::Scene s;
  s.bodies = {sphere("ball", 2.0, 0.5, Vector3d(0, 0.5, 0), Vector3d(0, -3.0, 0)), ground()};
  s.contacts = {contact("ball", "ground", Vector3d::Zero(), -Vector3d::UnitY(), e)};
  const auto r = solve(s);
  expectVecNear(r.bodies[0].linear_velocity, Vector3d(0, 3.0 * e, 0), kTol);
  expectVecNear(r.bodies[1].linear_velocity, Vector3d::Zero(), 0.0);
  EXPECT_NEAR(r.impulses[0].normal_impulse, 2.0 * (1 + e) * 3.0, kTol);
}

TEST(ImmovableBody, MovingImmovablePaddleKeepsItsVelocity) {
  // A paddle of infinite mass moving up at W hits a ball falling at v: in the paddle's frame the
  // ball bounces, v' - W = -e (v - W), so v' = (1 + e) W - e v. The paddle is unchanged.
  const double W = 1.5, v = -2.0, e = 0.6;
  cr::Scene s;
  s.bodies = {ground("paddle", Vector3d(0, W, 0)),
              sphere("ball", 0.3, 0.05, Vector3d(0, 0.05, 0), Vector3d(0, v, 0))};
  s.contacts = {contact("paddle", "ball", Vector3d::Zero(), Vector3d::UnitY(), e)};
  const auto r = solve(s);
  EXPECT_NEAR(r.bodies[1].linear_velocity.y(), (1 + e) * W - e * v, kTol);
  expectVecNear(r.bodies[0].linear_velocity, Vector3d(0, W, 0), 0.0);
}

// ---------------------------------------------------------------------------------------------
// Rod striking the ground at its tip, frictionless.
// A uniform rod (mass m, length L) along body x, inclined at theta in the x-y plane, lower tip on
// the ground (normal +y, ground is body a). r = tip - com = -(L/2)(cos theta, sin theta, 0).
// With w = w_z z: u_n = v_y + (w x r)_y = v_y + w_z r_x. The impulse j y at r gives
//   dv = j/m y,  dw = I^-1 (r x j y) = j r_x / I z, I = m L^2 / 12 (z is principal).
// u_n' = u_n + j (1/m + r_x^2 / I) = -e u_n  =>  j = -(1 + e) u_n m_eff, m_eff = 1/(1/m + r_x^2/I),
// with r_perp = r_x the lever arm of the normal about the centre of mass.
TEST(RodOnGround, FrictionlessTipImpactClosedForm) {
  const double m = 1.3, L = 0.8, theta = 50.0 * kPi / 180.0, e = 0.6, rad = 0.01;
  const double I = m * L * L / 12.0;
  cr::BodyState rod;
  rod.id = "rod";
  rod.mass = m;
  // Thin cylinder of radius rad along x: I_xx = m rad^2 / 2, I_yy = I_zz = m (3 rad^2 + L^2) / 12.
  // Use the slender-rod value m L^2 / 12 for the transverse moments (rad -> 0) and a small axial
  // moment, which still satisfies I_xx + I_yy >= I_zz.
  rod.inertia = Vector3d(0.5 * m * rad * rad, I, I).asDiagonal();
  rod.orientation = Quaterniond(Eigen::AngleAxisd(theta, Vector3d::UnitZ()));
  rod.position = Vector3d(0.2, 0.5 * L * std::sin(theta), -0.1);
  rod.linear_velocity = Vector3d(0.4, -1.1, 0.0);
  rod.angular_velocity = Vector3d(0.0, 0.0, 0.7);
  const Vector3d tip = rod.position - 0.5 * L * Vector3d(std::cos(theta), std::sin(theta), 0);
  ASSERT_NEAR(tip.y(), 0.0, 1e-15);

  cr::Scene s;
  s.bodies = {ground(), rod};
  s.contacts = {contact("ground", "rod", tip, Vector3d::UnitY(), e)};
  const auto r = solve(s);

  const double rx = -0.5 * L * std::cos(theta);
  const double u_n = -1.1 + 0.7 * rx;
  const double m_eff = 1.0 / (1.0 / m + rx * rx / I);
  const double j = -(1 + e) * u_n * m_eff;
  ASSERT_GT(j, 0.0);
  expectVecNear(r.bodies[1].linear_velocity, Vector3d(0.4, -1.1 + j / m, 0.0), kTol);
  expectVecNear(r.bodies[1].angular_velocity, Vector3d(0.0, 0.0, 0.7 + j * rx / I), kTol);
  EXPECT_NEAR(r.impulses[0].normal_impulse, j, kTol);
  // The tip's normal velocity is reversed and scaled by e.
  const double u_n_after = pointVelocity(r.bodies[1], tip).y();
  EXPECT_NEAR(u_n_after, -e * u_n, kTol);
  EXPECT_NEAR(r.impulses[0].normal_velocity_before, u_n, kTol);
  EXPECT_NEAR(r.impulses[0].normal_velocity_after, -e * u_n, kTol);
}

// ---------------------------------------------------------------------------------------------
// Solid sphere (I = 2/5 m R^2) hitting the ground obliquely with friction.
// Contact at r = (0, -R, 0) from the centre, normal +y. With w = w_z z: w x r = (w_z R, 0, 0), so
// the slip is u_t = v_x + w_z R (along x). A tangential impulse P_t x at r gives
//   dv_x = P_t / m,  dw_z = R P_t / I = 5 P_t / (2 m R),  du_t = P_t (1/m + R^2/I) = 7 P_t / (2 m).
// K is diagonal (central contact) so normal and tangential problems decouple:
//   P_n = m (1 + e) |v_y|.
// Stick: P_t = -2 m u_t / 7, v_x' = v_x - 2 u_t / 7 = (5 v_x - 2 w_z R) / 7, and the sphere rolls:
//   v_x' = -w_z' R. It sticks iff 2 |u_t| / 7 <= mu_s (1 + e) |v_y|.
// Slide: P_t = -mu_d P_n sign(u_t), v_x' = v_x - mu_d (1 + e) |v_y| sign(u_t),
//   w_z' = w_z - 5 mu_d (1 + e) |v_y| sign(u_t) / (2 R).
struct ObliqueBall {
  double m = 0.45, R = 0.11, vx = 3.0, vy = -2.0, wz = 4.0, e = 0.5;
  cr::Scene scene(double mu_s, double mu_d) const {
    cr::Scene s;
    s.bodies = {ground(),
                sphere("ball", m, R, Vector3d(0, R, 0), Vector3d(vx, vy, 0), Vector3d(0, 0, wz))};
    s.contacts = {contact("ground", "ball", Vector3d::Zero(), Vector3d::UnitY(), e, mu_s, mu_d)};
    return s;
  }
  double slip() const { return vx + wz * R; }
  double normalImpulse() const { return m * (1 + e) * -vy; }
  double stickRatio() const { return 2.0 * std::abs(slip()) / (7.0 * (1 + e) * -vy); }
};

void checkStick(const ObliqueBall& b, const cr::CollisionResult& r) {
  const double u_t = b.slip();
  const double P_t = -2.0 * b.m * u_t / 7.0;
  const cr::BodyState& out = r.bodies[1];
  EXPECT_NEAR(out.linear_velocity.x(), (5 * b.vx - 2 * b.wz * b.R) / 7.0, kTol);
  EXPECT_NEAR(out.linear_velocity.y(), -b.e * b.vy, kTol);
  EXPECT_NEAR(out.linear_velocity.z(), 0.0, kTol);
  EXPECT_NEAR(out.angular_velocity.z(), b.wz + 5 * P_t / (2 * b.m * b.R), kTol);
  // Rolling: the contact point is at rest tangentially, v' = -w' x r.
  const Vector3d r_c(0, -b.R, 0);
  const Vector3d rolling = -out.angular_velocity.cross(r_c);
  EXPECT_NEAR(out.linear_velocity.x(), rolling.x(), kTol);
  EXPECT_NEAR(out.linear_velocity.z(), rolling.z(), kTol);
  const Vector3d u_after = pointVelocity(out, Vector3d::Zero());
  EXPECT_NEAR(u_after.x(), 0.0, kTol);
  EXPECT_NEAR(u_after.z(), 0.0, kTol);
  EXPECT_TRUE(r.impulses[0].sticking);
  EXPECT_NEAR(r.impulses[0].normal_impulse, b.normalImpulse(), kTol);
  expectVecNear(r.impulses[0].friction_impulse, Vector3d(P_t, 0, 0), kTol);
}

void checkSlide(const ObliqueBall& b, double mu_d, const cr::CollisionResult& r) {
  const double sign = b.slip() > 0 ? 1.0 : -1.0;
  const double P_n = b.normalImpulse();
  const cr::BodyState& out = r.bodies[1];
  EXPECT_NEAR(out.linear_velocity.x(), b.vx - mu_d * (1 + b.e) * -b.vy * sign, kTol);
  EXPECT_NEAR(out.linear_velocity.y(), -b.e * b.vy, kTol);
  EXPECT_NEAR(out.angular_velocity.z(), b.wz - 5 * mu_d * (1 + b.e) * -b.vy * sign / (2 * b.R),
              kTol);
  EXPECT_FALSE(r.impulses[0].sticking);
  EXPECT_NEAR(r.impulses[0].normal_impulse, P_n, kTol);
  // |friction| = mu_d j_n exactly, opposite to the slip.
  EXPECT_NEAR(r.impulses[0].friction_impulse.norm(), mu_d * P_n, kTol);
  expectVecNear(r.impulses[0].friction_impulse, Vector3d(-sign * mu_d * P_n, 0, 0), kTol);
  // Still slipping in the same direction.
  const double slip_after = pointVelocity(out, Vector3d::Zero()).x();
  EXPECT_GT(slip_after * sign, 1e-6);
  EXPECT_NEAR(slip_after, b.slip() - 3.5 * sign * mu_d * P_n / b.m, kTol);
}

TEST(ObliqueBallWithFriction, LargeStaticFrictionSticksAndRolls) {
  ObliqueBall b;  // slip = 3 + 0.44 = 3.44, ratio = 6.88 / 10.5 = 0.655
  checkStick(b, solve(b.scene(2.0, 1.5)));
}

TEST(ObliqueBallWithFriction, BackspinSticks) {
  ObliqueBall b;
  b.wz = -40.0;  // slip = 3 - 4.4 = -1.4 < 0: friction pushes forward
  checkStick(b, solve(b.scene(1.0, 1.0)));
}

TEST(ObliqueBallWithFriction, SmallFrictionSlidesWithDynamicCoefficient) {
  ObliqueBall b;
  checkSlide(b, 0.1, solve(b.scene(0.2, 0.1)));
  b.wz = -60.0;  // slipping backwards
  checkSlide(b, 0.05, solve(b.scene(0.1, 0.05)));
}

TEST(ObliqueBallWithFriction, StickingImpulseBetweenDynamicAndStaticConeSticks) {
  ObliqueBall b;
  const double rho = b.stickRatio();  // |P_t,stick| / P_n
  checkStick(b, solve(b.scene(1.2 * rho, 0.5 * rho)));
  checkStick(b, solve(b.scene(rho * (1 + 1e-6), 0.9 * rho)));
}

TEST(ObliqueBallWithFriction, StickingImpulseJustAboveStaticConeSlidesWithDynamic) {
  ObliqueBall b;
  const double rho = b.stickRatio();
  const double mu_d = 0.5 * rho;
  checkSlide(b, mu_d, solve(b.scene(rho * (1 - 1e-6), mu_d)));
}

TEST(ObliqueBallWithFriction, SolveSingleContactDirectMatchesClosedForm) {
  // Same stick case through the low-level API; the bodies are left unchanged by the call.
  ObliqueBall b;
  const cr::Scene s = b.scene(2.0, 1.0);
  const cr::RigidBody ga = cr::makeRigidBody(s.bodies[0]);
  const cr::RigidBody ball = cr::makeRigidBody(s.bodies[1]);
  const cr::ContactPoint row(0, 1, Vector3d::Zero(), Vector3d::UnitY(), b.e, 2.0, 1.0);
  const cr::ContactImpulse imp = cr::solveSingleContact(ga, ball, row, cr::ImpactLaw::kNewton);
  EXPECT_TRUE(imp.sticking);
  EXPECT_NEAR(imp.normal_impulse, b.normalImpulse(), kTol);
  expectVecNear(imp.friction_impulse, Vector3d(-2.0 * b.m * b.slip() / 7.0, 0, 0), kTol);
  EXPECT_NEAR(imp.normal_velocity_before, b.vy, kTol);
  EXPECT_NEAR(imp.normal_velocity_after, -b.e * b.vy, kTol);
  expectVecNear(ball.linear_velocity, Vector3d(b.vx, b.vy, 0), 0.0);
}

// ---------------------------------------------------------------------------------------------
// Restitution law at the contact point, random off-centre frictional contacts.
TEST(RandomContacts, NewtonLawGivesMinusEUnAtContactPoint) {
  Random rnd(12345);
  for (int k = 0; k < 500; ++k) {
    const cr::Scene s = rnd.scene(k % 3 == 0, 1.5);
    const cr::Contact& c = s.contacts[0];
    const double u_n = relVel(s.bodies[0], s.bodies[1], c.point).dot(c.normal);
    ASSERT_LT(u_n, 0.0);
    const auto r = solve(s);
    const double u_n_after = relVel(r.bodies[0], r.bodies[1], c.point).dot(c.normal);
    EXPECT_NEAR(u_n_after, -c.restitution * u_n, kTol * std::max(1.0, std::abs(u_n)))
        << "case " << k;
    EXPECT_NEAR(r.impulses[0].normal_velocity_after, u_n_after,
                1e-12 * std::max(1.0, std::abs(u_n)));
  }
}

// The rod of the tests above, now rough (mu = 0.5), sliding forward: off-centre, K_tn != 0.
cr::Scene roughRod(double mu_s, double mu_d) {
  const double m = 1.0, L = 1.0, theta = 50.0 * kPi / 180.0, I = m * L * L / 12.0;
  cr::BodyState rod;
  rod.id = "rod";
  rod.mass = m;
  rod.inertia = Vector3d(1e-4 * I, I, I).asDiagonal();
  rod.orientation = Quaterniond(Eigen::AngleAxisd(theta, Vector3d::UnitZ()));
  rod.position = Vector3d(0, 0.5 * L * std::sin(theta), 0);
  const double phi = 20.0 * kPi / 180.0;
  rod.linear_velocity = Vector3d(std::sin(phi), -std::cos(phi), 0);
  const Vector3d tip = rod.position - 0.5 * L * Vector3d(std::cos(theta), std::sin(theta), 0);
  cr::Scene s;
  s.bodies = {ground(), rod};
  s.contacts = {contact("ground", "rod", tip, Vector3d::UnitY(), 0.5, mu_s, mu_d)};
  return s;
}

TEST(SeedOnePassLaw, ViolatesRestitutionForOffCentreFrictionalContact) {
  const cr::Scene s = roughRod(0.5, 0.5);
  const cr::Contact& c = s.contacts[0];
  const double u_n = relVel(s.bodies[0], s.bodies[1], c.point).dot(c.normal);
  ASSERT_LT(u_n, 0.0);
  const auto seed = solve(s, cr::ImpactLaw::kSeedOnePass);
  const double seed_after = relVel(seed.bodies[0], seed.bodies[1], c.point).dot(c.normal);
  // The second (friction) pass moves u_n by n^T K P_f != 0, since K_tn != 0 off centre.
  EXPECT_GT(std::abs(seed_after + c.restitution * u_n), 1e-3 * std::abs(u_n));
  const auto newton = solve(s, cr::ImpactLaw::kNewton);
  const double newton_after = relVel(newton.bodies[0], newton.bodies[1], c.point).dot(c.normal);
  EXPECT_NEAR(newton_after, -c.restitution * u_n, kTol);
}

TEST(SeedOnePassLaw, ViolatesRestitutionOnRandomOffCentreContactsButNewtonDoesNot) {
  Random rnd(777);
  int violations = 0;
  for (int k = 0; k < 100; ++k) {
    cr::Scene s = rnd.scene(false, 1.0);
    s.contacts[0].dynamic_friction = s.contacts[0].static_friction = rnd.uniform(0.3, 1.0);
    const cr::Contact& c = s.contacts[0];
    const double u_n = relVel(s.bodies[0], s.bodies[1], c.point).dot(c.normal);
    const auto seed = solve(s, cr::ImpactLaw::kSeedOnePass);
    const double after = relVel(seed.bodies[0], seed.bodies[1], c.point).dot(c.normal);
    if (std::abs(after + c.restitution * u_n) > 1e-3 * std::abs(u_n)) ++violations;
  }
  EXPECT_GT(violations, 50);
}

TEST(SeedOnePassLaw, MatchesNewtonForFrictionlessContacts) {
  Random rnd(4242);
  for (int k = 0; k < 200; ++k) {
    cr::Scene s = rnd.scene(k % 2 == 0, 1.0);
    s.contacts[0].static_friction = s.contacts[0].dynamic_friction = 0.0;
    const auto seed = solve(s, cr::ImpactLaw::kSeedOnePass);
    const auto newton = solve(s, cr::ImpactLaw::kNewton);
    for (int i = 0; i < 2; ++i) {
      expectVecNear(seed.bodies[i].linear_velocity, newton.bodies[i].linear_velocity, 1e-12);
      expectVecNear(seed.bodies[i].angular_velocity, newton.bodies[i].angular_velocity, 1e-11);
    }
  }
}

TEST(SeedOnePassLaw, MatchesNewtonForCentralFrictionalContacts) {
  // Spheres: K_tn = 0, normal and tangential problems decouple; stick and slide cases.
  for (const double mu : {2.0, 0.1}) {
    ObliqueBall b;
    const cr::Scene s = b.scene(mu, mu);
    const auto seed = solve(s, cr::ImpactLaw::kSeedOnePass);
    const auto newton = solve(s, cr::ImpactLaw::kNewton);
    expectVecNear(seed.bodies[1].linear_velocity, newton.bodies[1].linear_velocity, 1e-12);
    expectVecNear(seed.bodies[1].angular_velocity, newton.bodies[1].angular_velocity, 1e-11);
    EXPECT_EQ(seed.impulses[0].sticking, newton.impulses[0].sticking);
  }
  // Two free spheres, oblique central impact with relative spin.
  cr::Scene s;
  s.bodies = {sphere("s1", 1.0, 0.3, Vector3d::Zero(), Vector3d(1, 0.5, -0.2), Vector3d(1, 2, 3)),
              sphere("s2", 2.0, 0.6, Vector3d(0.9, 0, 0), Vector3d(-1, 0.1, 0.4))};
  s.contacts = {contact("s1", "s2", Vector3d(0.3, 0, 0), Vector3d::UnitX(), 0.7, 0.3, 0.3)};
  const auto seed = solve(s, cr::ImpactLaw::kSeedOnePass);
  const auto newton = solve(s, cr::ImpactLaw::kNewton);
  for (int i = 0; i < 2; ++i) {
    expectVecNear(seed.bodies[i].linear_velocity, newton.bodies[i].linear_velocity, 1e-12);
    expectVecNear(seed.bodies[i].angular_velocity, newton.bodies[i].angular_velocity, 1e-11);
  }
}

// ---------------------------------------------------------------------------------------------
// Friction cone on random contacts. A contact is Painleve-prone (the documented fallback returns
// the sticking impulse outside the cone) only if n^T K n <= mu_d |K_tn|; such cases are skipped.
TEST(RandomContacts, ImpulseLiesInFrictionConeAndSlidingUsesDynamicFriction) {
  Random rnd(2024);
  int tested = 0, sliding = 0, sticking = 0;
  const int total = 600;
  for (int k = 0; k < total; ++k) {
    const cr::Scene s = rnd.scene(k % 3 == 0, 1.2);
    const cr::Contact& c = s.contacts[0];
    const Vector3d& n = c.normal;
    const Matrix3d K = contactK(s.bodies[0], s.bodies[1], c.point);
    const Vector3d Kn = K * n;
    const double k_nn = n.dot(Kn);
    const double k_tn = (Kn - k_nn * n).norm();
    if (k_nn <= c.dynamic_friction * k_tn * (1 + 1e-6)) continue;
    ++tested;
    const auto r = solve(s);
    const cr::ContactImpulse& imp = r.impulses[0];
    const double j_r = imp.normal_impulse;
    const double j_f = imp.friction_impulse.norm();
    EXPECT_GE(j_r, 0.0) << "case " << k;
    EXPECT_NEAR(imp.friction_impulse.dot(n), 0.0, 1e-12 * std::max(1.0, j_r));
    EXPECT_LE(j_f, c.static_friction * j_r * (1 + 1e-9) + 1e-12) << "case " << k;
    // The sticking impulse (u' = -e u_n n) decides the mode.
    const Vector3d u = relVel(s.bodies[0], s.bodies[1], c.point);
    const double u_n = u.dot(n);
    const Vector3d P_stick = K.inverse() * (-(1 + c.restitution) * u_n * n - (u - u_n * n));
    const double Ps_n = P_stick.dot(n);
    const bool in_cone = Ps_n >= 0 && (P_stick - Ps_n * n).norm() <= c.static_friction * Ps_n;
    const Vector3d u_after = relVel(r.bodies[0], r.bodies[1], c.point);
    if (imp.sticking) {
      ++sticking;
      EXPECT_TRUE(in_cone) << "case " << k;
      EXPECT_LE((u_after - u_after.dot(n) * n).norm(), kTol * std::max(1.0, u.norm()));
    } else {
      ++sliding;
      EXPECT_FALSE(in_cone && c.static_friction > 0) << "case " << k;
      EXPECT_NEAR(j_f, c.dynamic_friction * j_r, kTol * std::max(1.0, j_r)) << "case " << k;
      // Coulomb: sliding friction does not push along the remaining slip (it dissipates).
      const Vector3d slip_after = u_after - u_after.dot(n) * n;
      EXPECT_LE(slip_after.dot(imp.friction_impulse), kTol * std::max(1.0, j_f * u.norm()))
          << "case " << k;
    }
  }
  EXPECT_GT(tested, total * 8 / 10);
  EXPECT_GT(sliding, 50);
  EXPECT_GT(sticking, 50);
}

// ---------------------------------------------------------------------------------------------
// Momentum: the contact impulse is internal to the pair of free bodies, applied as +P at p on b and
// -P at p on a; it changes total linear momentum by 0 and the angular momentum about any O by
// (p - O) x P - (p - O) x P = 0.
TEST(RandomContacts, TwoFreeBodiesConserveLinearAndAngularMomentum) {
  Random rnd(99);
  for (int k = 0; k < 300; ++k) {
    const cr::Scene s = rnd.scene(false, 1.5);
    const Vector3d O = rnd.vec(-5, 5);
    for (const cr::ImpactLaw law : {cr::ImpactLaw::kNewton, cr::ImpactLaw::kSeedOnePass}) {
      const auto r = solve(s, law);
      const Vector3d p0 = linearMomentum(s.bodies), p1 = linearMomentum(r.bodies);
      const double scale = std::max(1.0, p0.norm() + r.impulses[0].normal_impulse);
      expectVecNear(p1, p0, kTol * scale);
      for (const Vector3d& o : {Vector3d(Vector3d::Zero()), O}) {
        const Vector3d h0 = angularMomentum(s.bodies, o), h1 = angularMomentum(r.bodies, o);
        expectVecNear(h1, h0, kTol * std::max(1.0, h0.norm() + 10 * scale));
      }
      // Momentum actually changed on each body (the test is not vacuous).
      EXPECT_GT((r.bodies[1].linear_velocity - s.bodies[1].linear_velocity).norm(), 1e-6);
    }
  }
}

// ---------------------------------------------------------------------------------------------
TEST(NonApproachingContact, SeparatingContactGetsZeroImpulse) {
  cr::Scene s;
  s.bodies = {ground(), sphere("ball", 1.0, 0.5, Vector3d(0, 0.5, 0), Vector3d(2.0, 0.1, 0),
                               Vector3d(0, 0, 5))};
  s.contacts = {contact("ground", "ball", Vector3d::Zero(), Vector3d::UnitY(), 0.5, 1.0, 1.0)};
  const auto r = solve(s);
  EXPECT_EQ(r.impulses[0].normal_impulse, 0.0);
  EXPECT_EQ(r.impulses[0].friction_impulse, Vector3d::Zero());
  EXPECT_EQ(r.bodies[1].linear_velocity, s.bodies[1].linear_velocity);
  EXPECT_EQ(r.bodies[1].angular_velocity, s.bodies[1].angular_velocity);
  ASSERT_EQ(r.islands.size(), 1u);
  EXPECT_EQ(r.islands[0].methodName(), "none");
}

TEST(NonApproachingContact, RestingSlidingContactGetsZeroImpulse) {
  // u_n = 0 exactly (sliding along the ground): no impact, so no impulse, even with friction.
  cr::Scene s;
  s.bodies = {ground(), sphere("ball", 1.0, 0.5, Vector3d(0, 0.5, 0), Vector3d(2.0, 0.0, 1.0))};
  s.contacts = {contact("ground", "ball", Vector3d::Zero(), Vector3d::UnitY(), 0.5, 1.0, 1.0)};
  const auto r = solve(s);
  EXPECT_EQ(r.impulses[0].normal_impulse, 0.0);
  EXPECT_EQ(r.impulses[0].friction_impulse, Vector3d::Zero());
  EXPECT_EQ(r.bodies[1].linear_velocity, s.bodies[1].linear_velocity);
  EXPECT_EQ(r.bodies[1].angular_velocity, s.bodies[1].angular_velocity);

  const cr::RigidBody ga = cr::makeRigidBody(s.bodies[0]), ball = cr::makeRigidBody(s.bodies[1]);
  const cr::ContactPoint row(0, 1, Vector3d::Zero(), Vector3d::UnitY(), 0.5, 1.0, 1.0);
  for (const cr::ImpactLaw law : {cr::ImpactLaw::kNewton, cr::ImpactLaw::kSeedOnePass}) {
    const cr::ContactImpulse imp = cr::solveSingleContact(ga, ball, row, law);
    EXPECT_EQ(imp.normal_impulse, 0.0);
    EXPECT_EQ(imp.friction_impulse, Vector3d::Zero());
    EXPECT_FALSE(imp.sticking);
  }
}

// ---------------------------------------------------------------------------------------------
// Energy, frictionless: with P = j n, j = -(1 + e) u_n / k, k = n^T K n, the kinetic energy
// change is dT = j (u_n + j k / 2) = -(1 - e^2) u_n^2 / (2 k) <= 0, zero for e = 1.
TEST(RandomContacts, FrictionlessImpactNeverGainsEnergyAndElasticConservesIt) {
  Random rnd(31337);
  for (int k = 0; k < 400; ++k) {
    cr::Scene s = rnd.scene(k % 2 == 0, 0.0);
    cr::Contact& c = s.contacts[0];
    c.static_friction = c.dynamic_friction = 0.0;
    if (s.bodies[0].mass == 0.0) {
      // A moving immovable body is an energy source (a paddle); the bound holds for one at rest.
      s.bodies[0].linear_velocity.setZero();
      s.bodies[0].angular_velocity.setZero();
      if (relVel(s.bodies[0], s.bodies[1], c.point).dot(c.normal) >= 0.0) c.normal = -c.normal;
    }
    if (k % 4 == 1) c.restitution = 1.0;
    if (k % 4 == 3) c.restitution = 0.0;
    const auto r = solve(s);
    const double before = energy(s.bodies[0]) + energy(s.bodies[1]);
    const double after = energy(r.bodies[0]) + energy(r.bodies[1]);
    EXPECT_LE(after, before * (1 + 1e-12)) << "case " << k;
    // Closed form of the loss.
    const Matrix3d K = contactK(s.bodies[0], s.bodies[1], c.point);
    const double u_n = relVel(s.bodies[0], s.bodies[1], c.point).dot(c.normal);
    const double loss =
        (1 - c.restitution * c.restitution) * u_n * u_n / (2 * c.normal.dot(K * c.normal));
    EXPECT_NEAR(before - after, loss, kTol * std::max(1.0, before)) << "case " << k;
    if (c.restitution == 1.0) {
      EXPECT_NEAR(after, before, kTol * std::max(1.0, before));
    }
    EXPECT_NEAR(r.kinetic_energy_before, before, kTol * std::max(1.0, before));
    EXPECT_NEAR(r.kinetic_energy_after, after, kTol * std::max(1.0, before));
  }
}

}  // namespace
