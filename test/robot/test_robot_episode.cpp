// Robots in impact episodes (core::computeBodyEpisode() with robot::RobotEpisodeBody;
// docs/robots.md, "Robots in episodes") against references written here: a pendulum swinging
// down onto a floor (its time of first contact from an independent fixed-step integration of
// theta'' = -(3 g / 2 L) cos(theta), its speed there from energy, the impact from the single-link
// closed form with the reflected inertia I / r^2), the flight of the shipped arm under each torque
// model against conservation laws (no gravity and no torque, or gravity compensated: kinetic
// energy constant; a constant torque: its work tau . (q1 - q0)), and the arm's fingertips striking
// a box on a table: no contact passed through along a finely stepped reference path, no energy
// gained under Stronge; receding bodies (the bound by a convex pair's normal rate) that come back:
// a ball thrown up from a small sphere (closed-form return time), a pendulum's ball swinging away
// from a small sphere and back (an independent RK4 integration), and a turning capsule that
// closes on a dot while its frame recedes (the gap sampled along the uniform rotation); a box held
// on the table while the arm flies, sliding or spinning, against Coulomb's closed forms (the
// slide's v^2 / (2 mu_d g), the spin's stop after w0^2 / (2 mu_d m g r / I_zz)), and sliding
// while it spins against an independent RK4 integration of the planar Coulomb motion on its four
// corners.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "arm_box_scene.h"
#include "collision_response/core/body_episode.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/rigid_episode_body.h"
#include "collision_response/robot/robot_episode_body.h"
#include "collision_response/robot/urdf_loader.h"

namespace cr = collision_response::core;
namespace rb = collision_response::robot;
using Eigen::Vector3d;
using Eigen::VectorXd;

namespace {

const std::string kDir = ROBOT_TEST_DIR;
const std::string kArm7 = ARM7_URDF;

constexpr double kInf = std::numeric_limits<double>::infinity();
// pendulum.urdf: a uniform rod, m = 2 kg, L = 1 m, hinged at the origin about z.
constexpr double kMass = 2.0, kLength = 1.0, kInertia = kMass * kLength * kLength / 3.0;
constexpr double kG = 9.81;
constexpr double kFloor = 0.8;  // the floor is the plane y = -kFloor

// Closed-form geometry: geometry body 0 the floor (plane y = -kFloor, normal +y), body 1 the rod,
// its only feature the tip (L, 0, 0) in the rod's frame.
class TipOnFloor final : public cr::GapQuery {
 public:
  void gaps(const std::vector<cr::BodyState>& bodies, double range,
            std::vector<cr::GapContact>& out) const override {
    out.clear();
    const Vector3d tip = bodies[1].position + bodies[1].orientation * Vector3d(kLength, 0, 0);
    cr::GapContact c;
    c.body_a = 0;
    c.body_b = 1;
    c.gap = tip.y() + kFloor;
    c.point = tip;
    c.normal = Vector3d::UnitY();
    c.restitution = restitution;
    if (c.gap <= range) out.push_back(c);
  }
  double radius(int body) const override { return body == 0 ? kInf : kLength; }
  int bodyCount() const override { return 2; }
  double restitution = 0.5;
};

// theta'' = -(3 g / 2 L) cos(theta), RK4 at step h from theta = 0 at rest, until the tip reaches
// the floor (L sin(theta) = -kFloor), the crossing located by linear interpolation in the step.
double referenceContactTime(double h) {
  double th = 0.0, w = 0.0, t = 0.0;
  const auto acc = [](double x) { return -1.5 * kG / kLength * std::cos(x); };
  for (;;) {
    const double k1t = w, k1w = acc(th);
    const double k2t = w + 0.5 * h * k1w, k2w = acc(th + 0.5 * h * k1t);
    const double k3t = w + 0.5 * h * k2w, k3w = acc(th + 0.5 * h * k2t);
    const double k4t = w + h * k3w, k4w = acc(th + h * k3t);
    const double th1 = th + h / 6 * (k1t + 2 * k2t + 2 * k3t + k4t);
    const double w1 = w + h / 6 * (k1w + 2 * k2w + 2 * k3w + k4w);
    const double g0 = kLength * std::sin(th) + kFloor, g1 = kLength * std::sin(th1) + kFloor;
    if (g1 <= 0.0) return t + h * g0 / (g0 - g1);
    th = th1;
    w = w1;
    t += h;
  }
}

struct Pendulum {
  std::unique_ptr<rb::RobotEpisodeBody> rod;
  std::unique_ptr<cr::RigidEpisodeBody> floor;
  std::vector<cr::EpisodeBody*> bodies;
  std::vector<cr::EpisodePart> parts;
  TipOnFloor geometry;
  cr::EpisodeOptions options;
};

Pendulum pendulum() {
  Pendulum p;
  rb::ArticulatedBody rod = rb::robotFromUrdfFile(kDir + "/pendulum.urdf");
  rod.setState(VectorXd::Zero(1), VectorXd::Zero(1));
  rod.setLoads(VectorXd::Zero(1), Vector3d::Zero());  // torque model none
  const int link = rod.linkIndex("rod");
  p.rod = std::make_unique<rb::RobotEpisodeBody>(std::move(rod));
  cr::BodyState floor;
  floor.id = "floor";
  p.floor = std::make_unique<cr::RigidEpisodeBody>(floor);
  p.bodies = {p.floor.get(), p.rod.get()};
  p.parts = {{0, 0}, {1, link}};
  p.options.gravity = Vector3d(0.0, -kG, 0.0);
  p.options.horizon = 2.0;
  p.options.max_impacts = 1;
  p.options.contact_tolerance = 1e-5;
  p.options.solver.law = cr::ImpactLaw::kNewton;
  return p;
}

double pendulumEnergy(double theta, double rate) {
  return 0.5 * kInertia * rate * rate + kMass * kG * 0.5 * kLength * std::sin(theta);
}

}  // namespace

// The rod falls from horizontal at rest; its tip meets the floor at sin(theta) = -0.8.
TEST(RobotEpisode, PendulumFirstContactTimeSpeedAndImpact) {
  Pendulum p = pendulum();
  const cr::BodyEpisodeResult r = cr::computeBodyEpisode(p.bodies, p.parts, p.geometry, p.options);
  ASSERT_GE(r.impacts.size(), 1u);
  const cr::BodyEpisodeImpact& first = r.impacts[0];
  ASSERT_EQ(first.contacts.size(), 1u);
  // The reference's contact time converges to ~1e-12 at h = 1e-5 (RK4, error ~ h^4).
  const double t_ref = referenceContactTime(1e-5);
  const double theta_c = std::asin(-kFloor / kLength);
  const double rate_c = -std::sqrt(3.0 * kG / kLength * -std::sin(theta_c));  // energy
  const double tip_speed = std::abs(kLength * std::cos(theta_c) * rate_c);
  // Found within the tolerance before the true contact: gap in [0, tol] at the impact.
  EXPECT_LE(first.time, t_ref + 1e-9);
  EXPECT_GE(first.time, t_ref - p.options.contact_tolerance / tip_speed - 1e-9);
  // The state at the impact: energy conserved over the flight (kRobotFlightTolerance).
  const double u_n = first.impulses[0].normal_velocity_before;
  const double rate_before = u_n / (kLength * std::cos(theta_c));  // approximately, see below
  EXPECT_NEAR(u_n, -tip_speed, 2e-4 * tip_speed);  // the impact lies within 1e-5 m of theta_c
  // Single-DOF closed form, frictionless Newton: the joint rate reverses times e, and the impulse
  // is (1 + e) |u_n| times the reflected inertia I / r^2 at the tip (r = L cos(theta), the lever
  // of the normal y about the hinge).
  const double e = p.geometry.restitution;
  ASSERT_EQ(first.velocities_after[1].size(), 1);
  const double rate_after = first.velocities_after[1](0);
  (void)rate_before;
  // theta at the impact from the rod's tip point (x = L cos(theta), y = L sin(theta)).
  const double theta_i = std::atan2(first.contacts[0].point.y(), first.contacts[0].point.x());
  const double r_lever = kLength * std::cos(theta_i);
  const double rate_i = u_n / r_lever;
  EXPECT_NEAR(rate_after, -e * rate_i, 1e-9 * std::abs(rate_i));
  EXPECT_NEAR(first.impulses[0].normal_impulse,
              (1.0 + e) * std::abs(u_n) * kInertia / (r_lever * r_lever),
              1e-9 * first.impulses[0].normal_impulse);
  // Energy before the impact from the flight: 0 at the start (theta = 0 at rest).
  EXPECT_NEAR(pendulumEnergy(theta_i, rate_i), 0.0, 1e-8 * kMass * kG * kLength);
  // The episode ends at the second impact (max_impacts 1): the flight in between conserves
  // (1/2) I w^2 + m g (L/2) sin(theta).
  EXPECT_EQ(r.end, cr::EpisodeEnd::kImpactCap);
  const rb::ArticulatedBody& rod = p.rod->robot();
  const double after = pendulumEnergy(theta_i, rate_after);
  EXPECT_NEAR(pendulumEnergy(rod.jointPositions()(0), rod.jointVelocities()(0)), after,
              1e-8 * kMass * kG * kLength);
  EXPECT_GT(r.end_time, first.time);
}

// Bounces down to rest on the floor: sustained contact, the rod sticking (frictionless: sliding
// is allowed, but the tip cannot slide along the floor without turning the rod upward).
TEST(RobotEpisode, PendulumSettlesInSustainedContactWithoutGainingEnergy) {
  Pendulum p = pendulum();
  p.options.max_impacts = 200;
  p.options.horizon = 20.0;
  p.geometry.restitution = 0.3;
  const cr::BodyEpisodeResult r = cr::computeBodyEpisode(p.bodies, p.parts, p.geometry, p.options);
  ASSERT_EQ(r.end, cr::EpisodeEnd::kSustainedContact) << cr::toString(r.end);
  ASSERT_FALSE(r.resting.empty());
  // At rest on the tip: the tip's normal force holds the rod's weight moment about the hinge,
  // N L cos(theta) = m g (L/2) cos(theta): N = m g / 2.
  double normal = 0.0;
  for (const auto& f : r.resting) normal += f.normal_force;
  const double theta = p.rod->robot().jointPositions()(0);
  EXPECT_NEAR(std::sin(theta), -kFloor, 1e-4);
  EXPECT_NEAR(normal, 0.5 * kMass * kG, 1e-3 * kMass * kG);
  // Each impact keeps the energy at most what it was (e < 1).
  double energy = 0.0;
  for (const cr::BodyEpisodeImpact& impact : r.impacts) {
    const double th = std::atan2(impact.contacts[0].point.y(), impact.contacts[0].point.x());
    const double now = pendulumEnergy(th, impact.velocities_after[1](0));
    EXPECT_LE(now, energy + 1e-7);
    energy = now;
  }
}

// No contact, no gravity, no torque: the arm's kinetic energy is constant over a 0.3 s flight
// through large joint motions; under gravity compensation with gravity, the same motion.
TEST(RobotEpisode, ArmFlightConservesEnergyUnderNoneAndGravityCompensation) {
  const auto arm = [](bool compensated) {
    rb::ArticulatedBody a = rb::robotFromUrdfFile(kArm7);
    VectorXd q = VectorXd::Zero(a.jointCount()), qdot = VectorXd::Zero(a.jointCount());
    for (int j = 0; j < 7; ++j) {
      q(j) = 0.3 * std::sin(1.0 + j);
      qdot(j) = 2.0 * std::cos(0.7 * j);
    }
    a.setState(q, qdot);
    if (compensated) {
      a.setGravityCompensation(Vector3d(0, 0, -9.81));
    } else {
      a.setLoads(VectorXd::Zero(a.jointCount()), Vector3d::Zero());
    }
    return rb::RobotEpisodeBody(std::move(a));
  };
  rb::RobotEpisodeBody none = arm(false);
  rb::RobotEpisodeBody held = arm(true);
  none.setGravity(Vector3d::Zero());
  held.setGravity(Vector3d(0, 0, -9.81));
  const double e0 = none.kineticEnergy();
  const VectorXd q0 = none.robot().jointPositions();
  for (int k = 0; k < 30; ++k) {
    none.advance(0.01);
    held.advance(0.01);
  }
  EXPECT_GT((none.robot().jointPositions() - q0).norm(), 0.5);  // it did move a lot
  EXPECT_NEAR(none.kineticEnergy(), e0, 1e-8 * e0);
  EXPECT_NEAR(held.kineticEnergy(), e0, 1e-8 * e0);
  EXPECT_LT((held.robot().jointPositions() - none.robot().jointPositions()).norm(), 1e-7);
  EXPECT_LT((held.robot().jointVelocities() - none.robot().jointVelocities()).norm(), 1e-7);
}

// A constant joint torque without gravity: the kinetic energy gained is the torque's work,
// tau . (q(t) - q(0)).
TEST(RobotEpisode, ArmFlightUnderConstantEffortGainsTheTorquesWork) {
  rb::ArticulatedBody a = rb::robotFromUrdfFile(kArm7);
  VectorXd q = VectorXd::Zero(a.jointCount()), qdot = VectorXd::Zero(a.jointCount());
  VectorXd tau = VectorXd::Zero(a.jointCount());
  for (int j = 0; j < 7; ++j) {
    q(j) = 0.2 * std::cos(0.5 + j);
    qdot(j) = 0.5 * std::sin(1.3 * j);
    tau(j) = 3.0 * std::cos(2.1 * j);
  }
  a.setState(q, qdot);
  a.setLoads(tau, Vector3d::Zero());
  rb::RobotEpisodeBody body(std::move(a));
  body.setGravity(Vector3d::Zero());
  const double e0 = body.kineticEnergy();
  body.advance(0.2);
  const double work = tau.dot(body.robot().jointPositions() - q);
  EXPECT_GT(std::abs(work), 0.1);
  EXPECT_NEAR(body.kineticEnergy() - e0, work, 1e-8 * (e0 + std::abs(work)));
}

// The arm's fingertips strike the box on the table. Reference path: the arm's flight stepped at
// 20 us from the start state (no contact can happen before the episode's first impact if it was
// found in time): along it the fingers' signed distance to the box and the table stays >= 0 until
// the first impact's time. Energy: no kinetic energy gained (Stronge; gravity compensated, the box
// stays on the table).
TEST(RobotEpisode, ArmStrikesBoxNoContactMissedNoEnergyGained) {
  using collision_response::testing::armBoxScene;
  auto s = armBoxScene(kArm7);
  const double energy0 = s.arm->kineticEnergy() + s.box->kineticEnergy();
  auto reference = armBoxScene(kArm7);
  const cr::BodyEpisodeResult r = cr::computeBodyEpisode(s.bodies, s.parts, *s.geometry, s.options);
  ASSERT_GE(r.impacts.size(), 1u);
  // The first impact is the fingertips on the box (parts 2, 3 of the arm: body 2).
  bool arm_on_box = false;
  for (const auto& c : r.impacts[0].contacts)
    arm_on_box =
        arm_on_box || ((c.body_a == 1 && c.body_b == 2) || (c.body_a == 2 && c.body_b == 1));
  EXPECT_TRUE(arm_on_box);
  const double t1 = r.impacts[0].time;
  EXPECT_GT(t1, 0.0);
  std::vector<cr::BodyState> states = reference.part_states;
  std::vector<cr::GapContact> gaps;
  const double h = 2e-5;
  double smallest = kInf;
  for (double t = 0.0; t + h <= t1; t += h) {
    reference.arm->advance(h);
    for (std::size_t g = 0; g < reference.parts.size(); ++g)
      reference.bodies[reference.parts[g].body]->partPose(reference.parts[g].part, states[g]);
    reference.geometry->gaps(states, 0.05, gaps);
    for (const auto& gap : gaps) {
      if (gap.body_a >= 2 || gap.body_b >= 2) smallest = std::min(smallest, gap.gap);
    }
  }
  EXPECT_GE(smallest, 0.0);
  EXPECT_LT(smallest, 0.01);  // the path does come close (the impact follows)
  const double energy1 = s.arm->kineticEnergy() + s.box->kineticEnergy();
  EXPECT_LE(energy1, energy0 * (1.0 + 1e-6));
  EXPECT_LT(energy1, energy0);  // the impacts dissipate
}

namespace {

// The arm scene with the arm still on its way (lift 0.35: the episode cannot end in sustained
// contact before the horizon, and the box is held on the table meanwhile), its box set moving at
// v [m/s] and w [rad/s] (world frame) with its centre of mass at `com` (box frame), then run to
// `horizon` [s]. `start` is the box's state as set; the scene's box holds its end state.
struct MovingBox {
  collision_response::testing::ArmBoxScene scene;
  cr::BodyState start;
  cr::BodyEpisodeResult result;
  const cr::BodyState& end() const { return scene.box->state(); }
};

MovingBox runMovingBox(const Vector3d& v, const Vector3d& w, double horizon,
                       const Vector3d* com = nullptr) {
  MovingBox run;
  run.scene = collision_response::testing::armBoxScene(kArm7, /*lift=*/0.35);
  collision_response::testing::ArmBoxScene& s = run.scene;
  run.start = s.box->state();
  if (com != nullptr) run.start.com = *com;
  run.start.linear_velocity = v;
  run.start.angular_velocity = w;
  *s.box = cr::RigidEpisodeBody(run.start);
  s.bodies[1] = s.box.get();
  s.options.horizon = horizon;
  run.result = cr::computeBodyEpisode(s.bodies, s.parts, *s.geometry, s.options);
  return run;
}

}  // namespace

// A box sliding on the table while the arm is still on its way (the episode cannot end in
// sustained contact: the arm may reach the box before the horizon): held on the table by its
// resting forces, it slides to rest under dynamic friction, v^2 / (2 mu_d g) away after v / (mu_d
// g) (closed form), without sinking into the table or leaving it.
TEST(RobotEpisode, BoxSlidesToRestOnTheTableWhileTheArmFlies) {
  const double v = 0.3, mu_d = 0.4, g = 9.81;
  const MovingBox run = runMovingBox(Vector3d(v, 0.0, 0.0), Vector3d::Zero(), 0.12);
  const cr::BodyEpisodeResult& r = run.result;
  const Vector3d start = run.start.position;
  EXPECT_TRUE(r.impacts.empty()) << r.impacts.size() << " impacts";
  const cr::BodyState& end = run.end();
  EXPECT_NEAR(end.position.x() - start.x(), v * v / (2.0 * mu_d * g), 1e-6);
  EXPECT_NEAR(end.position.y(), start.y(), 1e-9);
  EXPECT_NEAR(end.position.z(), start.z(), 1e-9);
  EXPECT_LT(end.linear_velocity.norm(), 1e-9);
  EXPECT_LT(end.angular_velocity.norm(), 1e-9);
  EXPECT_LT(r.end_time, run.scene.options.horizon + 1e-12);
}

// The same box sliding slowly without turning: v = 0.02 m/s, every corner slipping at v along x,
// below the episode's resting threshold (sqrt(2 g tolerance) = 0.044 m/s) but far above round-off.
// A stuck answer exists here (nothing needs holding: zero friction does), which is what the
// analysis gave before, and the held box slid on unbraked, v t = 2.4 mm to the horizon. Coulomb's
// law at a nonzero slip: each corner's friction -mu_d N_i along -x, summing to -mu_d m g, so the
// box stops v^2 / (2 mu_d g) = 51 um away (closed form), not turning, on the table.
TEST(RobotEpisode, SlowlySlidingBoxStopsWithinTheDynamicFrictionDistance) {
  const double v = 0.02, mu_d = 0.4, g = 9.81;
  const MovingBox run = runMovingBox(Vector3d(v, 0.0, 0.0), Vector3d::Zero(), 0.12);
  ASSERT_LT(v, std::sqrt(2.0 * g * run.scene.options.contact_tolerance));
  const cr::BodyEpisodeResult& r = run.result;
  const Vector3d start = run.start.position;
  EXPECT_TRUE(r.impacts.empty()) << r.impacts.size() << " impacts";
  const cr::BodyState& end = run.end();
  const double distance = v * v / (2.0 * mu_d * g);
  EXPECT_NEAR(end.position.x() - start.x(), distance, 1e-6 * distance);
  EXPECT_NEAR(end.position.y(), start.y(), 1e-12);
  EXPECT_NEAR(end.position.z(), start.z(), 1e-9);
  EXPECT_LT(end.linear_velocity.norm(), 1e-9);
  EXPECT_LT(end.angular_velocity.norm(), 1e-12);
}

// The same box sliding slowly while it turns slowly: v = 0.02 m/s and w = 0.02 rad/s about the
// vertical, its corners' slips (|v + w x r| <= 0.0215 m/s) below the episode's resting threshold
// (sqrt(2 g tolerance) = 0.044 m/s) but above round-off, so sliding from the start (before the
// fix above they counted as none, and the turning left no stuck answer: the centripetal w^2 r no
// force cancels). Coulomb's law at those slips: each corner's friction -mu_d N_i against its own
// slip: the box slides to rest about v^2 / (2 mu_d g) = 51 um away (closed form, bounds below),
// not on at v (friction that opposed only the corners' centripetal accelerations, summing to
// nothing, let it slide 2.4 mm to the horizon).
TEST(RobotEpisode, SlowlyTurningBoxSlidesToRestUnderDynamicFriction) {
  const double v = 0.02, w = 0.02, mu_d = 0.4, g = 9.81;
  const MovingBox run = runMovingBox(Vector3d(v, 0.0, 0.0), Vector3d(0.0, 0.0, w), 0.12);
  const cr::BodyEpisodeResult& r = run.result;
  const Vector3d start = run.start.position;
  EXPECT_TRUE(r.impacts.empty()) << r.impacts.size() << " impacts";
  const cr::BodyState& end = run.end();
  const double distance = v * v / (2.0 * mu_d * g);
  // Along x: the corners' friction forces sum to at most mu_d m g (sum |F_t| = mu_d sum N), so
  // the box slides at least `distance`; their slips turn from x by at most about w (s / 2) / v
  // (s = 0.1 m the box's side), which bounds both the shortfall of the braking and the sideways
  // drift (the corners ahead, loaded more by the friction's tipping moment, slip towards +y).
  const double turned = w * 0.05 / v;
  EXPECT_GE(end.position.x() - start.x(), distance * (1.0 - 1e-9));
  EXPECT_LE(end.position.x() - start.x(), distance * (1.0 + turned * turned));
  EXPECT_LE(std::abs(end.position.y() - start.y()), turned * distance);
  EXPECT_NEAR(end.position.z(), start.z(), 1e-9);
  EXPECT_LT(end.linear_velocity.norm(), 1e-6);
  // Its spin too ends under the corners' friction torque (held, it kept turning at w before).
  EXPECT_LT(end.angular_velocity.norm(), 1e-9);
}

namespace {

// The arm scene's box (1 kg, 0.1 m cube, I = m s^2 / 6) spinning only, at w0 about the vertical,
// on the table while the arm flies (so the episode holds it rather than ending), to `horizon`.
struct SpinEnd {
  double rate = 0.0;   // its angular velocity about z at the end [rad/s]
  double angle = 0.0;  // the angle it turned about z [rad]
  Vector3d shift = Vector3d::Zero();
  Vector3d off_axis = Vector3d::Zero();  // its angular velocity's components about x and y
  std::size_t impacts = 0;
};

SpinEnd spinBox(double w0, double horizon) {
  const MovingBox run = runMovingBox(Vector3d::Zero(), Vector3d(0.0, 0.0, w0), horizon);
  const cr::BodyEpisodeResult& r = run.result;
  const Vector3d start = run.start.position;
  const Eigen::Quaterniond q0 = run.start.orientation;
  const cr::BodyState& end = run.end();
  SpinEnd out;
  out.rate = end.angular_velocity.z();
  out.off_axis = Vector3d(end.angular_velocity.x(), end.angular_velocity.y(), 0.0);
  const Eigen::AngleAxisd turned(end.orientation * q0.conjugate());
  out.angle = turned.angle() * turned.axis().z();
  out.shift = end.position - start;
  out.impacts = r.impacts.size();
  return out;
}

}  // namespace

// The box spinning only, about the vertical, on its four bottom corners: each corner carries m g /
// 4 (no net friction force, so no tipping moment) and slips tangentially at w r, so Coulomb's
// friction -mu_d m g / 4 along the slip at each gives the constant torque -mu_d m g r (r = s /
// sqrt(2) the corners' distance from the axis): the spin decelerates at alpha = mu_d m g r / I_zz
// (closed form, 166.5 rad/s^2, mu_d = 0.4 under the scene's mu_s = 0.5), stops at w0 / alpha after
// turning w0^2 / (2 alpha), and the box does not translate. w0 = 0.2 rad/s: corners slipping at
// 14 mm/s, below the episode's resting threshold (44 mm/s); 1 rad/s: 71 mm/s, above it (such a
// body was not held before: it fell into the table between plastic touches whose friction braked
// its spin in bursts, 3 impacts and 15 % too far a turn); 5 rad/s: 75 mrad, the hold redone
// every RigidEpisodeBody::kHeldTurn.
TEST(RobotEpisode, SpinningBoxStopsUnderTheCornersFrictionTorque) {
  const double mu_d = 0.4, g = 9.81, m = 1.0, side = 0.1;
  const double r = side / std::sqrt(2.0), inertia = m * side * side / 6.0;
  const double alpha = mu_d * m * g * r / inertia;
  for (const double w0 : {0.2, 1.0, 5.0}) {
    SCOPED_TRACE(w0);
    const double angle = w0 * w0 / (2.0 * alpha);
    const SpinEnd end = spinBox(w0, 0.12);
    EXPECT_EQ(end.impacts, 0u);
    EXPECT_LT(std::abs(end.rate), 1e-9);
    EXPECT_NEAR(end.angle, angle, 1e-6 * angle);
    EXPECT_LT(end.shift.norm(), 1e-9);
    EXPECT_LT(end.off_axis.norm(), 1e-9);
  }
}

// A held rigid body's spin: its angular acceleration I^-1 tau about its centre of mass (the torque
// given about the origin, tau_origin - c x F), the step limit where its spin stops, w0 / |alpha|,
// the acceleration bound |a| + |alpha| r, and after that step no spin left, turned by w0^2 / (2
// |alpha|) about the axis (closed form); a spin that would turn farther than kHeldTurn first
// (w0^2 / (2 alpha) > kHeldTurn) is limited to the time it turns by kHeldTurn at most, kHeldTurn
// / w0.
TEST(RobotEpisode, HeldBodyStepLimitIsWhereItsSpinStops) {
  cr::BodyState box;
  box.mass = 2.0;
  box.inertia = Eigen::Matrix3d::Identity() * 0.5;
  box.position = Vector3d(1.0, 2.0, 0.5);
  box.angular_velocity = Vector3d(0.0, 0.0, 0.1);
  cr::RigidEpisodeBody body(box);
  body.setGravity(Vector3d(0, 0, -10.0));
  // Normal force m g up at the centre's foot (no moment about the centre), torque -2 N m about z.
  const Vector3d F(0.0, 0.0, 20.0), foot(1.0, 2.0, 0.0);
  const Vector3d torque = foot.cross(F) + Vector3d(0.0, 0.0, -2.0);
  ASSERT_TRUE(body.hold(F, torque));
  const double alpha = 2.0 / 0.5;
  EXPECT_NEAR(body.stepLimit(), 0.1 / alpha, 1e-15);
  EXPECT_NEAR(body.partAccelerationBound(0, 0.1), 0.1 * alpha, 1e-12);
  body.advance(0.1 / alpha);
  EXPECT_LT(body.state().angular_velocity.norm(), 1e-15);
  EXPECT_LT((body.state().position - box.position).norm(), 1e-15);
  const Eigen::AngleAxisd turned(body.state().orientation);
  EXPECT_NEAR(turned.angle() * turned.axis().z(), 0.01 / (2.0 * alpha), 1e-15);
  box.angular_velocity = Vector3d(0.0, 0.0, 3.0);
  cr::RigidEpisodeBody fast(box);
  fast.setGravity(Vector3d(0, 0, -10.0));
  ASSERT_TRUE(fast.hold(F, torque));
  EXPECT_NEAR(fast.stepLimit(), cr::RigidEpisodeBody::kHeldTurn / 3.0, 1e-15);
}

// A held rigid body's step limit: the time its velocity's component against the held
// acceleration takes to run out (v / (mu g) for a slide stopping under friction), never for one
// the acceleration speeds up (sliding off from rest).
TEST(RobotEpisode, HeldBodyStepLimitIsWhereItsSlipStops) {
  cr::BodyState box;
  box.mass = 2.0;
  box.inertia = Eigen::Matrix3d::Identity();
  box.linear_velocity = Vector3d(0.5, 0.0, 0.0);
  cr::RigidEpisodeBody body(box);
  body.setGravity(Vector3d(0, 0, -10.0));
  // Normal force m g up, friction 0.4 m g against the slip.
  ASSERT_TRUE(body.hold(Vector3d(-0.4 * 2.0 * 10.0, 0.0, 2.0 * 10.0), Vector3d::Zero()));
  EXPECT_NEAR(body.stepLimit(), 0.5 / 4.0, 1e-15);
  EXPECT_NEAR(body.partAccelerationBound(0, 0.1), 4.0, 1e-12);
  box.linear_velocity.setZero();
  cr::RigidEpisodeBody still(box);
  still.setGravity(Vector3d(0, 0, -10.0));
  ASSERT_TRUE(still.hold(Vector3d(3.0, 0.0, 20.0), Vector3d::Zero()));  // pushed off from rest
  EXPECT_EQ(still.stepLimit(), kInf);
  still.release();
  EXPECT_EQ(still.stepLimit(), kInf);
  EXPECT_NEAR(still.partAccelerationBound(0, 0.1), 10.0, 1e-12);
}

namespace {

// A box sliding and turning flat on the table, by an independent planar reference. Its mass sits in
// its base (centre of mass in the middle of the bottom face, the support plane), so the corners'
// friction, acting in that plane, has no tipping moment: the box does not tip, and its weight is
// balanced by normal forces N_k with sum m g and no moment about the centre. Four coplanar corners
// leave one mode of them free (more on one diagonal, less on the other: statically indeterminate);
// equal corner compliance picks m g / 4 each, and `diagonal` moves d m g / 4 from the (+a, -a) and
// (-a, +a) corners onto the (+a, +a) and (-a, -a) ones (|d| <= 1, held constant), to bound what
// another choice does. State (x, y, theta, vx, vy, wz) of the centre of mass; corner k (body offset
// c_k = (+-a, +-a)) slips at u_k = v + w z x R(theta) c_k and carries the friction
// -mu_d N_k u_k / |u_k|; RK4 at step h until the slip stops. It stops as a whole: for this box
// (I_zz = 2 m a^2 / 3) the spin dies faster than the slide (near a pure slide w / v falls as
// (T - t)^(m a^2 / I_zz - 1) = (T - t)^0.5; near a pure spin v / (w r) grows), so no corner's slip
// vanishes before the end (no set-valued friction to resolve, no regularisation), and the last
// step, where v would reverse, ends with the slide's closed form v^2 / (2 mu_d g) (w ~ (T - t)^1.5
// is spent by then).
struct PlanarState {
  double x = 0.0, y = 0.0, theta = 0.0, vx = 0.0, vy = 0.0, w = 0.0;
  double time = 0.0;  // when the slip stopped [s]
};

PlanarState planarSlideAndSpin(double vx, double wz, double mu_d, double g, double half,
                               double inertia_per_mass, double h, double diagonal = 0.0) {
  using State = std::array<double, 6>;
  const auto rate = [&](const State& s) {
    State d{s[3], s[4], s[5], 0.0, 0.0, 0.0};
    const double c = std::cos(s[2]), sn = std::sin(s[2]);
    for (const double cx : {-half, half})
      for (const double cy : {-half, half}) {
        const double rx = c * cx - sn * cy, ry = sn * cx + c * cy;
        const double ux = s[3] - s[5] * ry, uy = s[4] + s[5] * rx;
        const double u = std::hypot(ux, uy);
        if (!(u > 0.0)) continue;
        const double load = g / 4.0 * (1.0 + (cx * cy > 0.0 ? diagonal : -diagonal));  // N_k / m
        const double fx = -mu_d * load * ux / u, fy = -mu_d * load * uy / u;
        d[3] += fx;
        d[4] += fy;
        d[5] += (rx * fy - ry * fx) / inertia_per_mass;
      }
    return d;
  };
  const auto plus = [](const State& a, double k, const State& b) {
    State r;
    for (int i = 0; i < 6; ++i) r[i] = a[i] + k * b[i];
    return r;
  };
  State s{0.0, 0.0, 0.0, vx, 0.0, wz};
  double t = 0.0;
  for (;;) {
    const double speed = std::hypot(s[3], s[4]);
    PlanarState out{s[0], s[1], s[2], s[3], s[4], s[5], t};
    if (speed <= mu_d * g * h) {  // the slide's last step, closed form
      const double along = speed > 0.0 ? speed / (2.0 * mu_d * g) : 0.0;
      out.x += along * s[3];
      out.y += along * s[4];
      out.theta += 0.5 * s[5] * speed / (mu_d * g);
      out.vx = out.vy = out.w = 0.0;
      out.time += speed / (mu_d * g);
      return out;
    }
    const State k1 = rate(s), k2 = rate(plus(s, 0.5 * h, k1)), k3 = rate(plus(s, 0.5 * h, k2)),
                k4 = rate(plus(s, h, k3));
    for (int i = 0; i < 6; ++i) s[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    t += h;
  }
}

// The arm scene's box (1 kg, 0.1 m cube, I = m s^2 / 6 about its centre of mass) with its centre of
// mass moved to the middle of its bottom face, sliding at (v, 0, 0) and spinning at w about the
// vertical on the table while the arm flies, to a 0.12 s horizon.
struct HeldEnd {
  Vector3d shift = Vector3d::Zero();  // of its centre of mass [m]
  double angle = 0.0;                 // turned about z [rad]
  Vector3d velocity = Vector3d::Zero(), angular_velocity = Vector3d::Zero();
  double tilt = 0.0;  // between its z axis and the vertical [rad]
  std::size_t impacts = 0;
  int steps = 0;
};

HeldEnd slideAndSpinBaseHeavyBox(double v, double w) {
  const Vector3d base_centre(0.0, 0.0, -0.05);
  const MovingBox run =
      runMovingBox(Vector3d(v, 0.0, 0.0), Vector3d(0.0, 0.0, w), 0.12, &base_centre);
  const cr::BodyEpisodeResult& r = run.result;
  const cr::BodyState& box = run.start;
  const Vector3d start = box.position + box.orientation * box.com;
  const Eigen::Quaterniond q0 = box.orientation;
  const cr::BodyState& end = run.end();
  HeldEnd out;
  out.shift = end.position + end.orientation * end.com - start;
  const Eigen::AngleAxisd turned(end.orientation * q0.conjugate());
  out.angle = turned.angle() * turned.axis().z();
  out.velocity = end.linear_velocity;
  out.angular_velocity = end.angular_velocity;
  out.tilt = std::acos(std::min(1.0, (end.orientation * Vector3d::UnitZ()).z()));
  out.impacts = r.impacts.size();
  out.steps = r.steps;
  return out;
}

constexpr double kBoxHalf = 0.05, kBoxInertiaPerMass = 0.01 / 6.0;

}  // namespace

// The planar reference against its closed forms (so that the test below compares the episode with
// something right): a slide alone stops after v^2 / (2 mu_d g) in v / (mu_d g) without turning; a
// spin with a slide of 1e-4 of its corners' speed turns by w^2 / (2 alpha), alpha = mu_d g r /
// (I / m) (the spinning box's closed form above), with a slide that small not changing it beyond
// 1e-3; at h = 1 us its answers for the test's cases move by less than 1e-9 m and 1e-9 rad at h =
// 4 us (converged).
TEST(RobotEpisode, PlanarCoulombReferenceMeetsItsClosedForms) {
  const double mu_d = 0.4, g = 9.81;
  const PlanarState slide =
      planarSlideAndSpin(0.05, 0.0, mu_d, g, kBoxHalf, kBoxInertiaPerMass, 1e-6);
  EXPECT_NEAR(slide.x, 0.05 * 0.05 / (2.0 * mu_d * g), 1e-12);
  EXPECT_EQ(slide.y, 0.0);
  EXPECT_EQ(slide.theta, 0.0);
  EXPECT_NEAR(slide.time, 0.05 / (mu_d * g), 1e-12);
  const double r = kBoxHalf * std::sqrt(2.0), alpha = mu_d * g * r / kBoxInertiaPerMass;
  const PlanarState spin =
      planarSlideAndSpin(1e-4 * r, 1.0, mu_d, g, kBoxHalf, kBoxInertiaPerMass, 1e-6);
  EXPECT_NEAR(spin.theta, 1.0 / (2.0 * alpha), 1e-3 / (2.0 * alpha));
  for (const auto& [v, w] : {std::pair{0.05, 1.0}, std::pair{0.02, 3.0}}) {
    SCOPED_TRACE(::testing::Message() << "v " << v << " w " << w);
    const PlanarState fine = planarSlideAndSpin(v, w, mu_d, g, kBoxHalf, kBoxInertiaPerMass, 1e-6);
    const PlanarState coarse =
        planarSlideAndSpin(v, w, mu_d, g, kBoxHalf, kBoxInertiaPerMass, 4e-6);
    EXPECT_NEAR(coarse.x, fine.x, 1e-9);
    EXPECT_NEAR(coarse.y, fine.y, 1e-9);
    EXPECT_NEAR(coarse.theta, fine.theta, 1e-9);
  }
}

// Sliding and turning at once, against the planar reference: v = 0.05 m/s with w = 1 rad/s (the
// corners' spin w r = 71 mm/s against the slide's 50), and a slower slide, 0.02 m/s, with a faster
// spin, 3 rad/s (212 mm/s). The held wrench is exact in neither: the corners' slip directions turn
// with the body and with the changing ratio of slide to spin. Held in steps over which they turn by
// at most kHeldTurn = 0.02 rad, each corner's friction is exact in direction at a step's start and
// off by at most 0.02 rad at its end (in magnitude only to second order), so on average by half
// that: the stop and the angle turned should be within 1 % of the reference's (a literal here, not
// the constant, which a change must not loosen). The free diagonal mode of the corners' loads (the
// reference's comment) is the analysis's to pick: the box must end within the references' spread
// over constant diagonal shares d in [-1, 1] (sampled at -1, -0.5, 0, 0.5, 1; d moves the stop
// across the slide by up to 60 um, along it by up to 2.7 %, the angle by up to 7.4 %; at d = 0.25
// by 14 um, 0.3 % and 0.4 %), widened by that 1 %. Without the step limit on the slide-to-spin
// ratio (RigidEpisodeBody::stepLimit(), kHeldTurn / (|a| / |v| + |alpha| / |w|), floored at
// kHeldMinimumStep) it fails: the first wrench was held until the spin stopped (7.3 ms, where the
// reference still turns at 0.26 rad/s), at v = 0.05 m/s, w = 1 rad/s x = 493.8 um (reference
// 427.9, +15 %) and 3.628 mrad turned (5.006, -27.5 %); at v = 0.02 m/s, w = 3 rad/s 347.4 um
// (322.0, +7.9 %). With it: 156 and 154 steps, +0.11 % / +0.08 % and +0.45 % / +0.004 %.
TEST(RobotEpisode, SlidingAndTurningBoxStopsWhereThePlanarCoulombReferenceStops) {
  const double mu_d = 0.4, g = 9.81;
  for (const auto& [v, w] : {std::pair{0.05, 1.0}, std::pair{0.02, 3.0}}) {
    SCOPED_TRACE(::testing::Message() << "v " << v << " w " << w);
    const PlanarState ref = planarSlideAndSpin(v, w, mu_d, g, kBoxHalf, kBoxInertiaPerMass, 1e-6);
    PlanarState low = ref, high = ref;
    for (const double d : {-1.0, -0.5, 0.5, 1.0}) {
      const PlanarState other =
          planarSlideAndSpin(v, w, mu_d, g, kBoxHalf, kBoxInertiaPerMass, 1e-6, d);
      low.x = std::min(low.x, other.x);
      low.y = std::min(low.y, other.y);
      low.theta = std::min(low.theta, other.theta);
      high.x = std::max(high.x, other.x);
      high.y = std::max(high.y, other.y);
      high.theta = std::max(high.theta, other.theta);
    }
    const double tolerance = 0.01;
    const HeldEnd end = slideAndSpinBaseHeavyBox(v, w);
    std::printf(
        "v %g w %g: reference (equal loads; diagonal loads) x %.3f (%.3f to %.3f) um, y %.3f "
        "(%.3f to %.3f) um, theta %.4f (%.4f to %.4f) mrad, stop %.3f ms; episode x %.3f um, y "
        "%.3f um, theta %.4f mrad, %d steps\n",
        v, w, 1e6 * ref.x, 1e6 * low.x, 1e6 * high.x, 1e6 * ref.y, 1e6 * low.y, 1e6 * high.y,
        1e3 * ref.theta, 1e3 * low.theta, 1e3 * high.theta, 1e3 * ref.time, 1e6 * end.shift.x(),
        1e6 * end.shift.y(), 1e3 * end.angle, end.steps);
    EXPECT_EQ(end.impacts, 0u);
    EXPECT_LT(end.velocity.norm(), 1e-9);
    EXPECT_LT(end.angular_velocity.norm(), 1e-9);
    EXPECT_GE(end.shift.x(), low.x - tolerance * ref.x);
    EXPECT_LE(end.shift.x(), high.x + tolerance * ref.x);
    EXPECT_GE(end.angle, low.theta - tolerance * ref.theta);
    EXPECT_LE(end.angle, high.theta + tolerance * ref.theta);
    EXPECT_GE(end.shift.y(), low.y - tolerance * ref.x);
    EXPECT_LE(end.shift.y(), high.y + tolerance * ref.x);
    EXPECT_NEAR(end.shift.z(), 0.0, 1e-9);
    EXPECT_LT(end.tilt, 1e-9);
  }
}

namespace {

// A 1 kg ball (inertia 0.001 kg m^2), not turning, at `position` moving at `velocity`.
cr::BodyState movingBall(const Vector3d& position, const Vector3d& velocity) {
  cr::BodyState ball;
  ball.id = "ball";
  ball.mass = 1.0;
  ball.inertia = Eigen::Matrix3d::Identity() * 0.001;
  ball.position = position;
  ball.linear_velocity = velocity;
  return ball;
}

// Closed-form convex geometry (GapQuery::convex() true): geometry body 0 a fixed sphere of radius
// `fixed_radius` at `fixed_centre`, body 1 a ball of radius
// `ball_radius` centred on its part's reference point (BodyState::com of the pose given; a robot
// link's frame origin).
class BallAndObstacle final : public cr::GapQuery {
 public:
  void gaps(const std::vector<cr::BodyState>& bodies, double range,
            std::vector<cr::GapContact>& out) const override {
    out.clear();
    const cr::BodyState& b = bodies[1];
    const Vector3d centre = b.position + b.orientation * b.com;
    cr::GapContact c;
    c.body_a = 0;
    c.body_b = 1;
    c.normal = (centre - fixed_centre).normalized();
    c.gap = (centre - fixed_centre).norm() - ball_radius - fixed_radius;
    c.point = centre - ball_radius * c.normal;
    c.restitution = 0.5;
    if (c.gap <= range) out.push_back(c);
  }
  double radius(int body) const override { return body == 1 ? ball_radius : fixed_radius; }
  bool convex(int) const override { return true; }
  int bodyCount() const override { return 2; }
  Vector3d fixed_centre = Vector3d::Zero();
  double fixed_radius = 0.01, ball_radius = 0.05;
};

}  // namespace

// A ball thrown straight up from just above a small fixed sphere flies away from it and falls
// back onto it: the gap's bound by its normal velocity lets the ball rise in long steps, and its
// acceleration term (gravity) must bring it back before it passes through the small sphere; the
// contact at the closed-form time z0 + v t - g t^2 / 2 = r_ball + r_fixed.
TEST(RobotEpisode, BallThrownUpFromASphereComesBackAtTheClosedFormTime) {
  BallAndObstacle geometry;
  cr::BodyState floor;
  floor.id = "fixed sphere";
  const double gap0 = 0.01, v0 = 1.0;
  const cr::BodyState ball =
      movingBall(Vector3d(0.0, 0.0, geometry.ball_radius + geometry.fixed_radius + gap0),
                 Vector3d(0.0, 0.0, v0));
  cr::RigidEpisodeBody floor_body(floor), ball_body(ball);
  std::vector<cr::EpisodeBody*> bodies = {&floor_body, &ball_body};
  std::vector<cr::EpisodePart> parts = {{0, 0}, {1, 0}};
  cr::EpisodeOptions options;
  options.gravity = Vector3d(0.0, 0.0, -kG);
  options.horizon = 1.0;
  options.max_impacts = 1;
  options.contact_tolerance = 1e-5;
  options.solver.law = cr::ImpactLaw::kNewton;
  const cr::BodyEpisodeResult r = cr::computeBodyEpisode(bodies, parts, geometry, options);
  ASSERT_GE(r.impacts.size(), 1u) << "the falling ball's contact was missed";
  const double t_c = (v0 + std::sqrt(v0 * v0 + 2.0 * kG * gap0)) / kG;
  const double speed = std::sqrt(v0 * v0 + 2.0 * kG * gap0);
  EXPECT_LE(r.impacts[0].time, t_c + 1e-9);
  EXPECT_GE(r.impacts[0].time, t_c - options.contact_tolerance / speed - 1e-9);
  EXPECT_NEAR(r.impacts[0].impulses[0].normal_velocity_before, -speed, 1e-4 * speed);
}

// A ball (radius 5 cm) on a floor plane z = 0: geometry body 0 the floor, body 1 the ball.
class BallOnFloor final : public cr::GapQuery {
 public:
  void gaps(const std::vector<cr::BodyState>& bodies, double range,
            std::vector<cr::GapContact>& out) const override {
    out.clear();
    const Vector3d centre = bodies[1].position + bodies[1].orientation * bodies[1].com;
    cr::GapContact c;
    c.body_a = 0;
    c.body_b = 1;
    c.normal = Vector3d::UnitZ();
    c.gap = centre.z() - kRadius;
    c.point = centre - kRadius * Vector3d::UnitZ();
    c.restitution = 0.5;
    if (c.gap <= range) out.push_back(c);
  }
  double radius(int body) const override { return body == 1 ? kRadius : kInf; }
  int bodyCount() const override { return 2; }
  static constexpr double kRadius = 0.05;
};

// A ball touching the floor (gap half the 0.1 mm tolerance) and leaving it at 0.1 m/s, with a
// horizon of 0.9 ms. A touching pair is stepped by about a tolerance at its speed bound, 2 tol /
// (v + sqrt(v^2 + 2 g tol)) = 0.955 ms here, which covers the horizon: the episode takes that one
// step, and at the horizon the gap is 0.05 + 0.09 - 0.004 = 0.136 mm, beyond the tolerance:
// nothing touches there, so it ends `separated` at the horizon (not `horizon`, which says a pair
// still touches), as the rigid-body episode does.
TEST(RobotEpisode, BallLeavingTheFloorWithinTheLastStepEndsSeparatedAtTheHorizon) {
  BallOnFloor geometry;
  cr::BodyState floor;
  floor.id = "floor";
  const double tolerance = 1e-4, v = 0.1;
  const cr::BodyState ball =
      movingBall(Vector3d(0.0, 0.0, BallOnFloor::kRadius + 0.5 * tolerance), Vector3d(0.0, 0.0, v));
  cr::RigidEpisodeBody floor_body(floor), ball_body(ball);
  std::vector<cr::EpisodeBody*> bodies = {&floor_body, &ball_body};
  std::vector<cr::EpisodePart> parts = {{0, 0}, {1, 0}};
  cr::EpisodeOptions options;
  options.gravity = Vector3d(0.0, 0.0, -kG);
  options.horizon = 9e-4;
  options.contact_tolerance = tolerance;
  const cr::BodyEpisodeResult r = cr::computeBodyEpisode(bodies, parts, geometry, options);
  EXPECT_TRUE(r.impacts.empty());
  EXPECT_EQ(r.end, cr::EpisodeEnd::kSeparated);
  EXPECT_EQ(r.end_time, options.horizon);
  EXPECT_EQ(r.outcomes[1], cr::BodyOutcome::kSeparated);
  // In free flight there.
  const double H = options.horizon;
  EXPECT_NEAR(ball_body.state().position.z() - BallOnFloor::kRadius,
              0.5 * tolerance + v * H - 0.5 * kG * H * H, 1e-12);
}

// theta'' = -m g L cos(theta) / (m L^2 + I_c) of ball_pendulum.urdf (m = 1 kg, L = 1 m,
// I_c = 0.001 kg m^2), RK4 at step h from (theta0, rate0): the time at which theta first falls to
// theta_c (by linear interpolation in the step).
double ballPendulumTimeTo(double theta0, double rate0, double theta_c, double h) {
  double th = theta0, w = rate0, t = 0.0;
  const auto acc = [](double x) { return -kG * std::cos(x) / 1.001; };
  for (;;) {
    const double k1t = w, k1w = acc(th);
    const double k2t = w + 0.5 * h * k1w, k2w = acc(th + 0.5 * h * k1t);
    const double k3t = w + 0.5 * h * k2w, k3w = acc(th + 0.5 * h * k2t);
    const double k4t = w + h * k3w, k4w = acc(th + h * k3t);
    const double th1 = th + h / 6 * (k1t + 2 * k2t + 2 * k3t + k4t);
    const double w1 = w + h / 6 * (k1w + 2 * k2w + 2 * k3w + k4w);
    if (th1 <= theta_c) return t + h * (th - theta_c) / (th - th1);
    th = th1;
    w = w1;
    t += h;
  }
}

// A pendulum's ball swings up away from a small fixed sphere on its arc, turns under gravity and
// falls back onto it: the return contact is found, at the time of an independent RK4 integration
// of the pendulum's equation, and the receding half takes few steps.
TEST(RobotEpisode, PendulumSwingingAwayAndBackFindsTheReturnContact) {
  rb::ArticulatedBody bob = rb::robotFromUrdfFile(kDir + "/ball_pendulum.urdf");
  const double theta_o = -M_PI / 2 + 0.5;  // the obstacle's centre on the ball's arc (L = 1)
  const double theta0 = theta_o + 0.15, rate0 = 1.0;
  bob.setState(VectorXd::Constant(1, theta0), VectorXd::Constant(1, rate0));
  bob.setLoads(VectorXd::Zero(1), Vector3d::Zero());  // torque model none
  const int link = bob.linkIndex("bob");
  rb::RobotEpisodeBody rod(std::move(bob));
  BallAndObstacle geometry;
  geometry.fixed_centre = Vector3d(std::cos(theta_o), std::sin(theta_o), 0.0);
  cr::BodyState obstacle;
  obstacle.id = "obstacle";
  obstacle.position = geometry.fixed_centre;
  cr::RigidEpisodeBody obstacle_body(obstacle);
  std::vector<cr::EpisodeBody*> bodies = {&obstacle_body, &rod};
  std::vector<cr::EpisodePart> parts = {{0, 0}, {1, link}};
  cr::EpisodeOptions options;
  options.gravity = Vector3d(0.0, -kG, 0.0);
  options.horizon = 2.0;
  options.max_impacts = 1;
  options.contact_tolerance = 1e-5;
  options.solver.law = cr::ImpactLaw::kNewton;
  const cr::BodyEpisodeResult r = cr::computeBodyEpisode(bodies, parts, geometry, options);
  ASSERT_GE(r.impacts.size(), 1u) << "the returning ball's contact was missed";
  // Centres 0.06 m apart (the radii) on the unit arc: theta_c - theta_o = 2 asin(0.03).
  const double theta_c = theta_o + 2.0 * std::asin(0.03);
  // The reference converges to ~1e-12 s at h = 1e-5 (RK4).
  const double t_c = ballPendulumTimeTo(theta0, rate0, theta_c, 1e-5);
  const double rate_c =
      -std::sqrt(rate0 * rate0 + 2.0 * kG / 1.001 * (std::sin(theta0) - std::sin(theta_c)));
  // The ball meets the obstacle's sphere along their centre line, the ball's velocity L rate along
  // the tangent at angle (theta_c - theta_o) / 2 to that line's normal.
  const double u_n = rate_c * std::cos(0.5 * (theta_c - theta_o));
  EXPECT_LE(r.impacts[0].time, t_c + 1e-9);
  EXPECT_GE(r.impacts[0].time, t_c - options.contact_tolerance / std::abs(u_n) - 1e-9);
  EXPECT_NEAR(r.impacts[0].impulses[0].normal_velocity_before, u_n, 1e-3 * std::abs(u_n));
  EXPECT_GT(t_c, 0.3);  // it receded first (its rate reaches 0 at about 0.17 s)
}

namespace {

// Closed-form convex geometry: geometry body 0 a small fixed sphere (radius 0.001 m at `centre`),
// body 1 a thin capsule on its part's frame: the segment from -h e to +h e (h = 0.3 m, e =
// (-sin 0.1, cos 0.1, 0), part frame), radius 0.001 m.
class CapsuleAndDot final : public cr::GapQuery {
 public:
  static constexpr double kHalf = 0.3, kRadius = 0.001;
  static Vector3d axis() { return Vector3d(-std::sin(0.1), std::cos(0.1), 0.0); }
  // The gap and unit normal (from the dot to the capsule) for the capsule at `pose`.
  double gap(const cr::BodyState& capsule, Vector3d* normal = nullptr) const {
    const Vector3d q = capsule.orientation.conjugate() * (centre - capsule.position);
    const double t = std::clamp(q.dot(axis()), -kHalf, kHalf);
    const Vector3d away = capsule.orientation * (t * axis() - q);  // dot -> closest point
    if (normal != nullptr) *normal = away.normalized();
    return away.norm() - 2.0 * kRadius;
  }
  void gaps(const std::vector<cr::BodyState>& bodies, double range,
            std::vector<cr::GapContact>& out) const override {
    out.clear();
    cr::GapContact c;
    c.body_a = 0;
    c.body_b = 1;
    c.gap = gap(bodies[1], &c.normal);
    c.point = centre + kRadius * c.normal;
    if (c.gap <= range) out.push_back(c);
  }
  double radius(int body) const override { return body == 1 ? kHalf + kRadius : kRadius; }
  bool convex(int) const override { return true; }
  int bodyCount() const override { return 2; }
  Vector3d centre = Vector3d::Zero();
};

}  // namespace

// Without gravity the ball pendulum turns uniformly (theta = w t). A thin capsule on its ball's
// frame, tilted 0.1 rad from the tangent, passes a small fixed dot: the frame's origin recedes from
// the dot along the normal (at w L sin 0.1) while the capsule's turning brings its far part onto
// it (at w (t - L sin 0.1) for the point at t along it). The contact is found at the time sampled
// from the closed-form gap along theta = w t; taking the origin's normal velocity for the
// capsule's (no turning term) steps through the dot.
TEST(RobotEpisode, TurningThatClosesWhileTheOriginRecedesIsNotMissed) {
  rb::ArticulatedBody bob = rb::robotFromUrdfFile(kDir + "/ball_pendulum.urdf");
  const double w = 2.0;
  bob.setState(VectorXd::Zero(1), VectorXd::Constant(1, w));
  bob.setLoads(VectorXd::Zero(1), Vector3d::Zero());
  const int link = bob.linkIndex("bob");
  rb::RobotEpisodeBody rod(std::move(bob));
  CapsuleAndDot geometry;
  const Vector3d n(std::cos(0.1), std::sin(0.1), 0.0);  // normal of the capsule's side
  const double gap0 = 0.002;
  geometry.centre = Vector3d(1.0, 0.0, 0.0) + 0.25 * CapsuleAndDot::axis() -
                    (gap0 + 2.0 * CapsuleAndDot::kRadius) * n;
  cr::BodyState dot;
  dot.id = "dot";
  dot.position = geometry.centre;
  cr::RigidEpisodeBody dot_body(dot);
  std::vector<cr::EpisodeBody*> bodies = {&dot_body, &rod};
  std::vector<cr::EpisodePart> parts = {{0, 0}, {1, link}};
  cr::EpisodeOptions options;
  options.gravity = Vector3d::Zero();
  options.horizon = 0.5;
  options.max_impacts = 1;
  options.contact_tolerance = 1e-5;
  options.solver.law = cr::ImpactLaw::kNewton;
  // The capsule's frame at theta: at (cos, sin, 0), turned by theta about z.
  const auto pose = [](double theta) {
    cr::BodyState b;
    b.position = Vector3d(std::cos(theta), std::sin(theta), 0.0);
    b.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(theta, Vector3d::UnitZ()));
    return b;
  };
  ASSERT_NEAR(geometry.gap(pose(0.0)), gap0, 1e-12);
  // Reference: the first time the gap reaches 0, sampled every 1e-7 s and bisected.
  double lo = 0.0, hi = -1.0;
  for (double t = 1e-7; t < options.horizon; t += 1e-7) {
    if (geometry.gap(pose(w * t)) <= 0.0) {
      hi = t;
      break;
    }
    lo = t;
  }
  ASSERT_GT(hi, 0.0);
  for (int k = 0; k < 60; ++k) {
    const double mid = 0.5 * (lo + hi);
    (geometry.gap(pose(w * mid)) > 0.0 ? lo : hi) = mid;
  }
  const double t_ref = hi;
  const double closing =
      (geometry.gap(pose(w * (t_ref - 1e-6))) - geometry.gap(pose(w * t_ref))) / 1e-6;
  ASSERT_GT(closing, 0.0);
  const cr::BodyEpisodeResult r = cr::computeBodyEpisode(bodies, parts, geometry, options);
  ASSERT_GE(r.impacts.size(), 1u) << "the capsule passed through the dot";
  EXPECT_LE(r.impacts[0].time, t_ref + 1e-9);
  EXPECT_GE(r.impacts[0].time, t_ref - options.contact_tolerance / closing - 1e-9);
}

TEST(RobotEpisode, RefusesFloatingBaseAndBadParts) {
  rb::ArticulatedBody floating =
      rb::robotFromUrdfFile(kDir + "/pendulum.urdf", rb::BaseType::kFloating);
  try {
    rb::RobotEpisodeBody body(floating);
    FAIL() << "a floating base was accepted";
  } catch (const cr::InvalidInput& e) {
    EXPECT_EQ(e.field(), "base");
  }
  Pendulum p = pendulum();
  p.parts[1].part = 99;
  try {
    cr::computeBodyEpisode(p.bodies, p.parts, p.geometry, p.options);
    FAIL() << "a part out of range was accepted";
  } catch (const cr::InvalidInput& e) {
    EXPECT_EQ(e.field(), "parts[1]");
  }
}
