// Derivatives of robot impacts (core/body_impact_derivatives.h): the frictionless closed form
// dv'/dv = I - (1 + e) M^-1 J^T (J M^-1 J^T)^-1 J on the shipped arm, and every block against
// central differences of computeBodyResponse() taken here at random states (Newton with and
// without friction, one and several contacts; Poisson and Stronge at one contact; all analytic),
// to 1e-6 relative.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "collision_response/core/body_impact_derivatives.h"
#include "collision_response/core/body_response.h"
#include "collision_response/core/impulse_space_derivatives.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/robot/articulated_body.h"
#include "collision_response/robot/joint_position_coordinates.h"
#include "collision_response/robot/urdf_loader.h"
#include "two_link_arm.h"

namespace cr = collision_response::core;
namespace rb = collision_response::robot;
using Eigen::MatrixXd;
using Eigen::Vector3d;
using Eigen::VectorXd;

namespace {

const std::string kArm7 = ARM7_URDF;

cr::RigidBody sphere(double mass, double radius, const Vector3d& centre, const Vector3d& velocity) {
  cr::RigidBody out;
  out.inverse_mass = 1.0 / mass;
  out.inverse_inertia = Eigen::Matrix3d::Identity() / (0.4 * mass * radius * radius);
  out.com = centre;
  out.linear_velocity = velocity;
  return out;
}

cr::SolverOptions withLaw(cr::ImpactLaw law) {
  cr::SolverOptions options;
  options.law = law;
  return options;
}

// The arm at a random state (joint positions in +-pi, velocities in +-1 rad/s, fingers still).
rb::ArticulatedBody randomArm(std::mt19937& rng) {
  std::uniform_real_distribution<double> angle(-M_PI, M_PI), unit(-1.0, 1.0);
  rb::ArticulatedBody arm = rb::robotFromUrdfFile(kArm7);
  const int n = arm.jointCount();
  VectorXd q(n), qdot(n);
  for (int i = 0; i < n; ++i) {
    q(i) = i < 7 ? angle(rng) : 0.02;
    qdot(i) = i < 7 ? unit(rng) : 0.0;
  }
  arm.setState(q, qdot);
  return arm;
}

// The test's own central differences of computeBodyResponse() (step h, the bodies restored from
// copies): outputs as the library lays them out (arm's unknowns, then the sphere's twist if any,
// then 4 per contact), inputs the same unknowns then e, mu_s, mu_d per contact.
struct Scene {
  rb::ArticulatedBody arm;
  cr::RigidBody ball;
  bool with_ball = true;
  Vector3d wall_velocity = Vector3d::Zero();  // the walls' prescribed motion [m/s]
  std::vector<cr::ContactPoint> contacts;

  VectorXd outputs(const VectorXd& input, const cr::SolverOptions& options) const {
    rb::ArticulatedBody a = arm;
    cr::RigidBody b = ball;
    cr::RigidBody wall;  // immovable, moving at wall_velocity
    wall.linear_velocity = wall_velocity;
    const int n = a.velocityCount();
    a.addVelocityChange(input.head(n) - a.velocity());
    if (with_ball) {
      b.linear_velocity = input.segment<3>(n);
      b.angular_velocity = input.segment<3>(n + 3);
    }
    std::vector<cr::ContactPoint> cs = contacts;
    const int N = n + (with_ball ? 6 : 0);
    for (std::size_t c = 0; c < cs.size(); ++c) {
      cs[c].restitution = input(N + 3 * c);
      cs[c].static_friction = input(N + 3 * c + 1);
      cs[c].dynamic_friction = input(N + 3 * c + 2);
    }
    // Body 1: the sphere or a wall; body 2: a wall (immovable, no unknowns) in either case.
    std::vector<cr::BodyModel*> bodies{&a, with_ball ? static_cast<cr::BodyModel*>(&b) : &wall,
                                       &wall};
    const cr::BodyResponse r = cr::computeBodyResponse(bodies, cs, options);
    VectorXd out(N + 4 * cs.size());
    out.head(n) = a.velocity();
    if (with_ball) out.segment(n, 6) = b.velocity();
    for (std::size_t c = 0; c < cs.size(); ++c) {
      out(N + 4 * c) = r.impulses[c].normal_impulse;
      out.segment<3>(N + 4 * c + 1) = r.impulses[c].friction_impulse;
    }
    return out;
  }
  VectorXd inputs() const {
    const int n = arm.velocityCount(), N = n + (with_ball ? 6 : 0);
    VectorXd in(N + 3 * contacts.size());
    in.head(n) = arm.velocity();
    if (with_ball) in.segment(n, 6) = ball.velocity();
    for (std::size_t c = 0; c < contacts.size(); ++c) {
      in(N + 3 * c) = contacts[c].restitution;
      in(N + 3 * c + 1) = contacts[c].static_friction;
      in(N + 3 * c + 2) = contacts[c].dynamic_friction;
    }
    return in;
  }
  // Central differences over the columns [0, columns).
  MatrixXd differences(const cr::SolverOptions& options, int columns, double h) const {
    const VectorXd x = inputs();
    MatrixXd D(outputs(x, options).size(), columns);
    for (int k = 0; k < columns; ++k) {
      VectorXd plus = x, minus = x;
      plus(k) += h;
      minus(k) -= h;
      D.col(k) = (outputs(plus, options) - outputs(minus, options)) / (2 * h);
    }
    return D;
  }
  cr::BodyImpactDerivatives derivatives(const cr::SolverOptions& options) const {
    rb::ArticulatedBody a = arm;
    cr::RigidBody b = ball;
    cr::RigidBody wall;  // immovable, moving at wall_velocity
    wall.linear_velocity = wall_velocity;
    // Body 1: the sphere or a wall; body 2: a wall (immovable, no unknowns) in either case.
    std::vector<cr::BodyModel*> bodies{&a, with_ball ? static_cast<cr::BodyModel*>(&b) : &wall,
                                       &wall};
    return cr::computeBodyImpactDerivatives(bodies, contacts, options);
  }
  // The prediction computeBodyImpactDerivatives() returns (and leaves the bodies at) against the
  // plain solver's, computeBodyResponse() on copies of the same bodies, to 1e-12 relative: the
  // derivative call may take a lone impulse-space contact's answer from its sensitivity instead of
  // the solver (body_impact_derivatives.cpp), and it must be the same answer.
  void expectThePredictionOfTheSolver(const cr::SolverOptions& options) const {
    rb::ArticulatedBody a1 = arm, a2 = arm;
    cr::RigidBody b1 = ball, b2 = ball;
    cr::RigidBody wall;
    wall.linear_velocity = wall_velocity;
    std::vector<cr::BodyModel*> bodies1{&a1, with_ball ? static_cast<cr::BodyModel*>(&b1) : &wall,
                                        &wall};
    std::vector<cr::BodyModel*> bodies2{&a2, with_ball ? static_cast<cr::BodyModel*>(&b2) : &wall,
                                        &wall};
    const cr::BodyResponse got =
        cr::computeBodyImpactDerivatives(bodies1, contacts, options).result;
    const cr::BodyResponse want = cr::computeBodyResponse(bodies2, contacts, options);
    const auto near = [](double x, double y) {
      return std::abs(x - y) <= 1e-12 * std::max({std::abs(x), std::abs(y), 1e-300});
    };
    // Largest magnitude of a velocity vector (0 for a body without unknowns).
    const auto largest = [](const VectorXd& v) { return v.size() ? v.cwiseAbs().maxCoeff() : 0.0; };
    EXPECT_LE(largest(a1.velocity() - a2.velocity()),
              1e-12 * std::max(1.0, largest(a2.velocity())));
    ASSERT_EQ(b1.velocity().size(), b2.velocity().size());
    EXPECT_LE(largest(b1.velocity() - b2.velocity()),
              1e-12 * std::max(1.0, largest(b2.velocity())));
    ASSERT_EQ(got.impulses.size(), want.impulses.size());
    for (std::size_t c = 0; c < want.impulses.size(); ++c) {
      const cr::ContactImpulse &g = got.impulses[c], &w = want.impulses[c];
      const double impulse = std::max(std::abs(w.normal_impulse), w.friction_impulse.norm());
      EXPECT_LE(std::abs(g.normal_impulse - w.normal_impulse), 1e-12 * impulse) << c;
      EXPECT_LE((g.friction_impulse - w.friction_impulse).norm(), 1e-12 * impulse) << c;
      const double speed =
          std::max(std::abs(w.normal_velocity_before), std::abs(w.normal_velocity_after));
      EXPECT_LE(std::abs(g.normal_velocity_before - w.normal_velocity_before), 1e-12 * speed);
      EXPECT_LE(std::abs(g.normal_velocity_after - w.normal_velocity_after), 1e-12 * speed);
      EXPECT_EQ(g.sticking, w.sticking) << c;
      EXPECT_TRUE(near(got.effective_masses[c], want.effective_masses[c])) << c;
    }
    ASSERT_EQ(got.islands.size(), want.islands.size());
    for (std::size_t i = 0; i < want.islands.size(); ++i) {
      const cr::SolveReport &g = got.islands[i], &w = want.islands[i];
      EXPECT_EQ(g.method, w.method);
      EXPECT_EQ(g.contacts, w.contacts);
      EXPECT_EQ(g.iterations, w.iterations);
      EXPECT_EQ(g.converged, w.converged);
      ASSERT_EQ(g.impulse_space.has_value(), w.impulse_space.has_value());
      if (w.impulse_space) {
        EXPECT_EQ(g.impulse_space->segments, w.impulse_space->segments);
        EXPECT_EQ(g.impulse_space->steps, w.impulse_space->steps);
        EXPECT_EQ(g.impulse_space->series_order, w.impulse_space->series_order);
        EXPECT_EQ(g.impulse_space->fallback, w.impulse_space->fallback);
        EXPECT_TRUE(
            near(g.impulse_space->compression_impulse, w.impulse_space->compression_impulse));
        EXPECT_TRUE(near(g.impulse_space->compression_work, w.impulse_space->compression_work));
      }
    }
    EXPECT_EQ(got.warnings.size(), want.warnings.size());
  }
};

double relativeError(const MatrixXd& got, const MatrixXd& want) {
  return (got - want).cwiseAbs().maxCoeff() / std::max(1.0, want.cwiseAbs().maxCoeff());
}

}  // namespace

// The arm's hand point against an immovable wall along a random normal that the point approaches,
// frictionless, Newton: dv'/dv = I - (1 + e) M^-1 J^T (J M^-1 J^T)^-1 J with J the contact's
// normal row (u_n = J v) and dv'/de = -M^-1 J^T (J M^-1 J^T)^-1 u_n, from the arm's M and point
// Jacobian at each state.
TEST(RobotDerivatives, FrictionlessArmAgainstAWallIsTheClosedForm) {
  std::mt19937 rng(2026);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), restitution(0.1, 0.9);
  for (int trial = 0; trial < 10; ++trial) {
    Scene s{randomArm(rng)};
    s.with_ball = false;
    const int link = s.arm.linkIndex(trial % 2 ? "hand" : "link5");
    const Vector3d p = s.arm.linkPose(link) * Vector3d(0.02, -0.01, 0.04);
    const Vector3d v = s.arm.partPointVelocity(link, p);
    Vector3d n = (v + 0.3 * v.norm() * Vector3d(unit(rng), unit(rng), unit(rng))).normalized();
    if (n.dot(v) <= 0.05 * v.norm()) n = v.normalized();  // the point moves towards the wall
    const double e = restitution(rng);
    cr::ContactPoint contact(0, 1, p, n, e, 0.0, 0.0);  // arm (a) -> wall (b)
    contact.part_a = link;
    s.contacts = {contact};
    const cr::BodyImpactDerivatives d = s.derivatives(withLaw(cr::ImpactLaw::kNewton));
    ASSERT_EQ(d.method, cr::DerivativeMethod::kAnalytic);
    ASSERT_GT(d.result.impulses[0].normal_impulse, 0.0);

    // J: the contact's normal row, u_n = n . (v_wall - v_arm(p)) = J v, so J = -n^T J(p) (1 x N).
    const MatrixXd Minv = s.arm.massMatrix().inverse();
    const MatrixXd J = -n.transpose() * s.arm.linkPointJacobian(link, p);
    const double w = (J * Minv * J.transpose())(0, 0);
    const int N = s.arm.velocityCount();
    const MatrixXd want = MatrixXd::Identity(N, N) - (1 + e) * Minv * J.transpose() * J / w;
    const double u_n = (J * s.arm.velocity())(0);
    ASSERT_LT(u_n, 0.0);
    const VectorXd want_e = -Minv * J.transpose() * u_n / w;
    SCOPED_TRACE("trial " + std::to_string(trial));
    EXPECT_LE(relativeError(d.velocitiesByVelocities(), want), 1e-10);
    EXPECT_LE(relativeError(d.velocitiesByCoefficients().col(0), want_e), 1e-10);
    // The normal impulse's row: P = -(1 + e) u_n / w, so dP/de = -u_n / w.
    EXPECT_NEAR(d.jacobian(N, N), -u_n / w, 1e-10 * std::abs(u_n / w));

    // A normal 0.08 % longer than unit is accepted (validation's tolerance) and solved as the unit
    // normal: the derivatives too (unnormalised, dP/de would be 0.08 % smaller).
    Scene longer = s;
    longer.contacts[0].normal *= 1.0008;
    const cr::BodyImpactDerivatives dl = longer.derivatives(withLaw(cr::ImpactLaw::kNewton));
    EXPECT_NEAR(dl.jacobian(N, N), -u_n / w, 1e-10 * std::abs(u_n / w));
    EXPECT_LE(relativeError(dl.velocitiesByVelocities(), want), 1e-10);
  }
}

// Every block against the test's central differences of the solver at random states: the arm
// struck by a free sphere at two points (Newton frictionless: two contacts through the exact
// solver), with friction under Newton (the closed form's derivative) and under Stronge (the
// integration's sensitivity), all analytic: to 1e-6 relative.
TEST(RobotDerivatives, EveryBlockMatchesCentralDifferencesOfTheSolver) {
  std::mt19937 rng(26);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  struct Case {
    cr::ImpactLaw law;
    double mu_s, mu_d;
    int contacts;
    cr::DerivativeMethod method;
  };
  const std::vector<Case> cases = {
      {cr::ImpactLaw::kNewton, 0.0, 0.0, 1, cr::DerivativeMethod::kAnalytic},
      {cr::ImpactLaw::kNewton, 0.0, 0.0, 2, cr::DerivativeMethod::kAnalytic},
      {cr::ImpactLaw::kNewton, 0.6, 0.4, 1, cr::DerivativeMethod::kAnalytic},
      {cr::ImpactLaw::kStronge, 0.6, 0.4, 1, cr::DerivativeMethod::kAnalytic}};
  int checked = 0;
  for (const Case& test : cases) {
    for (int trial = 0; trial < 4; ++trial) {
      Scene s{randomArm(rng)};
      const int link = s.arm.linkIndex("link7");
      const Vector3d p = s.arm.linkPose(link) * Vector3d(0.0, 0.0, 0.05);
      const Vector3d n = Vector3d(unit(rng), unit(rng), unit(rng)).normalized();  // ball -> arm
      s.ball = sphere(1.5, 0.05, p - 0.05 * n,
                      (n.dot(s.arm.partPointVelocity(link, p)) + 2.0) * n +
                          0.3 * Vector3d(unit(rng), unit(rng), unit(rng)));
      cr::ContactPoint contact(1, 0, p, n, 0.5, test.mu_s, test.mu_d);  // ball (a) -> arm (b)
      contact.body_a = 1;
      contact.body_b = 0;
      contact.part_b = link;
      s.contacts = {contact};
      if (test.contacts == 2) {
        // A second point of the same link, on the ball's surface: two contacts, one island.
        const Vector3d n2 = (n + 0.4 * n.unitOrthogonal()).normalized();
        cr::ContactPoint second(1, 0, s.ball.com + 0.05 * n2, n2, 0.3, 0.0, 0.0);
        second.part_b = link;
        s.contacts.push_back(second);
      }
      // Skip states at a mode switch (a contact barely active or barely separating).
      const cr::BodyImpactDerivatives d = s.derivatives(withLaw(test.law));
      bool clear = true;
      for (const cr::ContactImpulse& impulse : d.result.impulses)
        clear &= impulse.normal_impulse > 1e-3 || impulse.normal_velocity_after > 1e-3;
      if (!clear) continue;
      EXPECT_EQ(d.method, test.method);
      const int N = static_cast<int>(d.velocity_count);
      const MatrixXd want = s.differences(withLaw(test.law), N + 1, 1e-5);  // velocities and e
      SCOPED_TRACE(std::string(cr::toString(test.law)) + " mu " + std::to_string(test.mu_s) + ", " +
                   std::to_string(test.contacts) + " contacts, trial " + std::to_string(trial));
      EXPECT_LE(relativeError(d.jacobian.leftCols(N + 1), want), 1e-6);
      ++checked;
    }
  }
  EXPECT_GE(checked, 10);
}

// The arm's one frictional contact under the impulse-space laws (the sensitivity of the
// integration through the contact's 3x3 W = J M^-1 J^T): the hand struck by a free sphere, and
// the hand against an immovable wall, at random states and coefficients (mu_s >= mu_d), every
// column (joint velocities, the sphere's twist, e, mu_s, mu_d) against the test's central
// differences of computeBodyResponse() (integration tolerance 1e-14), to 1e-6 relative. States
// whose contact is at a reported switch are skipped; both sticking and sliding outcomes occur.
TEST(RobotDerivatives, ImpulseSpaceOneContactIsAnalyticAndMatchesCentralDifferences) {
  std::mt19937 rng(2617);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), mu(0.05, 1.5), ratio(0.4, 0.95),
      restitution(0.1, 0.9);
  for (const cr::ImpactLaw law : {cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    cr::SolverOptions options = withLaw(law);
    options.integration_tolerance = 1e-14;
    int checked = 0, sticking = 0, sliding = 0;
    for (int trial = 0; trial < 40 && checked < 8; ++trial) {
      Scene s{randomArm(rng)};
      const int link = s.arm.linkIndex("hand");
      const Vector3d p = s.arm.linkPose(link) * Vector3d(0.02, -0.01, 0.04);
      const double mu_s = mu(rng), mu_d = ratio(rng) * mu_s;
      if (trial % 2 == 0) {
        // The hand against a wall (body 1 without unknowns) it moves towards.
        s.with_ball = false;
        const Vector3d v = s.arm.partPointVelocity(link, p);
        Vector3d n = (v + 0.8 * v.norm() * Vector3d(unit(rng), unit(rng), unit(rng))).normalized();
        if (n.dot(v) <= 0.2 * v.norm()) continue;
        cr::ContactPoint contact(0, 1, p, n, restitution(rng), mu_s, mu_d);  // arm -> wall
        contact.part_a = link;
        s.contacts = {contact};
      } else {
        const Vector3d n = Vector3d(unit(rng), unit(rng), unit(rng)).normalized();  // ball -> arm
        s.ball = sphere(1.5, 0.05, p - 0.05 * n,
                        (n.dot(s.arm.partPointVelocity(link, p)) + 2.0) * n +
                            0.8 * Vector3d(unit(rng), unit(rng), unit(rng)));
        cr::ContactPoint contact(1, 0, p, n, restitution(rng), mu_s, mu_d);
        contact.part_b = link;
        s.contacts = {contact};
      }
      {
        SCOPED_TRACE(std::string(cr::toString(law)) + " trial " + std::to_string(trial) +
                     ", integration tolerance 1e-14");
        s.expectThePredictionOfTheSolver(options);
      }
      {
        SCOPED_TRACE(std::string(cr::toString(law)) + " trial " + std::to_string(trial) +
                     ", the default integration tolerance");
        s.expectThePredictionOfTheSolver(withLaw(law));
      }
      const cr::BodyImpactDerivatives d = s.derivatives(options);
      ASSERT_EQ(d.method, cr::DerivativeMethod::kAnalytic);
      ASSERT_EQ(d.contacts[0].method, cr::DerivativeMethod::kAnalytic);
      if (d.contacts[0].at_switch || !(d.result.impulses[0].normal_impulse > 1e-3)) continue;
      const int N = static_cast<int>(d.velocity_count);
      const MatrixXd want = s.differences(options, N + 3, 1e-5);
      SCOPED_TRACE(std::string(cr::toString(law)) + " trial " + std::to_string(trial) + " " +
                   cr::toString(d.contacts[0].mode));
      EXPECT_LE(relativeError(d.jacobian, want), 1e-6);
      sticking += d.contacts[0].mode == cr::ImpactMode::kSticking;
      sliding += d.contacts[0].mode == cr::ImpactMode::kSliding;
      ++checked;
    }
    std::printf("%s: %d states (%d sticking, %d sliding)\n", cr::toString(law), checked, sticking,
                sliding);
    EXPECT_GE(checked, 8);
    EXPECT_GE(sticking, 1);
    EXPECT_GE(sliding, 1);
  }
}

// Newton's law with friction on the shipped arm, analytic (the closed form's derivative at one
// contact, the exact solver's final mode at several), every column (joint velocities, the
// sphere's twist, each contact's e, mu_s, mu_d) against the test's central differences of
// computeBodyResponse(), to 1e-6 relative, at random states and coefficients with mu_s > mu_d:
// - one contact: the hand struck by a free sphere, or moving into an immovable wall (which moves:
//   its prescribed velocity enters the contact's u);
// - several contacts, one island: the sphere on two points of link7 (on its surface), and with
//   the hand against the wall as a third contact.
// States with a contact at a reported switch are skipped (the difference would straddle it); the
// outcomes must include sticking and sliding contacts at one and at several contacts, and
// sticking contacts in the band mu_d P_n < |P_t| <= mu_s P_n, where the answer depends on neither
// coefficient (zero friction columns), though the sliding impulse would take mu_d.
TEST(RobotDerivatives, NewtonWithFrictionIsAnalyticAndMatchesCentralDifferences) {
  std::mt19937 rng(2626);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), mu(0.05, 1.5), ratio(0.2, 0.9),
      restitution(0.1, 0.9);
  const cr::SolverOptions options = withLaw(cr::ImpactLaw::kNewton);
  int checked[2] = {0, 0}, sticking[2] = {0, 0}, sliding[2] = {0, 0}, band = 0;
  for (int trial = 0; trial < 300; ++trial) {
    Scene s{randomArm(rng)};
    const int variant = trial % 4;  // 0: sphere, 1: wall, 2: sphere on 2 points, 3: and the wall
    const int hand = s.arm.linkIndex("hand"), link7 = s.arm.linkIndex("link7");
    const auto coefficients = [&](cr::ContactPoint& contact) {
      contact.restitution = restitution(rng);
      contact.static_friction = mu(rng);
      contact.dynamic_friction = ratio(rng) * contact.static_friction;
    };
    const Vector3d p = s.arm.linkPose(variant == 0 ? hand : link7) * Vector3d(0.02, -0.01, 0.05);
    if (variant != 1) {
      const int link = variant == 0 ? hand : link7;
      const Vector3d n = Vector3d(unit(rng), unit(rng), unit(rng)).normalized();  // ball -> arm
      s.ball = sphere(1.5, 0.05, p - 0.05 * n,
                      (n.dot(s.arm.partPointVelocity(link, p)) + 2.0) * n +
                          0.8 * Vector3d(unit(rng), unit(rng), unit(rng)));
      cr::ContactPoint contact(1, 0, p, n, 0.0, 0.0, 0.0);
      contact.part_b = link;
      coefficients(contact);
      s.contacts.push_back(contact);
      if (variant >= 2) {
        const Vector3d n2 = (n + 0.5 * n.unitOrthogonal()).normalized();
        cr::ContactPoint second(1, 0, s.ball.com + 0.05 * n2, n2, 0.0, 0.0, 0.0);
        second.part_b = link7;
        coefficients(second);
        s.contacts.push_back(second);
      }
    } else {
      s.with_ball = false;
    }
    if (variant == 1 || variant == 3) {
      // The hand against a wall (a body without unknowns, moving: index 1 when there is no
      // sphere, a third body otherwise) that it moves towards.
      s.wall_velocity = 0.3 * Vector3d(unit(rng), unit(rng), unit(rng));
      const Vector3d q = s.arm.linkPose(hand) * Vector3d(0.02, -0.01, 0.04);
      const Vector3d v = s.arm.partPointVelocity(hand, q) - s.wall_velocity;
      Vector3d n = (v + 0.8 * v.norm() * Vector3d(unit(rng), unit(rng), unit(rng))).normalized();
      if (n.dot(v) <= 0.2 * v.norm()) continue;
      cr::ContactPoint contact(0, variant == 1 ? 1 : 2, q, n, 0.0, 0.0, 0.0);  // arm -> wall
      contact.part_a = hand;
      coefficients(contact);
      s.contacts.push_back(contact);
    }
    const cr::BodyImpactDerivatives d = s.derivatives(options);
    ASSERT_EQ(d.method, cr::DerivativeMethod::kAnalytic);
    bool clear = true;
    for (std::size_t c = 0; c < s.contacts.size(); ++c) {
      EXPECT_EQ(d.contacts[c].method, cr::DerivativeMethod::kAnalytic);
      const cr::ContactImpulse& impulse = d.result.impulses[c];
      clear &= !d.contacts[c].at_switch &&
               (impulse.normal_impulse > 1e-3 || impulse.normal_velocity_after > 1e-3);
    }
    if (!clear) continue;
    const int N = static_cast<int>(d.velocity_count);
    const MatrixXd want = s.differences(options, N + 3 * static_cast<int>(s.contacts.size()), 1e-5);
    SCOPED_TRACE("trial " + std::to_string(trial) + ", variant " + std::to_string(variant));
    EXPECT_LE(relativeError(d.jacobian, want), 1e-6);
    const int several = s.contacts.size() > 1 ? 1 : 0;
    ++checked[several];
    for (std::size_t c = 0; c < s.contacts.size(); ++c) {
      const cr::ContactImpulse& impulse = d.result.impulses[c];
      sticking[several] += d.contacts[c].mode == cr::ImpactMode::kSticking;
      sliding[several] += d.contacts[c].mode == cr::ImpactMode::kSliding;
      const double friction = impulse.friction_impulse.norm();
      if (d.contacts[c].mode == cr::ImpactMode::kSticking &&
          friction > s.contacts[c].dynamic_friction * impulse.normal_impulse) {
        ++band;
        // In the band the answer depends on neither friction coefficient.
        EXPECT_LE(relativeError(d.jacobian.middleCols(N + 3 * c + 1, 2),
                                want.middleCols(N + 3 * c + 1, 2)),
                  1e-6);
      }
    }
  }
  std::printf(
      "one contact: %d states (%d sticking, %d sliding); several: %d states (%d sticking, "
      "%d sliding contacts); %d sticking in the band mu_d P_n < |P_t| <= mu_s P_n\n",
      checked[0], sticking[0], sliding[0], checked[1], sticking[1], sliding[1], band);
  for (int several = 0; several < 2; ++several) {
    EXPECT_GE(checked[several], 10);
    EXPECT_GE(sticking[several], 2);
    EXPECT_GE(sliding[several], 2);
  }
  EXPECT_GE(band, 2);
}

// The benchmark's scene (benchmark/robot_scene.h, bench_derivatives' arm): the shipped arm
// strikes a free 1.5 kg box with its hand's origin, one frictional contact whose slip turns and
// stops. The sensitivity takes the slip's end by the stick-approach series, as the prediction
// does (asserted on the contact's own W = J M^-1 J^T and u = J v, built here from the arm's and
// the box's Jacobians), and every column of the Jacobian (the 9 joint velocities, the box's
// twist, e, mu_s, mu_d) matches central differences of the solver (at 1e-14) to 1e-6 of the
// column.
TEST(RobotDerivatives, ShippedArmStrikingABoxTakesTheSeriesAndMatchesCentralDifferences) {
  for (const cr::ImpactLaw law : {cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    Eigen::Matrix<double, 9, 1> q, qdot;
    q << 0.3, -0.8, 0.2, 1.4, -0.3, 0.9, 0.1, 0.02, 0.02;
    qdot << 0.5, 0.2, -0.3, 0.4, 0.1, -0.2, 0.3, 0.0, 0.0;
    const Vector3d normal = Vector3d(1, 0.3, -0.2).normalized();
    Scene s{rb::robotFromUrdfFile(kArm7)};
    s.arm.setState(q, qdot);
    const int hand = s.arm.linkIndex("hand");
    const Vector3d p = s.arm.linkPose(hand).translation();
    const double mass = 1.5;
    const Vector3d size(0.2, 0.1, 0.3), s2 = size.cwiseProduct(size);
    const Vector3d inertia =
        mass / 12.0 * Vector3d(s2.y() + s2.z(), s2.x() + s2.z(), s2.x() + s2.y());
    s.ball.inverse_mass = 1.0 / mass;
    s.ball.inverse_inertia = inertia.cwiseInverse().asDiagonal();
    s.ball.com = p + 0.05 * normal;
    s.ball.linear_velocity = -2.0 * normal + Vector3d(0.3, -0.2, 0.1);
    cr::ContactPoint contact(0, 1, p, normal, 0.5, 0.6, 0.5);  // hand -> box
    contact.part_a = hand;
    s.contacts = {contact};
    cr::SolverOptions options = withLaw(law);
    options.integration_tolerance = 1e-14;
    SCOPED_TRACE(cr::toString(law));

    // The contact's W and u, from each side's Jacobians (b minus a).
    const Eigen::MatrixXd Ja = s.arm.partPointJacobian(hand, p);
    const Eigen::MatrixXd Jb = s.ball.partPointJacobian(0, p);
    const Eigen::Matrix3d W = Ja * s.arm.partInverseMassJacobianTranspose(hand, p) +
                              Jb * s.ball.partInverseMassJacobianTranspose(0, p);
    const Vector3d u = Jb * s.ball.velocity() - Ja * s.arm.velocity();
    Eigen::Matrix3d dP_du, dP_dc;
    cr::ContactDerivativeMode mode;
    cr::ImpulseSpaceSensitivityDetail detail;
    ASSERT_TRUE(cr::differentiateImpulseSpace(normal, W, u, 0.5, 0.6, 0.5, law,
                                              options.integration_tolerance, dP_du, dP_dc, mode,
                                              nullptr, &detail));
    EXPECT_TRUE(detail.series);
    s.expectThePredictionOfTheSolver(options);
    s.expectThePredictionOfTheSolver(withLaw(law));  // the benchmark's tolerance

    const cr::BodyImpactDerivatives d = s.derivatives(options);
    ASSERT_EQ(d.contacts[0].method, cr::DerivativeMethod::kAnalytic);
    ASSERT_FALSE(d.contacts[0].at_switch) << d.contacts[0].switch_detail;
    const int N = static_cast<int>(d.velocity_count);
    const MatrixXd want = s.differences(options, N + 3, 1e-5);
    const double largest = want.cwiseAbs().maxCoeff();
    for (int k = 0; k < N + 3; ++k) {
      const double scale = std::max(want.col(k).cwiseAbs().maxCoeff(), 1e-3 * largest);
      EXPECT_LE((d.jacobian.col(k) - want.col(k)).cwiseAbs().maxCoeff(), 1e-6 * scale)
          << "column " << k;
    }
  }
}

// Derivatives with respect to the joint positions (robot/joint_position_coordinates.h), the contact
// point and normal held in the world. The 2R arm of two_link.urdf at q = (0.4, 1.1), qdot = (0.5,
// -0.3), struck at the world point p where its tip is at that q, frictionless, e = 0.5, against an
// immovable wall with normal n. Closed form written here: the Jacobian of link 2's material point
// at world p is [z x p, z x (p - o2(q1))], o2 = l1 (cos q1, sin q1) (the elbow); M(q) from the
// textbook (two_link_arm.h); P = -(1 + e) n.J qdot / (n^T J M^-1 J^T n), qdot' = qdot + M^-1 J^T n
// P. Its central differences in q (step 1e-5: the closed form is smooth) are the reference.
namespace {
struct TwoLinkAtAWorldPoint {
  Eigen::Vector2d p, n;
  Eigen::Vector2d qdot{0.5, -0.3};
  double e = 0.5;
  // (qdot1', qdot2', P) at q.
  Eigen::Vector3d outcome(const Eigen::Vector2d& q) const {
    const auto zCross = [](const Eigen::Vector2d& r) { return Eigen::Vector2d(-r.y(), r.x()); };
    const Eigen::Vector2d elbow = two_link::l1 * Eigen::Vector2d(std::cos(q(0)), std::sin(q(0)));
    Eigen::Matrix2d J;
    J.col(0) = zCross(p);
    J.col(1) = zCross(p - elbow);
    const Eigen::Matrix2d M = two_link::massMatrix(q(1));
    const Eigen::Vector2d Jtn = J.transpose() * n;
    const double P = -(1 + e) * n.dot(J * qdot) / Jtn.dot(M.inverse() * Jtn);
    Eigen::Vector3d out;
    out << qdot + M.inverse() * Jtn * P, P;
    return out;
  }
  // d outcome / d q by central differences.
  Eigen::Matrix<double, 3, 2> reference(const Eigen::Vector2d& q) const {
    Eigen::Matrix<double, 3, 2> d;
    for (int k = 0; k < 2; ++k) {
      Eigen::Vector2d plus = q, minus = q;
      plus(k) += 1e-5;
      minus(k) -= 1e-5;
      d.col(k) = (outcome(plus) - outcome(minus)) / 2e-5;
    }
    return d;
  }
  // The arm of two_link.urdf at q, qdot and the contact at p, n (the wall body 0, the arm's link 2
  // body 1); the contact is written to `contact`.
  rb::ArticulatedBody arm(const Eigen::Vector2d& q, cr::ContactPoint& contact) const {
    rb::ArticulatedBody out = rb::robotFromUrdfFile(std::string(ROBOT_TEST_DIR) + "/two_link.urdf");
    out.setState(q, qdot);
    contact =
        cr::ContactPoint(0, 1, Vector3d(p.x(), p.y(), 0), Vector3d(n.x(), n.y(), 0), e, 0.0, 0.0);
    contact.part_b = out.linkIndex("fore");
    return out;
  }
};
}  // namespace

TEST(RobotDerivatives, JointPositionColumnsMatchTheTwoLinkClosedForm) {
  const Eigen::Vector2d q(0.4, 1.1);
  TwoLinkAtAWorldPoint scene;
  scene.p = two_link::tip(q(0), q(1));
  scene.n = -(two_link::tipJacobian(q(0), q(1)) * scene.qdot).normalized();  // into the wall
  const Eigen::Matrix<double, 3, 2> want = scene.reference(q);
  ASSERT_GT(want.cwiseAbs().maxCoeff(), 0.1);  // q matters here

  cr::ContactPoint contact;
  rb::ArticulatedBody arm = scene.arm(q, contact);
  cr::RigidBody wall;
  std::vector<int> joints;
  const std::vector<cr::ConfigurationCoordinate> coordinates =
      rb::jointPositionCoordinates(arm, &joints);
  ASSERT_EQ(joints, (std::vector<int>{0, 1}));
  const cr::BodyImpactDerivatives d =
      cr::computeBodyImpactDerivatives({&wall, &arm}, {contact}, {}, coordinates);
  ASSERT_EQ(d.coordinate_count, 2);
  ASSERT_EQ(d.jacobian.cols(), 2 + 3 + 2);
  // (mu = 0 sits at its bound: that column's flag, not a configuration's)
  EXPECT_EQ(d.contacts[0].switch_detail.find("configuration"), std::string::npos)
      << d.contacts[0].switch_detail;
  const MatrixXd got = d.jacobian.block(0, 5, 3, 2);  // qdot1', qdot2', P by q1, q2
  EXPECT_LE((got - want).cwiseAbs().maxCoeff(), 1e-6 * want.cwiseAbs().maxCoeff())
      << "got\n"
      << got << "\nwant\n"
      << want;
  EXPECT_LE((d.velocitiesByCoordinates() - want.topRows(2)).cwiseAbs().maxCoeff(),
            1e-6 * want.cwiseAbs().maxCoeff());
  // The arm ends at its q and at the prediction's velocities (the closed form's).
  EXPECT_EQ(arm.jointPositions(), VectorXd(q));
  EXPECT_LE((arm.jointVelocities() - scene.outcome(q).head(2)).cwiseAbs().maxCoeff(), 1e-12);
  // The velocity and coefficient columns are unchanged by the extra columns.
  arm.setState(q, scene.qdot);
  const cr::BodyImpactDerivatives plain =
      cr::computeBodyImpactDerivatives({&wall, &arm}, {contact});
  EXPECT_EQ(plain.jacobian, d.jacobian.leftCols(5));
}

// The closed-form columns never move the robot: coordinates whose set() throws give the same
// columns under Newton's law as those that work (the shipped arm's hand striking a ball), and the
// same coordinates without their body (differenced through set()) throw.
TEST(RobotDerivatives, ClosedFormJointPositionColumnsDoNotMoveTheRobot) {
  std::mt19937 rng(4);
  rb::ArticulatedBody arm = randomArm(rng);
  const int hand = arm.linkIndex("hand");
  const Vector3d p = arm.linkPose(hand).translation();
  const Vector3d normal = Vector3d(0.3, -0.2, 1.0).normalized();
  const cr::RigidBody ball = sphere(0.5, 0.05, p + 0.05 * normal, -1.5 * normal);
  cr::ContactPoint contact(0, 1, p, normal, 0.5, 0.6, 0.5);
  contact.part_a = hand;
  const VectorXd q = arm.jointPositions(), qdot = arm.jointVelocities();
  cr::RigidBody struck = ball;
  std::vector<cr::ConfigurationCoordinate> coordinates = rb::jointPositionCoordinates(arm);
  const cr::BodyImpactDerivatives working = cr::computeBodyImpactDerivatives(
      {&arm, &struck}, {contact}, withLaw(cr::ImpactLaw::kNewton), coordinates);
  EXPECT_EQ(working.coordinate_method, cr::DerivativeMethod::kAnalytic);
  for (cr::ConfigurationCoordinate& c : coordinates)
    c.set = [](double) { throw std::runtime_error("moved"); };
  arm.setState(q, qdot);
  struck = ball;
  const cr::BodyImpactDerivatives d = cr::computeBodyImpactDerivatives(
      {&arm, &struck}, {contact}, withLaw(cr::ImpactLaw::kNewton), coordinates);
  EXPECT_EQ(d.coordinate_method, cr::DerivativeMethod::kAnalytic);
  EXPECT_EQ(d.jacobian, working.jacobian);
  arm.setState(q, qdot);
  struck = ball;
  for (cr::ConfigurationCoordinate& c : coordinates) c.body = nullptr;
  EXPECT_THROW(cr::computeBodyImpactDerivatives({&arm, &struck}, {contact},
                                                withLaw(cr::ImpactLaw::kNewton), coordinates),
               std::runtime_error);
}

// A coordinate whose perturbed solve fails (here its setter throws on the minus side, as a robot's
// setState() does where M(q - h) is singular): the error goes on, and the arm is back at its q and
// at the prediction's velocities (the closed form's).
TEST(RobotDerivatives, JointPositionColumnThatThrowsLeavesTheArmAsItWas) {
  const Eigen::Vector2d q(0.4, 1.1);
  TwoLinkAtAWorldPoint scene;
  scene.p = two_link::tip(q(0), q(1));
  scene.n = -(two_link::tipJacobian(q(0), q(1)) * scene.qdot).normalized();
  cr::ContactPoint contact;
  rb::ArticulatedBody arm = scene.arm(q, contact);
  cr::RigidBody wall;
  std::vector<cr::ConfigurationCoordinate> coordinates = rb::jointPositionCoordinates(arm);
  const auto set = coordinates[1].set;
  const double value = coordinates[1].value;
  coordinates[1].set = [set, value](double x) {
    if (x < value) throw std::runtime_error("no state below q2");
    set(x);
  };
  EXPECT_THROW(cr::computeBodyImpactDerivatives({&wall, &arm}, {contact}, {}, coordinates),
               std::runtime_error);
  EXPECT_EQ(arm.jointPositions(), VectorXd(q));
  EXPECT_LE((arm.jointVelocities() - scene.outcome(q).head(2)).cwiseAbs().maxCoeff(), 1e-12);
}

// At a mode switch: the tip barely approaches the wall (n.J qdot = -1e-9 m/s), so that moving q1 by
// the difference step one way makes it separate (no impulse). The column is then one-sided on the
// impulse's side, equal to the closed form's derivative there, and the contact says so.
TEST(RobotDerivatives, JointPositionColumnAtASeparationSwitchIsOneSided) {
  const Eigen::Vector2d q(0.4, 1.1);
  TwoLinkAtAWorldPoint scene;
  scene.p = two_link::tip(q(0), q(1));
  const Eigen::Matrix2d J = two_link::tipJacobian(q(0), q(1));
  // n along the tip's velocity turned by 90 degrees, tilted so that n.J qdot = -1e-9.
  const Eigen::Vector2d v = J * scene.qdot;
  const Eigen::Vector2d side(-v.y(), v.x());
  scene.n = (side.normalized() - 1e-9 / v.norm() * v.normalized()).normalized();
  ASSERT_LT(scene.n.dot(v), 0.0);
  ASSERT_GT(scene.n.dot(v), -2e-9);
  const Eigen::Matrix<double, 3, 2> want = scene.reference(q);  // the impulse side's (smooth)

  cr::ContactPoint contact;
  rb::ArticulatedBody arm = scene.arm(q, contact);
  cr::RigidBody wall;
  const cr::BodyImpactDerivatives d = cr::computeBodyImpactDerivatives(
      {&wall, &arm}, {contact}, {}, rb::jointPositionCoordinates(arm));
  EXPECT_TRUE(d.contacts[0].at_switch);
  EXPECT_NE(d.contacts[0].switch_detail.find("one-sided"), std::string::npos)
      << d.contacts[0].switch_detail;
  const MatrixXd got = d.jacobian.block(0, 5, 3, 2);
  EXPECT_LE((got - want).cwiseAbs().maxCoeff(), 1e-4 * want.cwiseAbs().maxCoeff())
      << "got\n"
      << got << "\nwant\n"
      << want;
}

// The shipped arm struck on the hand by a sphere with friction (Newton: analytic; Stronge: the
// series), the joint-position columns against the test's own central differences of
// computeBodyResponse() with the arm set to q +- h (setState) here, 1e-6 relative.
TEST(RobotDerivatives, ShippedArmJointPositionColumnsMatchCentralDifferences) {
  std::mt19937 rng(11);
  for (const cr::ImpactLaw law : {cr::ImpactLaw::kNewton, cr::ImpactLaw::kStronge}) {
    rb::ArticulatedBody arm = randomArm(rng);
    const int hand = arm.linkIndex("hand");
    const Vector3d p = arm.linkPose(hand).translation();
    const Vector3d normal = (Vector3d(0.3, -0.2, 1.0)).normalized();  // from the hand to the ball
    cr::RigidBody ball = sphere(0.5, 0.05, p + 0.05 * normal, -1.5 * normal + Vector3d(0.4, 0, 0));
    cr::ContactPoint contact(0, 1, p, normal, 0.5, 0.6, 0.5);
    contact.part_a = hand;
    cr::SolverOptions options = withLaw(law);
    options.integration_tolerance = 1e-14;
    const VectorXd q = arm.jointPositions(), qdot = arm.jointVelocities();
    const int n = arm.velocityCount();
    const auto outputs = [&](const VectorXd& at) {
      rb::ArticulatedBody a = arm;
      a.setState(at, qdot);
      cr::RigidBody b = ball;
      const cr::BodyResponse r = cr::computeBodyResponse({&a, &b}, {contact}, options);
      VectorXd out(n + 6 + 4);
      out << a.velocity(), b.velocity(), r.impulses[0].normal_impulse,
          r.impulses[0].friction_impulse;
      return out;
    };
    std::vector<int> joints;
    rb::ArticulatedBody differentiated = arm;
    cr::RigidBody struck = ball;
    const cr::BodyImpactDerivatives d =
        cr::computeBodyImpactDerivatives({&differentiated, &struck}, {contact}, options,
                                         rb::jointPositionCoordinates(differentiated, &joints));
    ASSERT_EQ(static_cast<int>(joints.size()), arm.jointCount());  // no mimic joints
    ASSERT_FALSE(d.contacts[0].at_switch) << d.contacts[0].switch_detail;
    // Newton's closed form, Stronge's sensitivity with K's entries: both in closed form.
    EXPECT_EQ(d.coordinate_method, cr::DerivativeMethod::kAnalytic);
    MatrixXd want(n + 10, arm.jointCount());
    for (int k = 0; k < arm.jointCount(); ++k) {
      VectorXd plus = q, minus = q;
      plus(k) += 1e-6;
      minus(k) -= 1e-6;
      want.col(k) = (outputs(plus) - outputs(minus)) / 2e-6;
    }
    const MatrixXd got = d.jacobian.rightCols(arm.jointCount());
    const double largest = want.cwiseAbs().maxCoeff();
    ASSERT_GT(largest, 0.1);
    for (int k = 0; k < arm.jointCount(); ++k) {
      const double scale = std::max(want.col(k).cwiseAbs().maxCoeff(), 1e-3 * largest);
      EXPECT_LE((got.col(k) - want.col(k)).cwiseAbs().maxCoeff(), 1e-6 * scale)
          << cr::toString(law) << " joint " << k;
    }
    EXPECT_EQ(differentiated.jointPositions(), q);
  }
}

// Mimic joints (gripper.urdf: finger2_joint mimics finger1_joint): one coordinate per joint that
// mimics no other (the wrist, finger 1), the follower moved with its leader. The gripper struck on
// the follower's pad with mu_s > mu_d under Newton: every column against the test's own central
// differences of computeBodyResponse() with the leader's position moved by setState(), 1e-6.
TEST(RobotDerivatives, MimicGripperJointPositionColumnsMoveTheLeader) {
  rb::ArticulatedBody gripper =
      rb::robotFromUrdfFile(std::string(ROBOT_TEST_DIR) + "/gripper.urdf");
  const int f1 = gripper.jointIndex("finger1_joint");
  const VectorXd q = Eigen::Vector3d(0.3, 0.02, 0.02), qdot = Eigen::Vector3d(0.5, 0.05, 0.05);
  gripper.setState(q, qdot);
  const int pad = gripper.linkIndex("finger2");
  const Eigen::Isometry3d pose = gripper.linkPose(pad);
  const Vector3d p = pose * Vector3d(0.0, -0.01, 0.03);
  const Vector3d n = (pose.linear() * Vector3d(0.2, -1.0, 0.1)).normalized();
  const cr::RigidBody ball = sphere(0.2, 0.03, p + 0.03 * n, -2.0 * n + Vector3d(0.3, 0, 0));
  cr::ContactPoint contact(0, 1, p, n, 0.5, 0.8, 0.5);
  contact.part_a = pad;
  const cr::SolverOptions options = withLaw(cr::ImpactLaw::kNewton);
  std::vector<int> joints;
  rb::ArticulatedBody differentiated = gripper;
  cr::RigidBody struck = ball;
  const cr::BodyImpactDerivatives d =
      cr::computeBodyImpactDerivatives({&differentiated, &struck}, {contact}, options,
                                       rb::jointPositionCoordinates(differentiated, &joints));
  ASSERT_EQ(joints, (std::vector<int>{gripper.jointIndex("wrist"), f1}));
  const auto outputs = [&](const VectorXd& at) {
    rb::ArticulatedBody a = gripper;
    a.setState(at, qdot);
    cr::RigidBody b = ball;
    const cr::BodyResponse r = cr::computeBodyResponse({&a, &b}, {contact}, options);
    VectorXd out(a.velocityCount() + 6 + 4);
    out << a.velocity(), b.velocity(), r.impulses[0].normal_impulse, r.impulses[0].friction_impulse;
    return out;
  };
  ASSERT_GT(d.result.impulses[0].normal_impulse, 0.0);
  ASSERT_FALSE(d.contacts[0].at_switch) << d.contacts[0].switch_detail;
  EXPECT_EQ(d.coordinate_method, cr::DerivativeMethod::kAnalytic);
  for (std::size_t k = 0; k < joints.size(); ++k) {
    VectorXd plus = q, minus = q;
    plus(joints[k]) += 1e-6;
    minus(joints[k]) -= 1e-6;
    const VectorXd want = (outputs(plus) - outputs(minus)) / 2e-6;
    const VectorXd got = d.jacobian.col(d.jacobian.cols() - 2 + static_cast<Eigen::Index>(k));
    EXPECT_LE((got - want).cwiseAbs().maxCoeff(), 1e-6 * std::max(1.0, want.cwiseAbs().maxCoeff()))
        << "joint " << joints[k] << "\n"
        << got.transpose() << "\n"
        << want.transpose();
  }
  EXPECT_EQ(differentiated.jointPositions()(2), differentiated.jointPositions()(f1));
}

// ---- Joint-position columns in closed form (Newton's law) ------------------------------------
// Robots (fixed or floating bases, a locked joint) and a ball, every robot's joint positions as
// coordinates; the columns against the test's own central differences of computeBodyResponse()
// with one joint moved by setState() on copies (step 1e-6 rad), the contacts held in the world.
namespace {

struct PosedRobot {
  rb::ArticulatedBody body;
  VectorXd q, qdot;
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  Vector3d base_v = Vector3d::Zero(), base_w = Vector3d::Zero();
  void pose() { body.setState(q, qdot, base, base_v, base_w); }
};

struct RobotsAndBall {
  std::vector<PosedRobot> robots;
  cr::RigidBody ball;
  std::vector<cr::ContactPoint> contacts;  // bodies: robots 0..R-1, then the ball
  cr::SolverOptions options = withLaw(cr::ImpactLaw::kNewton);

  // The library's outputs with robot r's joint `joint` moved by dq (the others as posed); with
  // `velocity`, robot r's velocity unknown `joint` moved by dq instead (r = robots.size(): the
  // ball's twist entry).
  VectorXd outputs(std::size_t r, int joint, double dq, bool velocity = false) const {
    std::vector<PosedRobot> copies = robots;
    cr::RigidBody b = ball;
    if (!velocity) {
      copies[r].q(joint) += dq;
    } else if (r == robots.size()) {
      (joint < 3 ? b.linear_velocity(joint) : b.angular_velocity(joint - 3)) += dq;
    } else {
      PosedRobot& c = copies[r];
      const int base = c.body.baseType() == rb::BaseType::kFloating ? 6 : 0;
      if (joint < base) {
        (joint < 3 ? c.base_v(joint) : c.base_w(joint - 3)) += dq;
      } else {
        c.qdot(c.body.jointOfUnknown(joint)) += dq;
      }
    }
    std::vector<cr::BodyModel*> bodies;
    Eigen::Index n = 6;
    for (PosedRobot& copy : copies) {
      copy.pose();
      bodies.push_back(&copy.body);
      n += copy.body.velocityCount();
    }
    bodies.push_back(&b);
    const cr::BodyResponse result = cr::computeBodyResponse(bodies, contacts, options);
    VectorXd out(n + 4 * static_cast<Eigen::Index>(contacts.size()));
    Eigen::Index row = 0;
    for (const cr::BodyModel* body : bodies) {
      out.segment(row, body->velocityCount()) = body->velocity();
      row += body->velocityCount();
    }
    for (const cr::ContactImpulse& impulse : result.impulses) {
      out(row) = impulse.normal_impulse;
      out.segment<3>(row + 1) = impulse.friction_impulse;
      row += 4;
    }
    return out;
  }

  // The arm (robots[0]) struck by the ball at a point of its hand (trial % 4 < 2) or its link5,
  // along a random normal n (from the link to the ball) at 1.2 m/s with a random sideways part of
  // up to `sideways` m/s; restitution e; friction by trial: mu_s 0.8 > mu_d 0.3, 0.15 = 0.15 every
  // fourth, none every fifth. The contact is appended and returned.
  cr::ContactPoint strikeArm(int trial, std::mt19937& rng, double e, double sideways) {
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    const rb::ArticulatedBody& arm = robots[0].body;
    const int link = arm.linkIndex(trial % 4 < 2 ? "hand" : "link5");
    const Vector3d p = arm.linkPose(link) * Vector3d(0.02, -0.01, 0.03);
    const Vector3d n = Vector3d(unit(rng), unit(rng), 1.0).normalized();
    ball = sphere(0.4, 0.05, p + 0.05 * n, -1.2 * n + sideways * Vector3d(unit(rng), unit(rng), 0));
    const bool without_friction = trial % 5 == 4, band = trial % 4 != 3;
    cr::ContactPoint contact(0, 1, p, n, e,
                             without_friction ? 0.0
                             : band           ? 0.8
                                              : 0.15,
                             without_friction ? 0.0
                             : band           ? 0.3
                                              : 0.15);
    contact.part_a = link;
    contacts.push_back(contact);
    return contact;
  }

  // The differences' step [rad | m, m/s | rad/s]: 1e-5 leaves a margin of 10 over their own
  // round-off at the 1e-6 tolerance (1e-6 came within a factor of 2 on multi-robot scenes).
  static constexpr double kStep = 1e-5;

  // Differentiates and checks every velocity and coordinate column (failures labelled `label`);
  // returns the derivatives.
  cr::BodyImpactDerivatives check(const std::string& label, double tolerance = 1e-6) {
    SCOPED_TRACE(label + ", " + std::to_string(contacts.size()) + " contacts");
    std::vector<cr::BodyModel*> bodies;
    std::vector<cr::ConfigurationCoordinate> coordinates;
    std::vector<std::pair<std::size_t, int>> joint_of;  // per coordinate: robot, joint
    std::vector<PosedRobot> differentiated = robots;
    for (std::size_t r = 0; r < differentiated.size(); ++r) {
      differentiated[r].pose();
      bodies.push_back(&differentiated[r].body);
      std::vector<int> joints;
      for (cr::ConfigurationCoordinate& c :
           rb::jointPositionCoordinates(differentiated[r].body, &joints))
        coordinates.push_back(std::move(c));
      for (const int j : joints) joint_of.emplace_back(r, j);
    }
    cr::RigidBody b = ball;
    bodies.push_back(&b);
    const cr::BodyImpactDerivatives d =
        cr::computeBodyImpactDerivatives(bodies, contacts, options, coordinates);
    // The velocity columns (a locked joint's kept velocity moves u: not in J v).
    Eigen::Index column = 0;
    for (std::size_t r = 0; r <= robots.size(); ++r) {
      const int n = r < robots.size() ? robots[r].body.velocityCount() : 6;
      for (int k = 0; k < n; ++k, ++column) {
        const VectorXd want =
            (outputs(r, k, kStep, true) - outputs(r, k, -kStep, true)) / (2 * kStep);
        EXPECT_LE((d.jacobian.col(column) - want).cwiseAbs().maxCoeff(),
                  tolerance * std::max(1.0, want.cwiseAbs().maxCoeff()))
            << "body " << r << " velocity unknown " << k;
      }
    }
    const Eigen::Index first = d.jacobian.cols() - d.coordinate_count;
    for (std::size_t k = 0; k < joint_of.size(); ++k) {
      const auto [r, joint] = joint_of[k];
      const VectorXd want = (outputs(r, joint, kStep) - outputs(r, joint, -kStep)) / (2 * kStep);
      const VectorXd got = d.jacobian.col(first + static_cast<Eigen::Index>(k));
      EXPECT_LE((got - want).cwiseAbs().maxCoeff(),
                tolerance * std::max(1.0, want.cwiseAbs().maxCoeff()))
          << "robot " << r << " joint " << joint << "\ngot  " << got.transpose() << "\nwant "
          << want.transpose();
    }
    return d;
  }
};

// Whether a contact is flagged at a switch, beyond the frictionless contacts' own flag (their
// friction columns one-sided, which does not touch the other columns).
bool anyAtSwitch(const cr::BodyImpactDerivatives& d) {
  for (const cr::ContactDerivativeMode& mode : d.contacts) {
    if (mode.at_switch && mode.switch_detail.rfind("frictionless: ", 0) != 0) return true;
    if (mode.at_switch && mode.switch_detail.find("; ") != std::string::npos) return true;
  }
  return false;
}

enum class Locks { kNone, kJoint3, kJoint2, kAll };

// The shipped arm at a random state; `locks`: none, index 3 (joint4: its velocity kept, its
// position still shapes M and J), index 1 (joint2, the mimic root below: its group locked), or
// every joint (no velocity unknown on a fixed base, 9 coordinates); `mimic`: joint5 follows joint2
// at multiplier -0.7, offset 0.1 (root and follower on one path).
PosedRobot randomPosedArm(std::mt19937& rng, rb::BaseType base, Locks locks, bool mimic = false) {
  std::uniform_real_distribution<double> angle(-M_PI, M_PI), unit(-1.0, 1.0);
  PosedRobot r{rb::robotFromUrdfFile(kArm7, base)};
  if (mimic) r.body.setMimicJoints({{"joint5", "joint2", -0.7, 0.1}});
  const int n = r.body.jointCount();
  r.q.resize(n);
  r.qdot.resize(n);
  for (int i = 0; i < n; ++i) {
    r.q(i) = i < 7 ? angle(rng) : 0.02;
    r.qdot(i) = i < 7 ? unit(rng) : 0.0;
  }
  if (locks != Locks::kNone) {
    std::vector<bool> locked(n, locks == Locks::kAll);
    locked[locks == Locks::kJoint2 ? 1 : 3] = true;
    r.body.setLockedJoints(locked);
  }
  if (base == rb::BaseType::kFloating) {
    r.base = Eigen::Translation3d(0.1, 0.2, -0.1) *
             Eigen::AngleAxisd(angle(rng), Vector3d(unit(rng), unit(rng), 1.0).normalized());
    r.base_v = Vector3d(unit(rng), unit(rng), unit(rng)) * 0.3;
    r.base_w = Vector3d(unit(rng), unit(rng), unit(rng)) * 0.3;
  }
  r.pose();
  return r;
}

}  // namespace

// One contact (Newton's closed form) and two (the exact solver's final mode) between the arm's
// hand and a ball, on fixed and floating bases, with a locked joint moving at its kept velocity,
// with joint5 mimicking joint2 (multiplier -0.7; its root locked on some), mu_s 0.8 > mu_d 0.3 (the
// band between mu_d N and mu_s N), 0.15 = 0.15 or frictionless, and on some the hand also against
// the arm's own link2 (one body on both sides): sticking and sliding both met. Every column in
// closed form (coordinate_method) and equal to the differences.
TEST(RobotDerivatives, NewtonJointPositionColumnsAreClosedFormAcrossModes) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  int sticking = 0, sliding = 0, islands = 0, frictionless = 0, self = 0, mimic = 0, closed = 0;
  for (int trial = 0; trial < 40; ++trial) {
    RobotsAndBall s;
    const rb::BaseType base = trial % 2 ? rb::BaseType::kFloating : rb::BaseType::kFixed;
    const bool with_mimic = trial % 5 == 2;
    const Locks locks = trial % 3 != 0 ? Locks::kNone
                        : with_mimic   ? Locks::kJoint2
                                       : Locks::kJoint3;
    s.robots.push_back(randomPosedArm(rng, base, locks, with_mimic));
    rb::ArticulatedBody& arm = s.robots[0].body;
    const cr::ContactPoint contact = s.strikeArm(trial, rng, 0.4, 0.6);
    const int hand = contact.part_a;
    const Vector3d p = contact.point, n = contact.normal;
    const double mu_s = contact.static_friction, mu_d = contact.dynamic_friction;
    const bool without_friction = mu_s == 0.0;
    if (trial % 2 == 0) {  // a second point of the hand on the ball: one island of two
      cr::ContactPoint second = contact;
      const Vector3d t = n.unitOrthogonal();
      second.point = p + 0.03 * t;
      second.normal = (n - 0.4 * t).normalized();
      s.contacts.push_back(second);
    }
    const bool with_self = trial % 6 == 5;
    if (with_self) {  // the hand against link2 at the hand's point, approaching
      const int link2 = arm.linkIndex("link2");
      const Vector3d u = arm.partPointVelocity(link2, p) - arm.partPointVelocity(hand, p);
      Vector3d normal = Vector3d(unit(rng), unit(rng), unit(rng)).normalized();
      if (normal.dot(u) > 0.0) normal = -normal;
      cr::ContactPoint own(0, 0, p, normal, 0.3, mu_s, mu_d);
      own.part_a = hand;
      own.part_b = link2;
      s.contacts.push_back(own);
    }
    const cr::BodyImpactDerivatives d = s.check("trial " + std::to_string(trial));
    if (anyAtSwitch(d)) continue;
    EXPECT_EQ(d.coordinate_method, cr::DerivativeMethod::kAnalytic) << "trial " << trial;
    if (d.coordinate_method != cr::DerivativeMethod::kAnalytic) continue;
    ++closed;
    islands += s.contacts.size() > 1;
    frictionless += without_friction;
    self += with_self;
    mimic += with_mimic;
    for (const cr::ContactDerivativeMode& mode : d.contacts) {
      sticking += mode.mode == cr::ImpactMode::kSticking;
      sliding += mode.mode == cr::ImpactMode::kSliding;
    }
  }
  std::printf(
      "%d of 40 in closed form (%d with two or more contacts, %d frictionless, %d with the "
      "arm against itself, %d with the mimic joint): %d sticking, %d sliding contacts\n",
      closed, islands, frictionless, self, mimic, sticking, sliding);
  EXPECT_GE(closed, 25);
  EXPECT_GE(sticking, 3);
  EXPECT_GE(sliding, 3);
  EXPECT_GE(islands, 3);
  EXPECT_GE(frictionless, 2);
  EXPECT_GE(self, 2);
  EXPECT_GE(mimic, 2);
}

// A robot with every joint locked has no velocity unknown but its joint positions still move its
// points (9 coordinates): the ball it strikes, in closed form. With the ball at three points of the
// hand (mu 2), two or three of them sticking are redundant (a rigid ball's velocities at two points
// have rank 5 of 6): the columns are differenced (coordinate_method), and still equal to the
// differences here.
TEST(RobotDerivatives, LockedArmJointPositionColumnsAndTheRedundantFallback) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  int closed = 0, redundant = 0;
  for (int trial = 0; trial < 8; ++trial) {
    RobotsAndBall s;
    s.robots.push_back(randomPosedArm(rng, rb::BaseType::kFixed, Locks::kAll));
    ASSERT_EQ(s.robots[0].body.velocityCount(), 0);
    rb::ArticulatedBody& arm = s.robots[0].body;
    const int hand = arm.linkIndex("hand");
    const Vector3d p = arm.linkPose(hand) * Vector3d(0.01, 0.02, 0.03);
    const Vector3d n = Vector3d(unit(rng), unit(rng), 1.0).normalized();
    s.ball = sphere(0.4, 0.05, p + 0.05 * n, -1.5 * n + 0.2 * Vector3d(unit(rng), 0, 0));
    const bool three = trial % 2 == 1;
    cr::ContactPoint contact(0, 1, p, n, 0.5, three ? 2.0 : 0.6, three ? 2.0 : 0.4);
    contact.part_a = hand;
    s.contacts.push_back(contact);
    if (three) {
      const Vector3d t1 = n.unitOrthogonal(), t2 = n.cross(t1);
      for (const Vector3d& t : {t1, t2}) {
        cr::ContactPoint other = contact;
        other.point = p + 0.02 * t;
        s.contacts.push_back(other);
      }
    }
    const cr::BodyImpactDerivatives d = s.check("trial " + std::to_string(trial));
    if (anyAtSwitch(d)) continue;
    if (!three) {
      EXPECT_EQ(d.coordinate_method, cr::DerivativeMethod::kAnalytic) << "trial " << trial;
      closed += d.coordinate_method == cr::DerivativeMethod::kAnalytic;
    } else if (d.method == cr::DerivativeMethod::kAnalytic &&
               d.coordinate_method == cr::DerivativeMethod::kFiniteDifference) {
      ++redundant;  // two or three of the points sticking: W singular, the columns differenced
    }
  }
  std::printf("%d in closed form, %d redundant and differenced\n", closed, redundant);
  EXPECT_GE(closed, 3);
  EXPECT_GE(redundant, 2);
}

// One contact under Poisson and Stronge, the arm with a locked joint moving at its kept velocity:
// the prediction computeBodyImpactDerivatives() writes from the contact's sensitivity equals
// computeBodyResponse()'s (it used to leave the locked joint out of u: P_n 0.517 against 0.282 N s
// on one such strike), and every column equals the differences (the joint positions' in closed
// form: the sensitivity with K's entries).
TEST(RobotDerivatives, ImpulseSpaceLoneContactWithAMovingLockedJoint) {
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (const cr::ImpactLaw law : {cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    for (int trial = 0; trial < 6; ++trial) {
      RobotsAndBall s;
      s.options = withLaw(law);
      s.options.integration_tolerance = 1e-14;
      s.robots.push_back(randomPosedArm(rng, rb::BaseType::kFixed, Locks::kJoint3));
      s.robots[0].qdot(3) = 2.0;  // the locked joint's kept velocity [rad/s]
      s.robots[0].pose();
      rb::ArticulatedBody& arm = s.robots[0].body;
      const int hand = arm.linkIndex("hand");
      const Vector3d p = arm.linkPose(hand).translation();
      const Vector3d n = Vector3d(unit(rng), unit(rng), 1.0).normalized();
      s.ball = sphere(0.5, 0.05, p + 0.05 * n, -1.0 * n);
      cr::ContactPoint contact(0, 1, p, n, 0.5, 0.6, 0.4);
      contact.part_a = hand;
      s.contacts.push_back(contact);
      const cr::BodyImpactDerivatives d =
          s.check(std::string(cr::toString(law)) + " trial " + std::to_string(trial));
      if (!anyAtSwitch(d)) EXPECT_EQ(d.coordinate_method, cr::DerivativeMethod::kAnalytic);
      cr::RigidBody ball = s.ball;
      rb::ArticulatedBody predicted = arm;
      const cr::BodyResponse want =
          cr::computeBodyResponse({&predicted, &ball}, s.contacts, s.options);
      EXPECT_NEAR(d.result.impulses[0].normal_impulse, want.impulses[0].normal_impulse,
                  1e-9 * std::max(1.0, want.impulses[0].normal_impulse));
      EXPECT_LE((d.result.impulses[0].friction_impulse - want.impulses[0].friction_impulse).norm(),
                1e-9 * std::max(1.0, want.impulses[0].normal_impulse));
    }
  }
}

// One contact under Poisson and Stronge (the sensitivity carrying K's six entries: dP = dP/du du +
// dP/dK dK), the arm's hand or link5 struck by a ball on fixed and floating bases, with a locked
// joint, with joint5 mimicking joint2, mu_s 0.8 > mu_d 0.3, 0.15 = 0.15 or frictionless: sticking
// (after a turning slip stops, or from the start) and sliding both met; every column against the
// test's differences at integration tolerance 1e-14, 1e-6.
TEST(RobotDerivatives, ImpulseSpaceJointPositionColumnsAreClosedForm) {
  std::mt19937 rng(31);
  for (const cr::ImpactLaw law : {cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    int closed = 0, sticking = 0, sliding = 0;
    for (int trial = 0; trial < 16; ++trial) {
      RobotsAndBall s;
      s.options = withLaw(law);
      s.options.integration_tolerance = 1e-14;
      const rb::BaseType base = trial % 2 ? rb::BaseType::kFloating : rb::BaseType::kFixed;
      s.robots.push_back(randomPosedArm(rng, base, trial % 3 == 0 ? Locks::kJoint3 : Locks::kNone,
                                        trial % 5 == 2));
      s.strikeArm(trial, rng, 0.5, 0.8);
      const cr::BodyImpactDerivatives d =
          s.check(std::string(cr::toString(law)) + " trial " + std::to_string(trial));
      if (anyAtSwitch(d)) continue;
      EXPECT_EQ(d.coordinate_method, cr::DerivativeMethod::kAnalytic) << "trial " << trial;
      closed += d.coordinate_method == cr::DerivativeMethod::kAnalytic;
      sticking += d.contacts[0].mode == cr::ImpactMode::kSticking;
      sliding += d.contacts[0].mode == cr::ImpactMode::kSliding;
    }
    std::printf("%s: %d of 16 in closed form, %d sticking, %d sliding\n", cr::toString(law), closed,
                sticking, sliding);
    EXPECT_GE(closed, 10);
    EXPECT_GE(sticking, 2);
    EXPECT_GE(sliding, 2);
  }
}

// Two robots striking each other (two arms facing each other across 0.9 m, the second on a
// floating base on some; the contact at a world point of the first arm's hand, where the second's
// link6 also has a material point): both robots' joints are coordinates, and K moves with either.
// Then both strike the ball too.
TEST(RobotDerivatives, TwoRobotsJointPositionColumnsAreClosedForm) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  int closed = 0;
  for (int trial = 0; trial < 6; ++trial) {
    RobotsAndBall s;
    s.robots.push_back(randomPosedArm(rng, rb::BaseType::kFixed, Locks::kNone));
    s.robots.push_back(
        randomPosedArm(rng, trial % 3 == 2 ? rb::BaseType::kFloating : rb::BaseType::kFixed,
                       trial % 2 == 1 ? Locks::kJoint3 : Locks::kNone));
    s.robots[1].base =
        Eigen::Translation3d(0.9, 0.0, 0.0) * Eigen::AngleAxisd(M_PI, Vector3d::UnitZ());
    s.robots[1].pose();
    const int hand = s.robots[0].body.linkIndex("hand");
    const int other = s.robots[1].body.linkIndex("link6");
    const Vector3d p = s.robots[0].body.linkPose(hand).translation();
    const Vector3d u =
        s.robots[1].body.partPointVelocity(other, p) - s.robots[0].body.partPointVelocity(hand, p);
    // From robot 0 to robot 1, approaching: n . u < 0.
    const Vector3d n =
        (-u.normalized() + 0.3 * Vector3d(unit(rng), unit(rng), unit(rng))).normalized();
    if (!(n.dot(u) < -0.05)) continue;
    cr::ContactPoint contact(0, 1, p, n, 0.3, 0.5, 0.3);
    contact.part_a = hand;
    contact.part_b = other;
    s.contacts.push_back(contact);
    s.ball = sphere(0.4, 0.05, p + Vector3d(0, 0, 0.3), Vector3d(0, 0, -1.0));
    if (trial >= 3) {  // the second robot's hand also meets the ball
      const int hand1 = s.robots[1].body.linkIndex("hand");
      const Vector3d q = s.robots[1].body.linkPose(hand1).translation();
      s.ball = sphere(0.4, 0.05, q + Vector3d(0, 0, 0.05), Vector3d(0.2, 0, -1.0));
      cr::ContactPoint strike(1, 2, q, Vector3d::UnitZ(), 0.5, 0.6, 0.4);
      strike.part_a = hand1;
      s.contacts.push_back(strike);
    }
    const cr::BodyImpactDerivatives d = s.check("trial " + std::to_string(trial));
    if (anyAtSwitch(d)) continue;
    EXPECT_EQ(d.coordinate_method, cr::DerivativeMethod::kAnalytic);
    closed += d.coordinate_method == cr::DerivativeMethod::kAnalytic;
  }
  EXPECT_GE(closed, 4);
}
