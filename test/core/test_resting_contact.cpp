// The force-based Coulomb model (docs/physics.md, "Resting contacts") for resting contacts,
// against closed forms.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <string>
#include <utility>

#include "collision_response/core/compute_response.h"
#include "collision_response/core/contact_problem.h"
#include "collision_response/core/friction_disk.h"
#include "collision_response/core/resting_contact.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/stick_certificate.h"

namespace core = collision_response::core;

namespace {

constexpr double kG = 9.81;

// Solid ball (m = 1 kg, R = 0.1 m, I = 2/5 m R^2) resting on an immovable floor, contact below
// the centre (normal +z), gravity -m g z and a horizontal push F x through the centre.
core::Scene ballOnFloor(double push, double mu_s, double mu_d) {
  core::BodyState floor;
  floor.id = "floor";
  core::BodyState ball;
  ball.id = "ball";
  ball.mass = 1.0;
  ball.inertia = Eigen::Matrix3d::Identity() * 0.4 * 0.01;
  ball.position = {0.0, 0.0, 0.1};
  ball.force = {push, 0.0, -kG};
  core::Contact contact;
  contact.body_a = "floor";
  contact.body_b = "ball";
  contact.normal = Eigen::Vector3d::UnitZ();
  contact.static_friction = mu_s;
  contact.dynamic_friction = mu_d;
  core::Scene scene;
  scene.bodies = {floor, ball};
  scene.contacts = {contact};
  return scene;
}

// Sticking: the contact point must not accelerate. Along z: N = m g. Along x: the ball's centre
// accelerates at (F + f)/m and the contact point at (F + f)/m + R alpha_y... with alpha = R f / I
// (the friction f at the bottom spins it), rolling needs (F + f)/m = -R^2 f / I, so
// f = -F / (1 + m R^2 / I) = -F / 3.5 = -2F/7. It sticks while 2F/7 <= mu_s m g.
TEST(RestingContact, PushedBallRollsWithTwoSeventhsFriction) {
  const core::CollisionResult result = core::computeResponse(ballOnFloor(1.0, 0.5, 0.4));
  const core::ContactImpulse& contact = result.impulses[0];
  EXPECT_TRUE(contact.resting);
  EXPECT_NEAR(contact.normal_force, kG, 1e-12);
  EXPECT_NEAR(contact.friction_force.x(), -2.0 / 7.0, 1e-12);
  EXPECT_NEAR(contact.friction_force.y(), 0.0, 1e-12);
  EXPECT_TRUE(contact.sticking);
  EXPECT_EQ(contact.normal_impulse, 0.0);  // no impact
  EXPECT_EQ(result.islands[0].methodName(), "resting_closed_form");
  // Velocities are not changed by a resting analysis.
  EXPECT_EQ(result.bodies[1].linear_velocity, Eigen::Vector3d::Zero());
}

// Above the static limit (2 * 30 / 7 = 8.57 N > 0.5 * 9.81 N) it slides: |f| = mu_d m g = 3.924 N,
// against the push.
TEST(RestingContact, HardPushedBallSlidesWithDynamicFriction) {
  const core::ContactImpulse contact =
      core::computeResponse(ballOnFloor(30.0, 0.5, 0.4)).impulses[0];
  EXPECT_TRUE(contact.resting);
  EXPECT_FALSE(contact.sticking);
  EXPECT_NEAR(contact.normal_force, kG, 1e-12);
  EXPECT_NEAR(contact.friction_force.x(), -0.4 * kG, 1e-12);
}

// Just below and just above the static limit F = 3.5 mu_s m g.
TEST(RestingContact, StaticLimitSeparatesStickFromSlide) {
  const double limit = 3.5 * 0.5 * kG;
  EXPECT_TRUE(core::computeResponse(ballOnFloor(0.999 * limit, 0.5, 0.4)).impulses[0].sticking);
  const auto slide = core::computeResponse(ballOnFloor(1.001 * limit, 0.5, 0.4)).impulses[0];
  EXPECT_FALSE(slide.sticking);
  EXPECT_NEAR(slide.friction_force.norm(), 0.4 * kG, 1e-12);
}

// Already sliding (v = 1 m/s along y, no spin): dynamic friction -mu_d N against the slip
// (docs/physics.md, "Resting contacts"), whatever the push: f = -mu_d m g y.
TEST(RestingContact, SlidingBallGetsDynamicFrictionAgainstItsSlip) {
  core::Scene scene = ballOnFloor(1.0, 0.5, 0.4);
  scene.bodies[1].linear_velocity = {0.0, 1.0, 0.0};
  const core::ContactImpulse contact = core::computeResponse(scene).impulses[0];
  EXPECT_TRUE(contact.resting);
  EXPECT_FALSE(contact.sticking);
  EXPECT_NEAR(contact.normal_force, kG, 1e-12);
  EXPECT_NEAR(contact.friction_force.x(), 0.0, 1e-12);
  EXPECT_NEAR(contact.friction_force.y(), -0.4 * kG, 1e-12);
}

// Pulled up harder than gravity: the contact unloads, no force, nothing holds it.
TEST(RestingContact, LiftedBallGetsNoContactForce) {
  core::Scene scene = ballOnFloor(1.0, 0.5, 0.4);
  scene.bodies[1].force.z() = 2.0 * kG;
  const core::ContactImpulse contact = core::computeResponse(scene).impulses[0];
  EXPECT_TRUE(contact.resting);
  EXPECT_EQ(contact.normal_force, 0.0);
  EXPECT_EQ(contact.friction_force.norm(), 0.0);
  EXPECT_FALSE(contact.sticking);
}

// A wheel (the ball) rolling without slip at v = w R along x: the contact point is at rest but
// accelerates towards the centre at w^2 R (centripetal). Under gravity the floor only has to supply
// N = m (g - w^2 R); the friction needed is zero.
TEST(RestingContact, RollingWheelLoadIsReducedByCentripetalAcceleration) {
  core::Scene scene = ballOnFloor(0.0, 0.5, 0.4);
  const double R = 0.1, w = 5.0;  // w^2 R = 2.5 m/s^2 < g
  scene.bodies[1].linear_velocity = {w * R, 0.0, 0.0};
  scene.bodies[1].angular_velocity = {0.0, w, 0.0};  // w x (0, 0, -R) = (-w R, 0, 0): rolling
  const core::ContactImpulse contact = core::computeResponse(scene).impulses[0];
  EXPECT_TRUE(contact.resting);
  EXPECT_NEAR(contact.normal_force, kG - w * w * R, 1e-12);
  EXPECT_NEAR(contact.friction_force.norm(), 0.0, 1e-12);
}

// A box (1 x 0.2 x 1 m, 2 kg) resting flat on four corners, gravity and a push F x through the
// centre of mass below the static limit. The split between corners is not unique (4 contacts, 3
// equations), but the totals are: sum N = m g, sum f = -F, and every corner sticks.
TEST(RestingContact, BoxOnFourCornersHoldsGravityAndPush) {
  core::BodyState floor;
  floor.id = "floor";
  core::BodyState box;
  box.id = "box";
  box.mass = 2.0;
  box.inertia =
      Eigen::Vector3d(2.0 * (0.04 + 1.0) / 12.0, 2.0 * 2.0 / 12.0, 2.0 * (1.0 + 0.04) / 12.0)
          .asDiagonal();
  box.position = {0.0, 0.0, 0.1};
  box.force = {1.5, 0.0, -2.0 * kG};
  core::Scene scene;
  scene.bodies = {floor, box};
  for (const double x : {-0.5, 0.5}) {
    for (const double y : {-0.5, 0.5}) {
      core::Contact contact;
      contact.body_a = "floor";
      contact.body_b = "box";
      contact.point = {x, y, 0.0};
      contact.normal = Eigen::Vector3d::UnitZ();
      contact.static_friction = 0.6;
      contact.dynamic_friction = 0.6;
      scene.contacts.push_back(contact);
    }
  }
  core::SolverOptions options;
  options.tolerance = 1e-14;
  const core::CollisionResult result = core::computeResponse(scene, options);
  ASSERT_TRUE(result.islands[0].converged);
  EXPECT_EQ(result.islands[0].methodName(), "resting_iterative");
  double normal = 0.0;
  Eigen::Vector3d friction = Eigen::Vector3d::Zero();
  for (const auto& contact : result.impulses) {
    EXPECT_TRUE(contact.resting);
    EXPECT_GE(contact.normal_force, 0.0);
    EXPECT_LE(contact.friction_force.norm(), 0.6 * contact.normal_force + 1e-9);
    normal += contact.normal_force;
    friction += contact.friction_force;
  }
  EXPECT_NEAR(normal, 2.0 * kG, 1e-8);
  EXPECT_NEAR(friction.x(), -1.5, 1e-8);
  EXPECT_NEAR(friction.y(), 0.0, 1e-8);
}

// --- Resting boxes whose friction opposes the slip (issue 12, item 4; docs/physics.md, "Resting
// contacts"). A block (m = 2 kg, 0.2 m cube, I = m s^2 / 6 about every axis) rests flat on four
// corners (+-0.1, +-0.1, 0), centre at z = 0.1. The incline of angle theta is built by turning
// gravity: in the incline's frame (z along its normal, x down the slope) gravity is
// m g (sin theta, 0, -cos theta). A push P (in the plane) acts through the centre.
//
// One-body closed form: the tangential load is L = m g sin theta x + P, the normal load
// N = m g cos theta (the corners share it, their split balancing the moments, not unique).
// Sticking needs |L| <= mu_s N: then sum f = -L, sum F_n = N. Otherwise the block starts to slide
// along L/|L| without turning (the moments of the corner loads balance the friction's, and the
// friction, all along -L, has no yaw moment about the centre since sum F_i r_i is parallel to
// L), and every corner's friction is -mu_d F_i L/|L|: sum f = -mu_d N L/|L|.
namespace {

core::Scene blockOnIncline(double theta, const Eigen::Vector3d& push, double mu_s, double mu_d) {
  core::BodyState floor;
  floor.id = "floor";
  core::BodyState block;
  block.id = "block";
  block.mass = 2.0;
  block.inertia = Eigen::Matrix3d::Identity() * (2.0 * 0.04 / 6.0);
  block.position = {0.0, 0.0, 0.1};
  block.force =
      Eigen::Vector3d(2.0 * kG * std::sin(theta), 0.0, -2.0 * kG * std::cos(theta)) + push;
  core::Scene scene;
  scene.bodies = {floor, block};
  for (const auto& xy : {Eigen::Vector2d(0.1, -0.1), Eigen::Vector2d(-0.1, -0.1),
                         Eigen::Vector2d(0.1, 0.1), Eigen::Vector2d(-0.1, 0.1)}) {
    core::Contact contact;
    contact.body_a = "floor";
    contact.body_b = "block";
    contact.point = {xy.x(), xy.y(), 0.0};
    contact.normal = Eigen::Vector3d::UnitZ();
    contact.static_friction = mu_s;
    contact.dynamic_friction = mu_d;
    scene.contacts.push_back(contact);
  }
  return scene;
}

// Checks the corner forces' sums against the one-body closed form above (to 1e-9 m g).
void expectBlockClosedForm(double theta, const Eigen::Vector3d& push, double mu_s, double mu_d,
                           bool expect_stick) {
  const double N = 2.0 * kG * std::cos(theta);
  const Eigen::Vector3d load = Eigen::Vector3d(2.0 * kG * std::sin(theta), 0.0, 0.0) + push;
  ASSERT_EQ(load.norm() <= mu_s * N, expect_stick) << "the case is not what it claims";
  const Eigen::Vector3d want_friction =
      expect_stick ? Eigen::Vector3d(-load) : Eigen::Vector3d(-mu_d * N * load.normalized());
  core::SolverOptions options;
  options.tolerance = 1e-14;
  const core::CollisionResult result =
      core::computeResponse(blockOnIncline(theta, push, mu_s, mu_d), options);
  ASSERT_TRUE(result.islands[0].converged);
  double normal = 0.0;
  Eigen::Vector3d friction = Eigen::Vector3d::Zero();
  for (const auto& contact : result.impulses) {
    EXPECT_TRUE(contact.resting);
    EXPECT_EQ(contact.sticking, expect_stick);
    EXPECT_GE(contact.normal_force, 0.0);
    normal += contact.normal_force;
    friction += contact.friction_force;
    if (!expect_stick && contact.normal_force > 0.0) {  // each corner's force against the slip
      EXPECT_NEAR(contact.friction_force.normalized().dot(load.normalized()), -1.0, 1e-9);
    }
  }
  const double tol = 1e-9 * 2.0 * kG;
  EXPECT_NEAR(normal, N, tol);
  EXPECT_NEAR(friction.x(), want_friction.x(), tol);
  EXPECT_NEAR(friction.y(), want_friction.y(), tol);
  EXPECT_NEAR(friction.z(), 0.0, tol);
}

}  // namespace

// The incline: 20 degrees, push 15 N up the slope (-x). m g sin 20 = 6.710 N down the
// slope, so the load is L = 6.710 - 15 = -8.290 N (up the slope); N = m g cos 20 = 18.437 N.
// mu_s = 0.6 holds 11.06 N > 8.29 N: sticks, sum f = +8.290 N x. mu_s = mu_d = 0.3 holds 5.53 N
// < 8.29 N: slides up the slope, sum f = +0.3 x 18.437 N = +5.531 N x (before the fix: reported
// sliding with 6.33 N, each corner's force turned 24 degrees off the slip).
TEST(RestingBlock, InclinePushedUpSlopeSticksOrSlides) {
  const double theta = 20.0 * M_PI / 180.0;
  expectBlockClosedForm(theta, Eigen::Vector3d(-15.0, 0.0, 0.0), 0.6, 0.6, true);
  expectBlockClosedForm(theta, Eigen::Vector3d(-15.0, 0.0, 0.0), 0.3, 0.3, false);
}

// Down the slope: push 2 N down (+x), L = 8.710 N; mu 0.6 holds 11.06 N (sticks), mu 0.3 holds
// 5.53 N (slides down, sum f = -5.531 N x).
TEST(RestingBlock, InclinePushedDownSlopeSticksOrSlides) {
  const double theta = 20.0 * M_PI / 180.0;
  expectBlockClosedForm(theta, Eigen::Vector3d(2.0, 0.0, 0.0), 0.6, 0.6, true);
  expectBlockClosedForm(theta, Eigen::Vector3d(2.0, 0.0, 0.0), 0.3, 0.3, false);
}

// Sideways on the incline: push 5 N along y, L = (6.710, 5) N, |L| = 8.368 N; mu 0.6 sticks
// (11.06 N), mu 0.3 slides along L/|L| (oblique: the anisotropic corner blocks matter), sum
// f = -5.531 N L/|L|.
TEST(RestingBlock, InclinePushedSidewaysSticksOrSlides) {
  const double theta = 20.0 * M_PI / 180.0;
  expectBlockClosedForm(theta, Eigen::Vector3d(0.0, 5.0, 0.0), 0.6, 0.6, true);
  expectBlockClosedForm(theta, Eigen::Vector3d(0.0, 5.0, 0.0), 0.3, 0.3, false);
}

// On the floor (theta = 0, N = 19.62 N): push 5 N along (3, 4)/5 direction sticks at mu 0.6
// (11.77 N); 10 N along it slides at mu_s 0.4 (7.85 N) with mu_d 0.3: sum f = -5.886 N (3, 4)/5.
TEST(RestingBlock, FloorPushedObliquelySticksOrSlides) {
  expectBlockClosedForm(0.0, Eigen::Vector3d(3.0, 4.0, 0.0), 0.6, 0.6, true);
  expectBlockClosedForm(0.0, Eigen::Vector3d(6.0, 8.0, 0.0), 0.4, 0.3, false);
}

// --- The band mu_d N < |L| <= mu_s N (issue 22; docs/physics.md, "Resting contacts"): a block
// at rest whose tangential load lies between what dynamic and what static friction can hold has
// two answers that both satisfy the complementarity conditions, stuck (sum f = -L) and sliding
// (sum f = -mu_d N L/|L|). Static friction holds it: it must stick, as the single-contact closed
// form does. Every check below is Newton's second law for the block (m = 2 kg), from the one-body
// closed form computed here by hand, against the acceleration that the reported corner forces
// give it:
//   a = (F_ext + sum_i (F_i n + f_i)) / m,  I alpha = sum_i r_i x (F_i n + f_i)  (F_ext through
//   the centre, r_i from the centre to corner i);
//   |L| <= mu_s N: a = 0 and alpha = 0, every corner sticking inside its static cone;
//   |L| >  mu_s N: a = (|L| - mu_d N) / m along L/|L|, alpha = 0 (the argument above), every
//                  loaded corner's friction mu_d F_i against L.
// The whole scene may be turned by a rotation R (floor normal R z, corners R p, forces R F): the
// closed form is the same in the turned frame.
namespace {

constexpr double kBlockMass = 2.0;
constexpr double kBlockHalf = 0.1;  // half the edge of the 0.2 m cube

struct BandCase {
  double theta = 0.0;                              // incline angle [rad]
  Eigen::Vector3d push = Eigen::Vector3d::Zero();  // through the centre, incline frame [N]
  double mu_s = 0.6;
  double mu_d = 0.3;
  Eigen::Matrix3d turn = Eigen::Matrix3d::Identity();  // R: the whole scene turned
};

// The loads of the one-body closed form in the incline frame: normal N (pressing into the
// floor) and tangential L (in the plane).
double normalLoad(const BandCase& c) {
  return kBlockMass * kG * std::cos(c.theta) - c.push.z();
}
Eigen::Vector3d tangentialLoad(const BandCase& c) {
  return Eigen::Vector3d(kBlockMass * kG * std::sin(c.theta) + c.push.x(), c.push.y(), 0.0);
}

core::Scene bandScene(const BandCase& c) {
  core::Scene scene = blockOnIncline(c.theta, c.push, c.mu_s, c.mu_d);
  core::BodyState& block = scene.bodies[1];
  block.position = c.turn * block.position;
  block.force = c.turn * block.force;
  block.inertia = c.turn * block.inertia * c.turn.transpose();  // isotropic: unchanged
  for (core::Contact& contact : scene.contacts) {
    contact.point = c.turn * contact.point;
    contact.normal = c.turn * contact.normal;
  }
  return scene;
}

// Runs the case and checks Newton's second law for the block against the closed form.
void expectBandClosedForm(const BandCase& c, const std::string& label) {
  SCOPED_TRACE(label);
  const double N = normalLoad(c);
  const Eigen::Vector3d L = tangentialLoad(c);
  ASSERT_GT(N, 0.0);
  const bool stick = L.norm() <= c.mu_s * N;
  // Closed form, incline frame, then turned.
  const Eigen::Vector3d want_acceleration =
      stick ? Eigen::Vector3d::Zero()
            : Eigen::Vector3d((L.norm() - c.mu_d * N) / kBlockMass * L.normalized());
  const Eigen::Vector3d n = c.turn * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d slip = c.turn * L.normalized();

  core::SolverOptions options;
  options.tolerance = 1e-14;
  const core::Scene scene = bandScene(c);
  const core::CollisionResult result = core::computeResponse(scene, options);
  ASSERT_EQ(result.islands.size(), 1u);
  ASSERT_TRUE(result.islands[0].converged);
  EXPECT_EQ(result.islands[0].methodName(), "resting_iterative");

  const core::BodyState& block = scene.bodies[1];
  Eigen::Vector3d total = block.force;
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < result.impulses.size(); ++i) {
    const core::ContactImpulse& f = result.impulses[i];
    const Eigen::Vector3d force = f.normal_force * n + f.friction_force;
    total += force;
    moment += (scene.contacts[i].point - block.position).cross(force);
    EXPECT_TRUE(f.resting);
    EXPECT_GE(f.normal_force, 0.0);
    EXPECT_NEAR(f.friction_force.dot(n), 0.0, 1e-12 * kBlockMass * kG);
    if (stick) {
      EXPECT_TRUE(f.sticking) << "corner " << i;
      EXPECT_LE(f.friction_force.norm(), c.mu_s * f.normal_force * (1.0 + 1e-9) + 1e-12)
          << "corner " << i << " outside its static cone";
    } else {
      EXPECT_FALSE(f.sticking) << "corner " << i;
      EXPECT_NEAR(f.friction_force.norm(), c.mu_d * f.normal_force, 1e-9 * kBlockMass * kG);
      if (f.normal_force > 1e-9) {
        EXPECT_NEAR(f.friction_force.normalized().dot(slip), -1.0, 1e-9) << "corner " << i;
      }
    }
  }
  const double tol = 1e-9 * kG;  // [m/s^2]
  const Eigen::Vector3d acceleration = total / kBlockMass;
  EXPECT_LE((acceleration - c.turn * want_acceleration).norm(), tol)
      << "a = " << acceleration.transpose() << ", closed form "
      << (c.turn * want_acceleration).transpose();
  // alpha = I^-1 moment, I = m s^2 / 6 about every axis.
  const Eigen::Vector3d alpha = moment / (kBlockMass * 4.0 * kBlockHalf * kBlockHalf / 6.0);
  EXPECT_LE(alpha.norm(), tol / kBlockHalf) << "alpha = " << alpha.transpose();
}

// A load L = k N along the angle phi of the incline's plane, built by the push that gives it:
// P = L - m g sin theta x (plus a normal part pz, which changes N first).
BandCase loadCase(double theta, double k, double phi, double pz, double mu_s, double mu_d) {
  BandCase c;
  c.theta = theta;
  c.mu_s = mu_s;
  c.mu_d = mu_d;
  c.push.z() = pz;
  const double N = normalLoad(c);
  c.push.x() = k * N * std::cos(phi) - kBlockMass * kG * std::sin(theta);
  c.push.y() = k * N * std::sin(phi);
  return c;
}

}  // namespace

// The case: on the floor, mu_s = 0.6, mu_d = 0.3 (N = 19.62 N holds 11.77 N statically,
// 5.886 N dynamically), a push of 8 N along x: in the band, it must stick (a = 0, sum f = -8 N x),
// not slide with 5.886 N (which would give a = 1.057 m/s^2).
TEST(RestingBand, FourCornersInTheBandStick) {
  BandCase c;
  c.push = Eigen::Vector3d(8.0, 0.0, 0.0);
  expectBandClosedForm(c, "floor, 8 N along x");
  c.push = Eigen::Vector3d(0.0, 11.0, 0.0);  // near the static limit 11.77 N
  expectBandClosedForm(c, "floor, 11 N along y");
}

// Below mu_d N (sticks), inside the band (sticks), above mu_s N (slides, a = (|L| - mu_d N)/m):
// on the floor and on inclines of 10 and 25 degrees, the load along 8 directions of the plane
// (up, down and across the slope, and between), with pushes that also press the block into the
// incline (pz < 0, N grows) or pull it off (pz > 0, N shrinks).
TEST(RestingBand, LoadsBelowInsideAndAboveTheBandOnFloorsAndInclines) {
  const double mu_s = 0.6, mu_d = 0.3;
  for (const double theta_deg : {0.0, 10.0, 25.0}) {
    for (const double pz : {0.0, -6.0, 5.0}) {
      for (int j = 0; j < 8; ++j) {
        const double phi = j * M_PI / 4.0;
        for (const double k : {0.5 * mu_d, 0.9 * mu_d, 1.1 * mu_d, 0.5 * (mu_s + mu_d), 0.95 * mu_s,
                               1.05 * mu_s, 1.5 * mu_s}) {
          const BandCase c = loadCase(theta_deg * M_PI / 180.0, k, phi, pz, mu_s, mu_d);
          expectBandClosedForm(c, "theta " + std::to_string(theta_deg) + " deg, pz " +
                                      std::to_string(pz) + " N, phi " + std::to_string(j) +
                                      " x 45 deg, |L|/N " + std::to_string(k));
        }
      }
    }
  }
}

// The same closed form with the whole scene turned (the floor's normal not along z), and with
// other coefficients (mu_s = 1.0, mu_d = 0.2: a wide band; mu_s = 0.35, mu_d = 0.3: a narrow one).
TEST(RestingBand, TurnedScenesAndOtherCoefficients) {
  const Eigen::Matrix3d turns[] = {
      Eigen::Matrix3d::Identity(),
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1.0, 2.0, -0.5).normalized()).toRotationMatrix(),
      Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix(),  // floor upside down
  };
  for (const auto& [mu_s, mu_d] : {std::pair{1.0, 0.2}, std::pair{0.35, 0.3}}) {
    for (const Eigen::Matrix3d& turn : turns) {
      for (const double k : {0.5 * mu_d, 0.5 * (mu_s + mu_d), 0.98 * mu_s, 1.2 * mu_s}) {
        BandCase c = loadCase(15.0 * M_PI / 180.0, k, 2.0, -3.0, mu_s, mu_d);
        c.turn = turn;
        expectBandClosedForm(c, "mu_s " + std::to_string(mu_s) + ", mu_d " + std::to_string(mu_d) +
                                    ", |L|/N " + std::to_string(k));
      }
    }
  }
}

// Mixed: a block (4 kg, 0.2 m cube) on the floor on four corners (mu_s = 0.5, mu_d = 0.1) and a
// second one (2 kg, the same cube) on it on four corners (mu_s = 0.6, mu_d = 0.5), the top one
// pushed with P = 16 N along x through its centre. One-body closed forms: the top one needs 16 N
// > 0.6 x 2 g = 11.77 N to stick, so it slides with a_top = (16 - 0.5 x 2 g) / 2 = 3.095 m/s^2 and
// drags the bottom one with 0.5 x 2 g = 9.81 N; the floor holds the bottom one (N = 6 g =
// 58.86 N) with at most 0.5 N = 29.43 N, at least 0.1 N = 5.886 N sliding: 9.81 N is in its band,
// so it sticks (a_bottom = 0). With P = 10 N (< 11.77 N, and 10 N in the floor's band) both stick.
// Neither tips (moments about the front edges: the drag 9.81 N x 0.2 m < 4 g x 0.1 m for the
// bottom one, 16 N x 0.1 m < 2 g x 0.1 m for the top one, 10 N x 0.3 m < 6 g x 0.1 m for both).
// Third case: the top block already slides along x at 0.5 m/s (the island then skips the all-stick
// step: its corners get -mu_d F_n x), pushed with 10 N: a_top = (10 - 9.81) / 2 = 0.095 m/s^2, and
// the bottom one, dragged with 9.81 N, still sticks.
TEST(RestingBand, TopBlockSlidesWhileTheBottomOneSticksInItsBand) {
  for (const auto& [push, already_sliding] :
       {std::pair{16.0, false}, std::pair{10.0, false}, std::pair{10.0, true}}) {
    SCOPED_TRACE("push " + std::to_string(push) + (already_sliding ? ", sliding" : ""));
    core::BodyState floor;
    floor.id = "floor";
    core::BodyState bottom;
    bottom.id = "bottom";
    bottom.mass = 4.0;
    bottom.inertia = Eigen::Matrix3d::Identity() * (4.0 * 0.04 / 6.0);
    bottom.position = {0.0, 0.0, 0.1};
    bottom.force = {0.0, 0.0, -4.0 * kG};
    core::BodyState top = bottom;
    top.id = "top";
    top.mass = 2.0;
    top.inertia = Eigen::Matrix3d::Identity() * (2.0 * 0.04 / 6.0);
    top.position = {0.0, 0.0, 0.3};
    top.force = {push, 0.0, -2.0 * kG};
    if (already_sliding) top.linear_velocity = {0.5, 0.0, 0.0};
    core::Scene scene;
    scene.bodies = {floor, bottom, top};
    for (const double z : {0.0, 0.2}) {
      for (const double x : {-0.1, 0.1}) {
        for (const double y : {-0.1, 0.1}) {
          core::Contact contact;
          contact.body_a = z == 0.0 ? "floor" : "bottom";
          contact.body_b = z == 0.0 ? "bottom" : "top";
          contact.point = {x, y, z};
          contact.static_friction = z == 0.0 ? 0.5 : 0.6;
          contact.dynamic_friction = z == 0.0 ? 0.1 : 0.5;
          scene.contacts.push_back(contact);
        }
      }
    }
    const bool top_slides = already_sliding || push > 0.6 * 2.0 * kG;
    core::SolverOptions options;
    options.tolerance = 1e-14;
    const core::CollisionResult result = core::computeResponse(scene, options);
    ASSERT_EQ(result.islands.size(), 1u);
    ASSERT_TRUE(result.islands[0].converged);
    // Newton for each block from the reported forces (+F on b, -F on a).
    Eigen::Vector3d on_bottom = bottom.force, on_top = top.force;
    for (std::size_t i = 0; i < 8; ++i) {
      const core::ContactImpulse& f = result.impulses[i];
      const Eigen::Vector3d force = f.normal_force * Eigen::Vector3d::UnitZ() + f.friction_force;
      const bool lower = i < 4;
      if (lower) {
        on_bottom += force;
        EXPECT_TRUE(f.sticking) << "floor corner " << i;
        EXPECT_LE(f.friction_force.norm(), 0.5 * f.normal_force * (1.0 + 1e-9) + 1e-12);
      } else {
        on_bottom -= force;
        on_top += force;
        EXPECT_EQ(f.sticking, !top_slides) << "top corner " << i;
      }
    }
    const double tol = 1e-9 * kG;
    EXPECT_LE((on_bottom / 4.0).norm(), tol) << on_bottom.transpose();
    const Eigen::Vector3d a_top(top_slides ? (push - 0.5 * 2.0 * kG) / 2.0 : 0.0, 0.0, 0.0);
    EXPECT_LE((on_top / 2.0 - a_top).norm(), tol) << on_top.transpose();
  }
}

}  // namespace

// The all-stick sweeps' block solve on a prepared block (prepareFrictionCone(), once per contact)
// against the definition of its answer, the minimizer of f(x) = x.b + x^T A x / 2 over the cone
// |x_t| <= mu x_n: checked by convexity, f(x) <= f(y) for every y sampled in the cone (far, and
// near x along random directions brought back into the cone), on random blocks A = J J^T of rank
// 3, 2 and 1 (a redundant contact's singular block; then b in A's range, where f is bounded
// below) in random frames; and the answer is the same
// to the last bit as the one-shot solveFrictionCone() the solver used before.
TEST(RestingAllStick, PreparedConeBlockMinimizesOverTheCone) {
  std::mt19937 random(20261126);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto vec = [&] { return Eigen::Vector3d(normal(random), normal(random), normal(random)); };
  for (int trial = 0; trial < 300; ++trial) {
    const int rank = 1 + trial % 3;
    Eigen::Matrix3d J = Eigen::Matrix3d::Zero();
    for (int k = 0; k < rank; ++k) J.col(k) = vec();
    const Eigen::Matrix3d A = J * J.transpose();
    const Eigen::Vector3d n = vec().normalized();
    const Eigen::Vector3d t1 = n.unitOrthogonal();
    const Eigen::Vector3d t2 = n.cross(t1);
    const double mu = trial % 7 == 0 ? 0.0 : 0.05 + 1.5 * unit(random);
    // Full rank: any b. Singular: b in A's range (otherwise f may fall without bound in the cone).
    const Eigen::Vector3d b = rank == 3 ? Eigen::Vector3d(3.0 * vec()) : Eigen::Vector3d(A * vec());
    const core::FrictionConeBlock block = core::prepareFrictionCone(A, n, t1, t2, mu);
    const Eigen::Vector3d x = core::solveFrictionCone(block, b);
    const Eigen::Vector3d once = core::solveFrictionCone(A, b, n, t1, t2, mu);
    ASSERT_EQ(x, once) << "trial " << trial;
    const auto f = [&](const Eigen::Vector3d& y) { return y.dot(b) + 0.5 * y.dot(A * y); };
    // Into the cone: the nearest point of it (Euclidean projection).
    const auto project = [&](const Eigen::Vector3d& y) -> Eigen::Vector3d {
      const double y_n = y.dot(n);
      const Eigen::Vector3d y_t = y - y_n * n;
      const double r = y_t.norm();
      if (r <= mu * y_n) return y;
      if (mu * r <= -y_n) return Eigen::Vector3d::Zero();
      const double s = (y_n + mu * r) / (1.0 + mu * mu);
      return s * n + (r > 0.0 ? Eigen::Vector3d(mu * s * y_t / r) : Eigen::Vector3d::Zero());
    };
    const double x_n = x.dot(n);
    const double scale = 1.0 + x.norm();
    EXPECT_GE(x_n, -1e-12 * scale) << "trial " << trial;
    EXPECT_LE((x - x_n * n).norm(), mu * x_n + 1e-9 * scale) << "trial " << trial;
    const double fx = f(x);
    const double slack = 1e-9 * (1.0 + std::abs(fx) + b.norm() * scale);
    for (int k = 0; k < 400; ++k) {
      const double reach = k < 200 ? 3.0 : 1e-3 * scale;
      const Eigen::Vector3d y = project((k < 200 ? Eigen::Vector3d::Zero() : x) + reach * vec());
      ASSERT_LE(fx, f(y) + slack) << "trial " << trial << " sample " << k;
    }
  }
}

// --- No stuck answer (docs/physics.md, "No stuck answer"; stick_certificate.h). A block
// (m = 2 kg, 0.2 m cube, I = m s^2 / 6 about every axis) on four corners (+-0.1, +-0.1, 0),
// centre at z = 0.1, under gravity, turning about the vertical at w, its corners' slip w r below
// the resting threshold (so posed without a slip direction). Closed form: each corner's free
// acceleration is -g z - w^2 r_h (isotropic inertia: no angular acceleration); the range of the
// pair block W_pp = J_p M^-1 J_p^T is that of J_p, whose orthogonal complement for two points
// d = r_i - r_j apart is the single direction (d, -d) / (sqrt(2) |d|) (the rigid motions cannot
// change the points' distance), so the pair's least-squares residual is
// |(a_i - a_j).d| / (sqrt(2) |d|) = w^2 |d| / sqrt(2): no force cancels it.
struct TurningBlock {
  std::vector<core::BodyState> states;
  std::vector<core::RigidBody> bodies;
  std::vector<core::ContactPoint> contacts;
  std::vector<int> island{0, 1, 2, 3};
  core::ContactProblem problem;
  std::vector<Eigen::Vector3d> free;

  // The four bottom corners on the floor (body 0), or the given contacts.
  TurningBlock(double w, double vertical_force, std::vector<core::ContactPoint> given = {}) {
    core::BodyState floor;
    floor.id = "floor";
    core::BodyState box;
    box.id = "box";
    box.mass = 2.0;
    box.inertia = Eigen::Matrix3d::Identity() * 2.0 * 0.04 / 6.0;
    box.position = {0.0, 0.0, 0.1};
    box.angular_velocity = {0.0, 0.0, w};
    box.force = {0.0, 0.0, vertical_force};
    states = {floor, box};
    bodies = {core::makeRigidBody(floor), core::makeRigidBody(box)};
    for (const double x : {-0.1, 0.1}) {
      for (const double y : {-0.1, 0.1}) {
        contacts.emplace_back(0, 1, Eigen::Vector3d(x, y, 0.0), Eigen::Vector3d::UnitZ(), 0.0, 0.5,
                              0.4);
      }
    }
    if (!given.empty()) {
      contacts = std::move(given);
      island.resize(contacts.size());
      for (std::size_t i = 0; i < island.size(); ++i) island[i] = static_cast<int>(i);
    }
    problem.buildResting(states, bodies, contacts, island, 0.05);  // slips of w r < 0.05 m/s rest
    for (std::size_t i = 0; i < problem.size(); ++i) free.push_back(problem.relativeMotion(i));
  }
};

TEST(RestingNoStuckAnswer, PairResidualIsTheCentripetalPartNoForceCancels) {
  for (const double w : {0.0, 0.02, 0.3}) {
    TurningBlock block(w, -2.0 * kG);
    ASSERT_EQ(block.problem.size(), 4u);
    for (std::size_t i = 0; i < 4; ++i) {
      ASSERT_TRUE(block.problem.contact(i).slip_direction.isZero(0.0));
      for (std::size_t j = i + 1; j < 4; ++j) {
        const double d = (block.contacts[i].point - block.contacts[j].point).norm();
        EXPECT_NEAR(core::pairResidual(block.problem, block.free, i, j), w * w * d / std::sqrt(2.0),
                    1e-12)
            << "w " << w << " pair " << i << ", " << j;
      }
    }
  }
}

// The decision: turning on the table (any two corners would need the impossible, and one corner
// alone cannot hold the block: its opposite corner falls) -> proven; at rest (the four corners
// hold it) or turning while pulled off the table (every corner separates, F = 0 is stuck) -> not
// proven, and those are the cases the sweeps answer as before.
TEST(RestingNoStuckAnswer, ProvenOnlyWhenNoCornerSplitCanHoldTheTurningBlock) {
  const double tolerance = 1e-9 * kG;
  EXPECT_TRUE(core::noStuckAnswer(TurningBlock(0.02, -2.0 * kG).problem,
                                  TurningBlock(0.02, -2.0 * kG).free, tolerance));
  EXPECT_FALSE(core::noStuckAnswer(TurningBlock(0.0, -2.0 * kG).problem,
                                   TurningBlock(0.0, -2.0 * kG).free, tolerance));
  EXPECT_FALSE(core::noStuckAnswer(TurningBlock(0.02, 2.0 * kG).problem,
                                   TurningBlock(0.02, 2.0 * kG).free, tolerance));
  // Below the tolerance the residual proves nothing: w^2 |d| / sqrt(2) <= 2 tolerance.
  const double w_small = std::sqrt(tolerance * std::sqrt(2.0) / 0.2);
  EXPECT_FALSE(core::noStuckAnswer(TurningBlock(w_small, -2.0 * kG).problem,
                                   TurningBlock(w_small, -2.0 * kG).free, tolerance));
}

// The resting analysis of the turning block: the all-stick sweeps stop at the certificate (32
// sweeps instead of running to their cap) and the iterative solver answers from the restored
// problem; the vertical balance (sum F_n = m g: the block's centre neither rises nor falls),
// every force in its static cone (RestingSlowSlip below checks the answer itself). At rest the
// answer is the all-stick one, converged, before the certificate's sweep.
TEST(RestingNoStuckAnswer, TurningBlockSkipsTheAllStickSweeps) {
  core::SolverOptions options;
  TurningBlock turning(0.02, -2.0 * kG);
  std::vector<core::ContactImpulse> forces;
  const core::SolveReport report = core::solveRestingIsland(turning.problem, options, forces);
  EXPECT_LE(report.iterations, 32 + options.max_iterations);
  double normal = 0.0;
  for (const core::ContactImpulse& f : forces) {
    EXPECT_GE(f.normal_force, 0.0);
    EXPECT_LE(f.friction_force.norm(), 0.5 * f.normal_force + 1e-9);
    normal += f.normal_force;
  }
  EXPECT_NEAR(normal, 2.0 * kG, 1e-4);
  TurningBlock still(0.0, -2.0 * kG);
  const core::SolveReport rest = core::solveRestingIsland(still.problem, options, forces);
  EXPECT_TRUE(rest.converged);
  EXPECT_LT(rest.iterations, 32u);
  for (const core::ContactImpulse& f : forces) EXPECT_TRUE(f.sticking);
}

// One contact alone can hold: the turning block on a single floor point under its centre (on the
// turning axis: no centripetal part) touching a wall (immovable, normal -x) at the middle of its
// +x face, (0.1, 0, 0.1). The pair is inconsistent (closed form as above, d = (-0.1, 0, -0.1):
// residual w^2 |(0.1, 0, 0).d| / (sqrt(2) |d|) = w^2 / 20), but the floor force m g stops the
// floor point and the wall point accelerates away from the wall at w^2 0.1: a stuck answer
// exists (floor loaded, wall separating), so nothing is proven, and the analysis converges to
// it: N = m g at the floor, no friction, nothing at the wall.
TEST(RestingNoStuckAnswer, OneContactHoldingTheBlockIsNotRuledOut) {
  const double w = 0.02;
  const std::vector<core::ContactPoint> given = {
      core::ContactPoint(0, 1, Eigen::Vector3d(0.0, 0.0, 0.0), Eigen::Vector3d::UnitZ(), 0.0, 0.5,
                         0.4),
      core::ContactPoint(0, 1, Eigen::Vector3d(0.1, 0.0, 0.1), -Eigen::Vector3d::UnitX(), 0.0, 0.5,
                         0.4)};
  TurningBlock block(w, -2.0 * kG, given);
  ASSERT_EQ(block.problem.size(), 2u);
  EXPECT_NEAR(core::pairResidual(block.problem, block.free, 0, 1), w * w / 20.0, 1e-12);
  EXPECT_FALSE(core::noStuckAnswer(block.problem, block.free, 1e-9 * kG));
  core::SolverOptions options;
  std::vector<core::ContactImpulse> forces;
  const core::SolveReport report = core::solveRestingIsland(block.problem, options, forces);
  EXPECT_TRUE(report.converged);
  EXPECT_NEAR(forces[0].normal_force, 2.0 * kG, 1e-9);
  EXPECT_NEAR(forces[0].friction_force.norm(), 0.0, 1e-9);
  EXPECT_NEAR(forces[1].normal_force, 0.0, 1e-9);
}

// --- Slow slips (docs/physics.md, "Slow slips"). The turning block above, w = 0.02 and 0.2 rad/s:
// its corners slip at w |r| = 2.8 and 28 mm/s, below the resting velocity (0.05 m/s), and no stuck
// answer exists (the centripetal parts). Coulomb's law at that nonzero slip: each corner's friction
// -mu_d N_i along its own motion w z x r_i. Closed form: the friction forces circulate (no net
// force, and their moments about the horizontal axes through the centre cancel: sum F = 0 at the
// common depth), so the corners carry m g in total (any split of equal moments, e.g. m g / 4 each)
// and the block's only acceleration is the angular alpha_z = -mu_d m g |r| / I (every corner at |r|
// = 0.1 sqrt 2), I = m s^2 / 6: each corner's acceleration a'_i = alpha_z z x r_i - w^2 r_i, a'_n =
// 0. Friction at mu_d N (below the static band's top mu_s N: the corners slide). The answer is the
// solver's converged one: far below the sweep cap (52 sweeps at w = 0.02), and the same under a
// doubled cap. (Before: 10,032 sweeps at the cap; at w = 0.2 the radial answer after 19,461.)
TEST(RestingSlowSlip, TurningBlockSlidesAgainstItsCornersMotion) {
  const double m = 2.0, mu_d = 0.4, inertia = 2.0 * 0.04 / 6.0;
  const double r = 0.1 * std::sqrt(2.0);
  const double alpha = -mu_d * m * kG * r / inertia;
  for (const double w : {0.02, 0.2}) {  // corner slips 2.8 and 28 mm/s, both below 0.05 m/s
    std::vector<core::ContactImpulse> answers[2];
    for (const std::size_t cap : {std::size_t{10000}, std::size_t{20000}}) {
      SCOPED_TRACE("w " + std::to_string(w) + " cap " + std::to_string(cap));
      TurningBlock block(w, -m * kG);
      core::SolverOptions options;
      options.max_iterations = cap;
      std::vector<core::ContactImpulse>& forces = answers[cap == 10000 ? 0 : 1];
      const core::SolveReport report = core::solveRestingIsland(block.problem, options, forces);
      EXPECT_TRUE(report.converged);
      EXPECT_LT(report.iterations, 100u);  // 32 all-stick sweeps + about 20
      double normal = 0.0;
      for (std::size_t i = 0; i < 4; ++i) {
        const core::ContactImpulse& f = forces[i];
        const Eigen::Vector3d p = block.contacts[i].point;  // r_i: the centre is above the origin
        const Eigen::Vector3d motion = Eigen::Vector3d(0.0, 0.0, w).cross(p);
        normal += f.normal_force;
        EXPECT_GE(f.normal_force, 0.0);
        EXPECT_FALSE(f.sticking);
        // Coulomb at the slip: -mu_d N along the corner's motion.
        EXPECT_NEAR((f.friction_force + mu_d * f.normal_force * motion.normalized()).norm(), 0.0,
                    1e-9 * m * kG)
            << "corner " << i;
        // The corner's acceleration after the forces, against the closed form.
        const Eigen::Vector3d expected =
            alpha * Eigen::Vector3d::UnitZ().cross(p) - w * w * Eigen::Vector3d(p.x(), p.y(), 0.0);
        EXPECT_NEAR((block.problem.relativeMotion(i) - expected).norm(), 0.0,
                    1e-9 * std::abs(alpha))
            << "corner " << i;
      }
      EXPECT_NEAR(normal, m * kG, 1e-9 * m * kG);
    }
    for (std::size_t i = 0; i < 4; ++i) {
      EXPECT_EQ(answers[0][i].normal_force, answers[1][i].normal_force);
      EXPECT_EQ(answers[0][i].friction_force, answers[1][i].friction_force);
    }
  }
}
