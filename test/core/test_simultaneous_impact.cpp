// The simultaneous impulse-space integration of Poisson and Stronge (simultaneous_impact.h,
// docs/physics.md, "Simultaneous impulse-space integration"): symmetric scenes equal one contact
// at their midpoint, hand-derived answers, and invariants on random scenes.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <vector>

#include "collision_response/core/contact_point.h"
#include "collision_response/core/contact_problem.h"
#include "collision_response/core/island_solver.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/simultaneous_impact.h"
#include "collision_response/core/solver_options.h"

namespace cr = collision_response::core;
using Eigen::Matrix3d;
using Eigen::Vector3d;

namespace {

constexpr double kTol = 1e-9;

cr::RigidBody ground() {
  return cr::RigidBody();
}

// A box of mass m and full sizes `size`, rotated by `rotation`, at `com`.
cr::RigidBody box(double m, const Vector3d& size, const Matrix3d& rotation, const Vector3d& com,
                  const Vector3d& v, const Vector3d& w) {
  cr::RigidBody b;
  b.inverse_mass = 1.0 / m;
  const Vector3d s2 = size.cwiseProduct(size);
  const Vector3d inertia(m * (s2.y() + s2.z()) / 12, m * (s2.x() + s2.z()) / 12,
                         m * (s2.x() + s2.y()) / 12);
  b.inverse_inertia = rotation * inertia.cwiseInverse().asDiagonal() * rotation.transpose();
  b.com = com;
  b.linear_velocity = v;
  b.angular_velocity = w;
  return b;
}

struct Outcome {
  cr::RigidBody body;
  cr::SolveReport report;
  std::vector<cr::ContactImpulse> impulses;
};

// Ground (0) and the body (1) with contacts at `points` (normal +z), solved by the simultaneous
// integration (several points) or by the single-contact integration (one point).
Outcome solve(const cr::RigidBody& body, const std::vector<Vector3d>& points, double e, double mu_s,
              double mu_d, cr::ImpactLaw law) {
  std::vector<cr::RigidBody> bodies = {ground(), body};
  std::vector<cr::ContactPoint> contacts;
  std::vector<int> island;
  for (const Vector3d& p : points) {
    island.push_back(static_cast<int>(contacts.size()));
    contacts.emplace_back(0, 1, p, Vector3d::UnitZ(), e, mu_s, mu_d);
  }
  cr::ContactProblem problem;
  problem.buildImpact(bodies, contacts, island);
  cr::SolverOptions options;
  options.law = law;
  Outcome out;
  out.report = cr::solveSimultaneousImpulseSpace(problem, options, out.impulses);
  problem.addVelocityChangesTo(bodies);
  out.body = bodies[1];
  return out;
}

void expectSameMotion(const cr::RigidBody& got, const cr::RigidBody& want, double tol) {
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(got.linear_velocity[k], want.linear_velocity[k], tol) << "v " << k;
    EXPECT_NEAR(got.angular_velocity[k], want.angular_velocity[k], tol) << "w " << k;
  }
}

struct Coefficients {
  double e, mu_s, mu_d;
};
// e in {0, 0.5, 1}, mu_s > mu_d (stick possible), mu_s = mu_d, frictionless, and a large mu that
// stops the slip during compression.
const std::vector<Coefficients> kCoefficients = {{0.0, 0.3, 0.2}, {0.5, 1.2, 0.5},
                                                 {1.0, 0.4, 0.4}, {0.5, 0.0, 0.0},
                                                 {0.8, 3.0, 2.0}, {0.3, 0.25, 0.25}};
const std::vector<cr::ImpactLaw> kLaws = {cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge};

// (2) The flat bar of the issue: contacts at the ends, at the height of the centre of mass, sliding
// at 1 m/s, approaching at 1 m/s, e 0.5, mu_s 1.2, mu_d 0.5. By hand: the centre of mass is in the
// contact plane, so K = I / m for every total impulse and nothing rotates; P_n = (1 + e) m |v_z| =
// 1.5 m; the slip would stop at mu_d P_n = m v_x, i.e. P_n = 2 m > 1.5 m, so it slides all along:
// v_x' = 1 - 0.5 * 1.5 = 0.25 m/s, v_z' = 0.5 m/s, under Poisson and Stronge (the slip direction
// never changes: Stronge = Poisson).
TEST(SimultaneousImpact, FlatBarKeepsSlidingAsRouthSays) {
  const double m = 3.0;
  for (cr::ImpactLaw law : kLaws) {
    for (const Vector3d& slide : {Vector3d(1, 0, 0), Vector3d(0, 1, 0)}) {
      const cr::RigidBody bar = box(m, Vector3d(2.0, 0.1, 0.1), Matrix3d::Identity(),
                                    Vector3d::Zero(), slide - Vector3d::UnitZ(), Vector3d::Zero());
      const Outcome two = solve(bar, {Vector3d(-1, 0, 0), Vector3d(1, 0, 0)}, 0.5, 1.2, 0.5, law);
      EXPECT_EQ(two.report.methodName(), "simultaneous_impulse_space");
      EXPECT_TRUE(two.report.converged);
      const Vector3d want = 0.25 * slide + 0.5 * Vector3d::UnitZ();
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(two.body.linear_velocity[k], want[k], kTol);
      EXPECT_NEAR(two.body.angular_velocity.norm(), 0.0, kTol);
      EXPECT_NEAR(two.impulses[0].normal_impulse, 0.75 * m, kTol);
      EXPECT_NEAR(two.impulses[1].normal_impulse, 0.75 * m, kTol);
    }
  }
}

// (1), (2): a body with its centre of mass in the contact plane, on contacts symmetric about it,
// equals one contact at the centre, for every coefficient set and both laws.
TEST(SimultaneousImpact, SymmetricContactsInTheCentrePlaneEqualOneContactAtTheCentre) {
  const double m = 2.0;
  const std::vector<std::vector<Vector3d>> layouts = {
      {Vector3d(-0.8, 0, 0), Vector3d(0.8, 0, 0)},  // bar
      {Vector3d(-0.5, -0.3, 0), Vector3d(0.5, -0.3, 0), Vector3d(0.5, 0.3, 0),
       Vector3d(-0.5, 0.3, 0)}};  // thin plate on 4 corners
  for (cr::ImpactLaw law : kLaws) {
    for (const Coefficients& c : kCoefficients) {
      for (const auto& points : layouts) {
        const cr::RigidBody body =
            box(m, Vector3d(1.0, 0.6, 0.02), Matrix3d::Identity(), Vector3d::Zero(),
                Vector3d(0.7, -0.4, -1.3), Vector3d::Zero());
        const Outcome many = solve(body, points, c.e, c.mu_s, c.mu_d, law);
        const Outcome one = solve(body, {Vector3d::Zero()}, c.e, c.mu_s, c.mu_d, law);
        SCOPED_TRACE(testing::Message()
                     << "law " << cr::toString(law) << " e " << c.e << " mu_s " << c.mu_s
                     << " mu_d " << c.mu_d << " contacts " << points.size());
        EXPECT_TRUE(many.report.converged);
        expectSameMotion(many.body, one.body, kTol);
      }
    }
  }
}

// (3) A box landing on an edge (along y) while sliding across it (x) and spinning about the edge
// direction: the motion is planar and the two edge ends see equal velocities and equal impulses,
// so the pair equals one contact at the edge midpoint.
TEST(SimultaneousImpact, BoxLandingOnAnEdgeEqualsOneContactAtTheEdgeMidpoint) {
  const double m = 1.5, tilt = 0.5;
  const Vector3d size(0.4, 0.6, 0.3);
  const Matrix3d rotation = Eigen::AngleAxisd(tilt, Vector3d::UnitY()).toRotationMatrix();
  // The lower edge of the box (x = -sx/2, z = -sz/2 in the body frame) at world z = 0.
  const Vector3d edge_body(-size.x() / 2, 0, -size.z() / 2);
  const Vector3d com = -(rotation * edge_body);
  for (cr::ImpactLaw law : kLaws) {
    for (const Coefficients& c : kCoefficients) {
      for (double wy : {0.0, 2.0, -3.0}) {
        const cr::RigidBody body =
            box(m, size, rotation, com, Vector3d(1.0, 0, -1.0), Vector3d(0, wy, 0));
        const Vector3d half(0, size.y() / 2, 0);
        const Outcome two = solve(body, {-half, half}, c.e, c.mu_s, c.mu_d, law);
        const Outcome one = solve(body, {Vector3d::Zero()}, c.e, c.mu_s, c.mu_d, law);
        SCOPED_TRACE(testing::Message() << "law " << cr::toString(law) << " e " << c.e << " mu_s "
                                        << c.mu_s << " mu_d " << c.mu_d << " wy " << wy);
        EXPECT_TRUE(two.report.converged);
        expectSameMotion(two.body, one.body, kTol);
      }
    }
  }
}

}  // namespace
