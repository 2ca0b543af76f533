// Unit tests of the iterative (projected Gauss-Seidel) solver, iterative_solver.h: one contact
// against hand-derived closed forms (stick, slide, the static/dynamic split, random frictionless
// contacts), its low-level entry point, and friction that opposes the slip on a cube sliding flat
// on four corners (docs/physics.md, "The iterative solver").
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "collision_response/core/body_state.h"
#include "collision_response/core/compute_response.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/iterative_solver.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/scene.h"
#include "collision_response/core/solver_options.h"

#include "newton_scenes.h"
#include "scene_builders.h"

namespace cr = collision_response::core;
using namespace collision_response::testing;  // NOLINT: shared builders

namespace {

constexpr double kTol = 1e-9;

cr::CollisionResult solve(const cr::Scene& s, cr::SolverMethod method = cr::SolverMethod::kAuto) {
  const cr::SolverOptions o = newton(method);
  return cr::computeResponse(s, o);
}

// ---------------------------------------------------------------------------------------------
// Iterative solver on one contact. Solid sphere (I = 2/5 m R^2) on the ground, normal +y,
// r = (0, -R, 0): slip u_t = v_x + w_z R, du_t = 7 P_t / (2 m), P_n = m (1 + e) |v_y|.
// Stick: v_x' = (5 v_x - 2 w_z R) / 7, w_z' = -v_x' / R (rolling).
// Slide: v_x' = v_x - mu_d (1 + e) |v_y| sign(u_t), w_z' = w_z - 5 mu_d (1 + e) |v_y| sign(u_t) /
// (2R).
TEST(IterativeSolver, SingleStickingContactMatchesClosedForm) {
  const double m = 0.45, R = 0.11, vx = 3.0, vy = -2.0, wz = 4.0, e = 0.5;
  cr::Scene s;
  s.bodies = {fixed("ground"),
              sphere("ball", m, R, Vector3d(0, R, 0), Vector3d(vx, vy, 0), Vector3d(0, 0, wz))};
  s.contacts = {contact("ground", "ball", Vector3d::Zero(), Vector3d::UnitY(), e, 2.0, 1.5)};
  const auto r = solve(s, cr::SolverMethod::kIterative);
  ASSERT_EQ(r.islands.size(), 1u);
  EXPECT_EQ(r.islands[0].methodName(), "iterative");
  EXPECT_TRUE(r.islands[0].converged);
  const double vxp = (5 * vx - 2 * wz * R) / 7.0;
  expectVecNear(r.bodies[1].linear_velocity, Vector3d(vxp, -e * vy, 0), kTol);
  expectVecNear(r.bodies[1].angular_velocity, Vector3d(0, 0, -vxp / R), kTol);
  EXPECT_TRUE(r.impulses[0].sticking);
  EXPECT_NEAR(r.impulses[0].normal_impulse, m * (1 + e) * -vy, kTol);
  expectVecNear(r.impulses[0].friction_impulse, Vector3d(-2 * m * (vx + wz * R) / 7.0, 0, 0), kTol);
}

TEST(IterativeSolver, SinglePlanarSlidingContactMatchesClosedForm) {
  const double m = 0.45, R = 0.11, vx = 3.0, vy = -2.0, wz = 4.0, e = 0.5, mu_s = 0.2, mu_d = 0.1;
  cr::Scene s;
  s.bodies = {fixed("ground"),
              sphere("ball", m, R, Vector3d(0, R, 0), Vector3d(vx, vy, 0), Vector3d(0, 0, wz))};
  s.contacts = {contact("ground", "ball", Vector3d::Zero(), Vector3d::UnitY(), e, mu_s, mu_d)};
  const auto r = solve(s, cr::SolverMethod::kIterative);
  EXPECT_TRUE(r.islands[0].converged);
  const double P_n = m * (1 + e) * -vy;
  expectVecNear(r.bodies[1].linear_velocity, Vector3d(vx - mu_d * P_n / m, -e * vy, 0), kTol);
  expectVecNear(r.bodies[1].angular_velocity, Vector3d(0, 0, wz - 5 * mu_d * P_n / (2 * m * R)),
                kTol);
  EXPECT_FALSE(r.impulses[0].sticking);
  EXPECT_NEAR(r.impulses[0].normal_impulse, P_n, kTol);
  expectVecNear(r.impulses[0].friction_impulse, Vector3d(-mu_d * P_n, 0, 0), kTol);
}

TEST(IterativeSolver, StaticDynamicSplitSticksInsideStaticConeAndSlidesJustOutside) {
  // Same ball; the sticking impulse ratio is rho = |P_t| / P_n = 2 |u_t| / (7 (1 + e) |v_y|).
  // mu_d < rho < mu_s must stick (rolling result); rho just above mu_s must slide with mu_d.
  const double m = 0.45, R = 0.11, vx = 3.0, vy = -2.0, wz = 4.0, e = 0.5;
  const double u_t = vx + wz * R, rho = 2 * u_t / (7 * (1 + e) * -vy), P_n = m * (1 + e) * -vy;
  const auto scene = [&](double mu_s, double mu_d) {
    cr::Scene s;
    s.bodies = {fixed("ground"),
                sphere("ball", m, R, Vector3d(0, R, 0), Vector3d(vx, vy, 0), Vector3d(0, 0, wz))};
    s.contacts = {contact("ground", "ball", Vector3d::Zero(), Vector3d::UnitY(), e, mu_s, mu_d)};
    return s;
  };
  const auto stick = solve(scene(1.2 * rho, 0.5 * rho), cr::SolverMethod::kIterative);
  EXPECT_TRUE(stick.islands[0].converged);
  EXPECT_TRUE(stick.impulses[0].sticking);
  const double vxp = (5 * vx - 2 * wz * R) / 7.0;
  expectVecNear(stick.bodies[1].linear_velocity, Vector3d(vxp, -e * vy, 0), kTol);
  expectVecNear(stick.bodies[1].angular_velocity, Vector3d(0, 0, -vxp / R), kTol);
  const double mu_d = 0.5 * rho;
  const auto slide = solve(scene(rho * (1 - 1e-6), mu_d), cr::SolverMethod::kIterative);
  EXPECT_TRUE(slide.islands[0].converged);
  EXPECT_FALSE(slide.impulses[0].sticking);
  expectVecNear(slide.bodies[1].linear_velocity, Vector3d(vx - mu_d * P_n / m, -e * vy, 0), kTol);
  expectVecNear(slide.impulses[0].friction_impulse, Vector3d(-mu_d * P_n, 0, 0), kTol);
}

TEST(IterativeSolver, AgreesWithClosedFormOnRandomFrictionlessContacts) {
  // Frictionless, one contact: the Newton impulse is unique, whichever solver finds it.
  Random rnd(8);
  for (int k = 0; k < 100; ++k) {
    cr::Scene s;
    s.bodies = {rnd.body("a"), rnd.body("b")};
    s.contacts = {contact("a", "b", rnd.vec(-1, 1), rnd.unit(), rnd.uniform(0, 1))};
    if (relVel(s.bodies, s.contacts[0]).dot(s.contacts[0].normal) >= 0) {
      s.contacts[0].normal = -s.contacts[0].normal;
    }
    const auto closed = solve(s, cr::SolverMethod::kAuto);
    const auto iter = solve(s, cr::SolverMethod::kIterative);
    EXPECT_EQ(closed.islands[0].methodName(), "closed_form");
    EXPECT_EQ(iter.islands[0].methodName(), "iterative");
    for (int i = 0; i < 2; ++i) {
      expectVecNear(iter.bodies[i].linear_velocity, closed.bodies[i].linear_velocity, kTol);
      expectVecNear(iter.bodies[i].angular_velocity, closed.bodies[i].angular_velocity, kTol);
    }
  }
}

// The low-level entry point: solveIterative applies the impulses to the bodies it is given.
TEST(IterativeSolver, LowLevelApiAppliesImpulsesAndReportsConvergence) {
  // Two equal spheres, head-on, e = 0.5: v1' = (V - e V)/2, v2' = (V + e V)/2 (from momentum and
  // v2' - v1' = e V).
  const double V = 2.0, e = 0.5;
  std::vector<cr::RigidBody> bodies = {
      cr::makeRigidBody(sphere("a", 1.0, 0.5, Vector3d::Zero(), Vector3d(V, 0, 0))),
      cr::makeRigidBody(sphere("b", 1.0, 0.5, Vector3d(1, 0, 0), Vector3d::Zero()))};
  const std::vector<cr::ContactPoint> rows = {
      cr::ContactPoint(0, 1, Vector3d(0.5, 0, 0), Vector3d::UnitX(), e, 0, 0)};
  std::vector<cr::ContactImpulse> impulses(1);
  const cr::SolveReport stats = cr::solveIterative(bodies, rows, {0}, newton(), impulses);
  EXPECT_TRUE(stats.converged);
  EXPECT_GE(stats.iterations, 1u);
  EXPECT_LE(stats.residual, 1e-12);
  expectVecNear(bodies[0].linear_velocity, Vector3d((1 - e) * V / 2, 0, 0), kTol);
  expectVecNear(bodies[1].linear_velocity, Vector3d((1 + e) * V / 2, 0, 0), kTol);
  EXPECT_NEAR(impulses[0].normal_impulse, (1 + e) * V / 2, kTol);
}

}  // namespace

// --- Friction that opposes the slip (issue 12, item 1; docs/physics.md, "The iterative solver").
namespace {

// A cube (mass m = 1 kg, side 1 m, I = m s^2 / 6 = 1/6 kg m^2 about every axis) resting flat on
// the ground on its four bottom corners (+-0.5, +-0.5, 0), centre at z = 0.5, moving at
// v = (v_x, v_y, -1) m/s, no spin. The corners are listed in a scrambled order so that a
// Gauss-Seidel sweep does not follow the symmetry of the scene.
cr::Scene flatCube(const Vector3d& v, double e, double mu) {
  cr::BodyState box;
  box.id = "box";
  box.mass = 1.0;
  box.inertia = Matrix3d::Identity() / 6.0;
  box.position = {0.0, 0.0, 0.5};
  box.linear_velocity = v;
  cr::Scene scene;
  scene.bodies = {ground(), box};
  for (const auto& [x, y] :
       std::vector<std::pair<double, double>>{{0.5, -0.5}, {-0.5, -0.5}, {0.5, 0.5}, {-0.5, 0.5}}) {
    scene.contacts.push_back(
        contact("ground", "box", Vector3d(x, y, 0.0), Vector3d::UnitZ(), e, mu, mu));
  }
  return scene;
}

}  // namespace

// Closed form (by hand). The cube lands at u_n = -1 m/s while sliding at 1 m/s along x, e = 0,
// mu = 0.3. Guess: no spin after the impact, every corner keeps sliding along +x. Then every
// corner ends at u' = v' (no spin), u'_n = 0 needs v'_z = 0: the total normal impulse is
// m * 1 = 1 N s; each corner's friction opposes its slip (+x), -mu P_i x, total -0.3 N s x, so
// v'_x = 1 - 0.3 = 0.7 m/s > 0: the corners do keep sliding. Consistency of "no spin": about y
// the friction at the bottom (r_z = -0.5 m) gives sum (r x f)_y = r_z f_x = 0.15 N m s, the
// normal impulses sum (r x P_n z)_y = -sum x_i P_i; zero needs sum x_i P_i = 0.15, i.e. the
// front corners (x = +0.5) carry 0.65 N s and the back ones 0.35 N s, both >= 0. About x: by
// the y symmetry the left and right corners carry the same, and the friction (along x) has no
// x moment; about z: the friction is all along x at y = +-0.5 with equal loads, no yaw. So
// v' = (0.7, 0, 0), w' = 0 is a solution, and the one of maximal dissipation. Before the fix
// (the radial projection of -K_tt^-1 u_t) the iterative solver gave v'_x = 0.7191.
TEST(FrictionOpposesSlip, CubeSlidingFlatOnFourCornersMatchesClosedForm) {
  cr::SolverOptions options;
  options.law = cr::ImpactLaw::kNewton;
  options.method = cr::SolverMethod::kIterative;
  options.tolerance = 1e-14;
  const cr::CollisionResult result =
      cr::computeResponse(flatCube(Vector3d(1.0, 0.0, -1.0), 0.0, 0.3), options);
  ASSERT_TRUE(result.islands[0].converged);
  const cr::BodyState& box = result.bodies[1];
  expectVecNear(box.linear_velocity, Vector3d(0.7, 0.0, 0.0), 1e-9);
  expectVecNear(box.angular_velocity, Vector3d::Zero(), 1e-9);
  double normal = 0.0;
  for (const auto& impulse : result.impulses) {
    normal += impulse.normal_impulse;
    EXPECT_FALSE(impulse.sticking);
    // Friction exactly against the slip (+x).
    EXPECT_NEAR(impulse.friction_impulse.y(), 0.0, 1e-9);
    EXPECT_NEAR(impulse.friction_impulse.x(), -0.3 * impulse.normal_impulse, 1e-9);
  }
  EXPECT_NEAR(normal, 1.0, 1e-9);
}

// The same along the diagonal: slide at 1 m/s along (1, 1)/sqrt 2. The same argument with x
// replaced by the diagonal (the corners' loads now balance the moment about the other diagonal)
// gives v' = 0.7 (1, 1, 0)/sqrt 2, w' = 0.
TEST(FrictionOpposesSlip, CubeSlidingFlatAlongTheDiagonalMatchesClosedForm) {
  cr::SolverOptions options;
  options.law = cr::ImpactLaw::kNewton;
  options.method = cr::SolverMethod::kIterative;
  options.tolerance = 1e-14;
  const double d = 1.0 / std::sqrt(2.0);
  const cr::CollisionResult result =
      cr::computeResponse(flatCube(Vector3d(d, d, -1.0), 0.0, 0.3), options);
  ASSERT_TRUE(result.islands[0].converged);
  const cr::BodyState& box = result.bodies[1];
  expectVecNear(box.linear_velocity, Vector3d(0.7 * d, 0.7 * d, 0.0), 1e-9);
  expectVecNear(box.angular_velocity, Vector3d::Zero(), 1e-9);
}

// Mirror symmetry: the scene (cube landing flat, sliding along x) is symmetric under y -> -y, so
// the answer is: no sideways velocity v'_y, no roll w'_x (and no yaw w'_z), for every law and
// solver. Scenes: the README's (0.3 m/s, e = 0.5) at mu 0.1 and 0.6, and e = 0, mu = 0.3 at 1 m/s.
TEST(FrictionOpposesSlip, MirrorSymmetricSlideLeavesNoSidewaysMotion) {
  struct Case {
    double slide, e, mu;
  };
  for (const Case& k : {Case{0.3, 0.5, 0.1}, Case{0.3, 0.5, 0.6}, Case{1.0, 0.0, 0.3}}) {
    for (const cr::ImpactLaw law :
         {cr::ImpactLaw::kNewton, cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
      for (const cr::SolverMethod method :
           {cr::SolverMethod::kExact, cr::SolverMethod::kIterative, cr::SolverMethod::kAuto}) {
        SCOPED_TRACE(::testing::Message()
                     << "slide " << k.slide << " e " << k.e << " mu " << k.mu << " law "
                     << cr::toString(law) << " solver " << static_cast<int>(method));
        cr::SolverOptions options;
        options.law = law;
        options.method = method;
        options.tolerance = 1e-14;
        const cr::CollisionResult result =
            cr::computeResponse(flatCube(Vector3d(k.slide, 0.0, -1.0), k.e, k.mu), options);
        const cr::BodyState& box = result.bodies[1];
        EXPECT_NEAR(box.linear_velocity.y(), 0.0, 1e-9);
        EXPECT_NEAR(box.angular_velocity.x(), 0.0, 1e-9);
        EXPECT_NEAR(box.angular_velocity.z(), 0.0, 1e-9);
      }
    }
  }
}
