// The contact problem with bodies of fewer than 3 velocity unknowns behind a contact, so that the
// Delassus blocks W are singular: every solver against hand-derived least-norm answers
// (docs/physics.md, "The contact problem").
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>
#include <vector>

#include "collision_response/core/body_model.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/contact_problem.h"
#include "collision_response/core/exact_solver.h"
#include "collision_response/core/impulse_space_integrator.h"
#include "collision_response/core/island_solver.h"
#include "collision_response/core/iterative_solver.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/single_contact.h"

namespace cr = collision_response::core;
using Eigen::Matrix3d;
using Eigen::Vector3d;
using Eigen::VectorXd;

namespace {

constexpr double kTol = 1e-9;

/// A body on a straight rail: 1 unknown, its speed s along the unit world axis a [m/s]. Every
/// material point moves at s a, so J(p) = a (3 x 1), M = m, M^-1 J^T = a^T / m.
struct RailSlider final : cr::BodyModel {
  Vector3d axis = Vector3d::UnitX();
  double mass = 1.0;   // [kg]
  double speed = 0.0;  // [m/s]
  int velocityCount() const override { return 1; }
  VectorXd velocity() const override { return VectorXd::Constant(1, speed); }
  Vector3d materialPointVelocity(const Vector3d&) const override { return speed * axis; }
  Eigen::Matrix<double, 3, Eigen::Dynamic> pointJacobian(const Vector3d&) const override {
    return axis;
  }
  Eigen::Matrix<double, Eigen::Dynamic, 3> inverseMassJacobianTranspose(
      const Vector3d&) const override {
    return axis.transpose() / mass;
  }
  void addVelocityChange(const Eigen::Ref<const VectorXd>& change) override { speed += change(0); }
};

/// A body turning about a fixed hinge: 1 unknown, its rate w about the unit world axis k through
/// the pivot o [rad/s]. The point p moves at w k x (p - o): J(p) = k x (p - o), M = I_hinge.
struct HingedBody final : cr::BodyModel {
  Vector3d axis = Vector3d::UnitZ();
  Vector3d pivot = Vector3d::Zero();
  double moment = 1.0;  // I_hinge about the axis [kg m^2]
  double rate = 0.0;    // [rad/s]
  int velocityCount() const override { return 1; }
  VectorXd velocity() const override { return VectorXd::Constant(1, rate); }
  Vector3d materialPointVelocity(const Vector3d& p) const override {
    return rate * axis.cross(p - pivot);
  }
  Eigen::Matrix<double, 3, Eigen::Dynamic> pointJacobian(const Vector3d& p) const override {
    return axis.cross(p - pivot);
  }
  Eigen::Matrix<double, Eigen::Dynamic, 3> inverseMassJacobianTranspose(
      const Vector3d& p) const override {
    return axis.cross(p - pivot).transpose() / moment;
  }
  void addVelocityChange(const Eigen::Ref<const VectorXd>& change) override { rate += change(0); }
};

void expectVecNear(const Vector3d& got, const Vector3d& want, double tol) {
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(got[i], want[i], tol) << "component " << i;
}

const cr::RigidBody kObstacle;  // immovable, at rest: body a of every contact below

// The slider of scene (a): m = 2 kg on a rail along x, moving at -1 m/s into an immovable
// obstacle; the contact normal (from the obstacle to the slider) is at 45 degrees,
// n = (1, 1, 0) / sqrt 2. Then u = (-1, 0, 0) m/s, u_n = -1 / sqrt 2, and W = x x^T / m (rank 1:
// the slider cannot move along y or z). n^T W n = cos^2(45) / m = 1/4 1/kg: the effective mass
// along n is m / cos^2(45) = 4 kg.
struct SliderScene {
  RailSlider slider;
  std::vector<const cr::BodyModel*> bodies;
  std::vector<cr::ContactPoint> contacts;
  SliderScene(double e, double mu) {
    slider.mass = 2.0;
    slider.speed = -1.0;
    bodies = {&kObstacle, &slider};
    contacts = {
        cr::ContactPoint(0, 1, Vector3d(0.3, 0, 0), Vector3d(1, 1, 0).normalized(), e, mu, mu)};
  }
  cr::ContactProblem problem() const {
    cr::ContactProblem out;
    out.buildImpact(bodies, contacts, {0});
    return out;
  }
};

// The rod of scene (b): hinged at the origin about z, I_hinge = 3 kg m^2, turning at -2 rad/s,
// struck at p = (d, 0, 0), d = 0.5 m, by an immovable obstacle with normal n = +y. The point
// moves at w z x p = (0, w d, 0) = (0, -1, 0) m/s: u = (0, -1, 0), u_n = -1 m/s, no slip.
// J = (0, d, 0), W = d^2 / I_hinge y y^T (rank 1), n^T W n = d^2 / I_hinge = 1/12 1/kg: the
// effective mass is I_hinge / d^2 = 12 kg.
struct HingeScene {
  HingedBody rod;
  std::vector<const cr::BodyModel*> bodies;
  std::vector<cr::ContactPoint> contacts;
  HingeScene(double e, double mu) {
    rod.moment = 3.0;
    rod.rate = -2.0;
    bodies = {&kObstacle, &rod};
    contacts = {cr::ContactPoint(0, 1, Vector3d(0.5, 0, 0), Vector3d::UnitY(), e, mu, mu)};
  }
  cr::ContactProblem problem() const {
    cr::ContactProblem out;
    out.buildImpact(bodies, contacts, {0});
    return out;
  }
};

}  // namespace

TEST(ContactProblem, SingularBlocksOfTheTestBodies) {
  const cr::ContactProblem slider = SliderScene(0.5, 0.0).problem();
  ASSERT_EQ(slider.size(), 1u);
  ASSERT_EQ(slider.bodies().size(), 1u);  // the obstacle has no unknowns
  EXPECT_EQ(slider.unknowns(), 1);
  Matrix3d W = Matrix3d::Zero();
  W(0, 0) = 0.5;  // x x^T / m
  EXPECT_TRUE(slider.contact(0).delassus.isApprox(W, 1e-15));
  EXPECT_NEAR(slider.contact(0).normalDelassus(), 0.25, 1e-15);
  expectVecNear(slider.contact(0).free_velocity, Vector3d(-1, 0, 0), 1e-15);
  EXPECT_NEAR(slider.contact(0).target_normal_velocity, 0.5 / std::sqrt(2.0), 1e-15);  // -e u_n

  const cr::ContactProblem hinge = HingeScene(0.5, 0.0).problem();
  W.setZero();
  W(1, 1) = 0.25 / 3.0;  // d^2 / I_hinge y y^T
  EXPECT_TRUE(hinge.contact(0).delassus.isApprox(W, 1e-15));
  expectVecNear(hinge.contact(0).free_velocity, Vector3d(0, -1, 0), 1e-15);
}

// (a), frictionless, e = 0.5: the impulse must lie along n (the law), so it is unique:
// P_n = -(1 + e) u_n / (n^T W n) = 1.5 (1 / sqrt 2) 4 = 3 sqrt 2 N s, and the slider's speed
// changes by P_n n_x / m = 3 sqrt 2 (1 / sqrt 2) / 2 = 1.5: v' = -1 + 1.5 = 0.5 m/s = -e v (the
// obstacle acts along the rail as a wall would).
TEST(ContactProblem, SliderFrictionlessEverySolver) {
  const double P_n = 3.0 * std::sqrt(2.0);
  const auto check = [&](const cr::ContactProblem& problem, const cr::ContactImpulse& impulse,
                         const char* solver) {
    SCOPED_TRACE(solver);
    EXPECT_NEAR(impulse.normal_impulse, P_n, kTol);
    EXPECT_NEAR(impulse.friction_impulse.norm(), 0.0, kTol);
    EXPECT_NEAR(-1.0 + problem.velocityChanges()(0), 0.5, kTol);
  };
  {
    cr::ContactProblem problem = SliderScene(0.5, 0.0).problem();
    const cr::ContactImpulse impulse = cr::solveSingleContact(problem, 0, cr::ImpactLaw::kNewton);
    EXPECT_NEAR(impulse.normal_velocity_after, 0.5 / std::sqrt(2.0), kTol);  // -e u_n
    problem.applyImpulse(0, impulse.total(problem.contact(0).normal));
    check(problem, impulse, "closed form");
  }
  for (const cr::ImpactLaw law : {cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    cr::ContactProblem problem = SliderScene(0.5, 0.0).problem();
    const cr::ContactImpulse impulse = cr::integrateSingleContact(problem, 0, law, 1e-12);
    problem.applyImpulse(0, impulse.total(problem.contact(0).normal));
    check(problem, impulse, cr::toString(law));
  }
  {
    cr::ContactProblem problem = SliderScene(0.5, 0.0).problem();
    std::vector<cr::ContactImpulse> impulses;
    ASSERT_TRUE(cr::solveExact(problem, {}, impulses).converged);
    check(problem, impulses[0], "exact");
  }
  {
    cr::ContactProblem problem = SliderScene(0.5, 0.0).problem();
    std::vector<cr::ContactImpulse> impulses;
    ASSERT_TRUE(cr::solveIterative(problem, {}, impulses).converged);
    check(problem, impulses[0], "iterative");
  }
}

// (a) with friction, e = 0, mu = 2: the contact can stick (u' = 0 needs only the slider stopped,
// v' = 0), which takes P_x = m |v| = 2 N s; the impulses doing so are P = (2, y, z) for any y, z
// (W's null space is span(y, z)). The least-norm one is P = (2, 0, 0): P_n = P.n = sqrt 2,
// P_t = P - P_n n = (1, -1, 0), |P_t| = sqrt 2 = 1 x P_n, inside the cone mu_s P_n = 2 sqrt 2.
// The closed form (pseudo-inverse of the singular K), the exact solver (least-norm all-sticking
// solve) and the iterative solver (whose normal row first gives P = 2 sqrt 2 n = (2, 2, 0), the
// same velocities, then the projection onto the range of W) must all give (2, 0, 0).
TEST(ContactProblem, SliderStickingIsLeastNorm) {
  const Vector3d least_norm(2, 0, 0);
  const auto check = [&](const cr::ContactProblem& problem, const cr::ContactImpulse& impulse,
                         const char* solver) {
    SCOPED_TRACE(solver);
    expectVecNear(impulse.total(problem.contact(0).normal), least_norm, kTol);
    EXPECT_NEAR(-1.0 + problem.velocityChanges()(0), 0.0, kTol);
    EXPECT_TRUE(impulse.sticking);
  };
  {
    cr::ContactProblem problem = SliderScene(0.0, 2.0).problem();
    const cr::ContactImpulse impulse = cr::solveSingleContact(problem, 0, cr::ImpactLaw::kNewton);
    problem.applyImpulse(0, impulse.total(problem.contact(0).normal));
    check(problem, impulse, "closed form");
  }
  {
    cr::ContactProblem problem = SliderScene(0.0, 2.0).problem();
    std::vector<cr::ContactImpulse> impulses;
    const cr::SolveReport report = cr::solveExact(problem, {}, impulses);
    ASSERT_TRUE(report.converged);
    EXPECT_EQ(report.iterations, 0u);  // the all-sticking solve, no pivot
    check(problem, impulses[0], "exact");
  }
  {
    cr::ContactProblem problem = SliderScene(0.0, 2.0).problem();
    std::vector<cr::ContactImpulse> impulses;
    ASSERT_TRUE(cr::solveIterative(problem, {}, impulses).converged);
    check(problem, impulses[0], "iterative");
  }
}

// (a) with friction and e = 0.5: sticking would need u' = -e u_n n = (0.25, 0.25, 0), which has a
// y component the rail cannot give: the least-norm sticking impulse K^+ (-u - e u_n n) misses
// the target, so the closed form slides. Its sticking impulse is P_x = m (0.25 + 1) = 2.5 along x,
// P_t = 2.5 ((1, 0, 0) - (1, 1, 0) / 2) = (1.25, -1.25, 0), so d = (1, -1, 0) / sqrt 2, and
// P = P_n (n + mu d) with n^T W (n + mu d) = (1/sqrt 2)(1/sqrt 2 + mu / sqrt 2) / m = (1 + mu) / 4
// and P_n = -(1 + e) u_n 4 / (1 + mu) = 1.5 sqrt 2 4 / 3 = 2 sqrt 2 (mu = 0.5). The slider then
// leaves at v' = -1 + P_n (1 + mu) / (sqrt 2 m) = -1 + 2 sqrt 2 1.5 / (2 sqrt 2) = 0.5 m/s: the
// normal law u'_n = -e u_n holds. (The impulse is the law's, hence unique.)
TEST(ContactProblem, SliderUnreachableStickSlides) {
  cr::ContactProblem problem = SliderScene(0.5, 0.5).problem();
  const cr::ContactImpulse impulse = cr::solveSingleContact(problem, 0, cr::ImpactLaw::kNewton);
  EXPECT_FALSE(impulse.sticking);
  EXPECT_NEAR(impulse.normal_impulse, 2.0 * std::sqrt(2.0), kTol);
  expectVecNear(impulse.friction_impulse, Vector3d(1, -1, 0).normalized() * std::sqrt(2.0), kTol);
  problem.applyImpulse(0, impulse.total(problem.contact(0).normal));
  EXPECT_NEAR(-1.0 + problem.velocityChanges()(0), 0.5, kTol);
  EXPECT_NEAR(problem.contact(0).normal.dot(problem.relativeMotion(0)), 0.5 / std::sqrt(2.0), kTol);
}

// (b) The hinged rod, e = 0.5, mu = 0.5: a central strike (u_t = 0, W_tn = 0, W_tt = 0), so
// every law gives P = -(1 + e) u_n I_hinge / d^2 n = 1.5 x 12 = 18 N s along n, no friction
// (any friction impulse along x or z is in W's null space: the least-norm one is 0), and
// w' = w + d P_n / I_hinge = -2 + 0.5 x 18 / 3 = 1 rad/s = -e w.
TEST(ContactProblem, HingedRodEveryLawEverySolver) {
  const auto check = [&](const cr::ContactProblem& problem, const cr::ContactImpulse& impulse,
                         const std::string& solver) {
    SCOPED_TRACE(solver);
    expectVecNear(impulse.total(problem.contact(0).normal), Vector3d(0, 18, 0), kTol);
    EXPECT_NEAR(-2.0 + problem.velocityChanges()(0), 1.0, kTol);
  };
  for (const cr::ImpactLaw law : {cr::ImpactLaw::kNewton, cr::ImpactLaw::kPoisson,
                                  cr::ImpactLaw::kStronge, cr::ImpactLaw::kSeedOnePass}) {
    cr::ContactProblem problem = HingeScene(0.5, 0.5).problem();
    const cr::ContactImpulse impulse = cr::integrateSingleContact(problem, 0, law, 1e-12);
    problem.applyImpulse(0, impulse.total(problem.contact(0).normal));
    check(problem, impulse, std::string("single contact, ") + cr::toString(law));
  }
  for (const cr::SolverMethod method : {cr::SolverMethod::kExact, cr::SolverMethod::kIterative}) {
    for (const cr::ImpactLaw law : {cr::ImpactLaw::kNewton, cr::ImpactLaw::kStronge}) {
      cr::ContactProblem problem = HingeScene(0.5, 0.5).problem();
      cr::SolverOptions options;
      options.method = method;
      options.law = law;
      std::vector<cr::ContactImpulse> impulses;
      const cr::SolveReport report = cr::solveIsland(problem, options, impulses);
      EXPECT_TRUE(report.converged);
      check(problem, impulses[0],
            std::string(cr::toString(method)) + ", " + cr::toString(law) + " (" +
                report.methodName() + ")");
    }
  }
}

// A contact whose normal the bodies cannot move along (n^T W n = 0: the rail along x, the normal
// along y): no impulse can change u_n, and every solver gives the least-norm answer, zero, with
// no division by zero.
TEST(ContactProblem, UnpushableContactGetsNoImpulse) {
  RailSlider slider;
  slider.mass = 2.0;
  slider.speed = -1.0;
  const cr::RigidBody mover = [] {
    cr::RigidBody body;  // immovable (prescribed motion): +1 m/s along y
    body.linear_velocity = Vector3d(0, 1, 0);
    return body;
  }();
  const std::vector<const cr::BodyModel*> bodies = {&mover, &slider};
  // n = +y from the mover to the slider; u = v_slider - v_mover = (-1, -1, 0): u_n = -1.
  const std::vector<cr::ContactPoint> contacts = {
      cr::ContactPoint(0, 1, Vector3d::Zero(), Vector3d::UnitY(), 0.5, 0.3, 0.3)};
  for (const cr::ImpactLaw law :
       {cr::ImpactLaw::kNewton, cr::ImpactLaw::kStronge, cr::ImpactLaw::kSeedOnePass}) {
    cr::ContactProblem problem;
    problem.buildImpact(bodies, contacts, {0});
    EXPECT_EQ(problem.contact(0).normalDelassus(), 0.0);
    const cr::ContactImpulse impulse = cr::integrateSingleContact(problem, 0, law, 1e-10);
    EXPECT_EQ(impulse.normal_impulse, 0.0) << cr::toString(law);
    EXPECT_TRUE(impulse.friction_impulse.allFinite());
    EXPECT_EQ(impulse.normal_velocity_after, -1.0);
  }
  cr::ContactProblem problem;
  problem.buildImpact(bodies, contacts, {0});
  std::vector<cr::ContactImpulse> impulses;
  cr::solveIterative(problem, {}, impulses);
  EXPECT_EQ(impulses[0].normal_impulse, 0.0);
  EXPECT_TRUE(problem.velocityChanges().allFinite());
}
