// Unit tests of scenes with several contacts: island splitting, multi-contact islands (a V-groove,
// cube landings) against hand-derived closed forms, and invariants on random chains. The iterative
// solver's own tests are in test_iterative_solver.cpp.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "collision_response/core/body_state.h"
#include "collision_response/core/compute_response.h"
#include "collision_response/core/constants.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/islands.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/scene.h"
#include "collision_response/core/solver_options.h"
#include "sliding_cube_landing.h"

#include "newton_scenes.h"
#include "scene_builders.h"

#include "rigid_contact.h"

namespace cr = collision_response::core;
using collision_response::testing::spaceOf;
using collision_response::testing::velocityAt;
using namespace collision_response::testing;  // NOLINT: shared builders

namespace {

constexpr double kTol = 1e-9;
using collision_response::core::kPi;

// Both ways of solving a multi-contact island: whatever kAuto picks, and the iterative solver.
const cr::SolverMethod kMethods[] = {cr::SolverMethod::kAuto, cr::SolverMethod::kIterative};

cr::CollisionResult solve(const cr::Scene& s, cr::SolverMethod method = cr::SolverMethod::kAuto) {
  const cr::SolverOptions o = newton(method);
  return cr::computeResponse(s, o);
}

// ---------------------------------------------------------------------------------------------
// Islands.
TEST(Islands, TwoBallsOnTheSameFloorAreTwoIslands) {
  // An immovable floor transmits nothing, so the two contacts are independent.
  std::vector<cr::RigidBody> bodies(3);
  bodies[1].inverse_mass = 1.0;
  bodies[2].inverse_mass = 0.5;
  const auto islands = cr::findIslands(bodies, {{0, 1}, {0, 2}});
  ASSERT_EQ(islands.size(), 2u);
  EXPECT_EQ(islands[0].contacts, std::vector<int>({0}));
  EXPECT_EQ(islands[1].contacts, std::vector<int>({1}));
}

TEST(Islands, BallsTouchingEachOtherFormOneIsland) {
  std::vector<cr::RigidBody> bodies(3);
  bodies[1].inverse_mass = 1.0;
  bodies[2].inverse_mass = 0.5;
  const auto islands = cr::findIslands(bodies, {{0, 1}, {0, 2}, {1, 2}});
  ASSERT_EQ(islands.size(), 1u);
  EXPECT_EQ(islands[0].contacts, std::vector<int>({0, 1, 2}));
}

TEST(Islands, ChainsJoinTransitivelyAndSeparateGroupsStaySeparate) {
  // Bodies: 0 floor (immovable), 1..5 movable. Contacts: 1-2, 0-4, 2-3, 4-5, 0-1, 0-3, 0-5.
  // Groups {1,2,3} and {4,5}; islands in order of their first contact.
  std::vector<cr::RigidBody> bodies(6);
  for (int i = 1; i < 6; ++i) bodies[i].inverse_mass = 1.0;
  const auto islands =
      cr::findIslands(bodies, {{1, 2}, {0, 4}, {2, 3}, {4, 5}, {0, 1}, {3, 0}, {0, 5}});
  ASSERT_EQ(islands.size(), 2u);
  EXPECT_EQ(islands[0].contacts, std::vector<int>({0, 2, 4, 5}));
  EXPECT_EQ(islands[1].contacts, std::vector<int>({1, 3, 6}));
}

TEST(Islands, ComputeResponseReportsIslandsAndSkipsOnesWithNothingApproaching) {
  // Ball 1 falls on the floor; ball 2 rises off the floor (u_n > 0): its island costs nothing.
  cr::Scene s;
  s.bodies = {fixed("floor"), sphere("b1", 1.0, 0.5, Vector3d(0, 0.5, 0), Vector3d(0, -1, 0)),
              sphere("b2", 2.0, 0.5, Vector3d(3, 0.5, 0), Vector3d(1, 1, 0), Vector3d(0, 0, 2))};
  s.contacts = {contact("floor", "b1", Vector3d::Zero(), Vector3d::UnitY(), 1.0),
                contact("floor", "b2", Vector3d(3, 0, 0), Vector3d::UnitY(), 1.0, 0.5, 0.5)};
  const auto r = solve(s);
  ASSERT_EQ(r.islands.size(), 2u);
  EXPECT_EQ(r.islands[0].contacts, std::vector<int>({0}));
  EXPECT_EQ(r.islands[0].methodName(), "closed_form");
  EXPECT_EQ(r.islands[1].contacts, std::vector<int>({1}));
  EXPECT_EQ(r.islands[1].methodName(), "none");
  EXPECT_EQ(r.impulses[1].normal_impulse, 0.0);
  EXPECT_EQ(r.impulses[1].friction_impulse, Vector3d::Zero());
  EXPECT_EQ(r.bodies[2].linear_velocity, s.bodies[2].linear_velocity);
  EXPECT_EQ(r.bodies[2].angular_velocity, s.bodies[2].angular_velocity);
  // Elastic bounce of ball 1: v' = -v.
  expectVecNear(r.bodies[1].linear_velocity, Vector3d(0, 1, 0), kTol);
}

TEST(Islands, MultiContactIslandWithNothingApproachingHasZeroImpulses) {
  // A ball resting (u_n = 0) on the floor and touching a second ball that moves away from it.
  cr::Scene s;
  s.bodies = {fixed("floor"), sphere("b1", 1.0, 0.5, Vector3d(0, 0.5, 0), Vector3d::Zero()),
              sphere("b2", 1.0, 0.5, Vector3d(1, 0.5, 0), Vector3d(0.5, 0, 0))};
  s.contacts = {contact("floor", "b1", Vector3d::Zero(), Vector3d::UnitY(), 0.5, 0.3, 0.3),
                contact("b1", "b2", Vector3d(0.5, 0.5, 0), Vector3d::UnitX(), 0.5, 0.3, 0.3)};
  const auto r = solve(s);
  ASSERT_EQ(r.islands.size(), 1u);
  // No impulse; the floor contact (u_n = 0) is analysed as resting, and with no wrench on the
  // bodies it carries no force. The separating contact is not resting.
  EXPECT_EQ(r.islands[0].methodName(), "resting_closed_form");
  EXPECT_TRUE(r.impulses[0].resting);
  EXPECT_FALSE(r.impulses[1].resting);
  for (const auto& imp : r.impulses) {
    EXPECT_EQ(imp.normal_impulse, 0.0);
    EXPECT_EQ(imp.friction_impulse, Vector3d::Zero());
    EXPECT_EQ(imp.normal_force, 0.0);
    EXPECT_EQ(imp.friction_force, Vector3d::Zero());
  }
  for (std::size_t i = 0; i < s.bodies.size(); ++i) {
    EXPECT_EQ(r.bodies[i].linear_velocity, s.bodies[i].linear_velocity);
    EXPECT_EQ(r.bodies[i].angular_velocity, s.bodies[i].angular_velocity);
  }
}

// ---------------------------------------------------------------------------------------------
// Ball falling vertically into a symmetric frictionless V-groove.
// The walls are inclined at beta to the horizontal; their normals (wall -> ball) are n1 = (sin b,
// cos b, 0) and n2 = (-sin b, cos b, 0). Contacts are central (p = c - R n_i), so no spin. By
// symmetry j1 = j2 = j and v' = v + (j/m)(n1 + n2) = (0, -V + 2 j cos b / m, v_z). Newton at each
// contact with both impulses active: v'.n_i = -e v.n_i, i.e. v'_y cos b = e V cos b, so v'_y = e V
// and j = m (1 + e) V / (2 cos b) > 0 (consistent). The groove-parallel velocity v_z is untouched.
TEST(VGroove, SymmetricFrictionlessBallBouncesStraightUp) {
  const double m = 0.8, R = 0.2, V = 2.0, vz = 0.3, e = 0.5, beta = 40.0 * kPi / 180.0;
  const Vector3d n1(std::sin(beta), std::cos(beta), 0), n2(-std::sin(beta), std::cos(beta), 0);
  const Vector3d c(0, 1.0, 0);
  cr::Scene s;
  s.bodies = {fixed("left"), fixed("right"), sphere("ball", m, R, c, Vector3d(0, -V, vz))};
  s.contacts = {contact("left", "ball", c - R * n1, n1, e),
                contact("right", "ball", c - R * n2, n2, e)};
  for (const cr::SolverMethod method : kMethods) {
    SCOPED_TRACE(cr::toString(method));
    const auto r = solve(s, method);
    ASSERT_EQ(r.islands.size(), 1u);
    if (method == cr::SolverMethod::kIterative) {
      EXPECT_EQ(r.islands[0].methodName(), "iterative");
    }
    EXPECT_TRUE(r.islands[0].converged);
    expectVecNear(r.bodies[2].linear_velocity, Vector3d(0, e * V, vz), kTol);
    expectVecNear(r.bodies[2].angular_velocity, Vector3d::Zero(), kTol);
    const double j = m * (1 + e) * V / (2 * std::cos(beta));
    EXPECT_NEAR(r.impulses[0].normal_impulse, j, kTol);
    EXPECT_NEAR(r.impulses[1].normal_impulse, j, kTol);
    for (const auto& imp : r.impulses) {
      EXPECT_NEAR(imp.normal_velocity_before, -V * std::cos(beta), kTol);
      EXPECT_NEAR(imp.normal_velocity_after, e * V * std::cos(beta), kTol);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Cube (side s, mass m, I = m s^2 / 6) landing flat with 4 corner contacts, frictionless, e = 0.5.
// v' = (0, 0.5, 0), w' = 0 satisfies u'_n = -e u_n = 0.5 at every corner with the total normal
// impulse m (1 + e) * 1 along +y and zero total moment (symmetric split); since the Delassus
// matrix is positive semi-definite the post-impact velocities of every LCP solution coincide, so
// this is the answer even though the individual corner impulses are not unique.
TEST(CubeLanding, FlatFourCornerImpactBouncesWithoutSpin) {
  const double m = 2.0, side = 1.0, e = 0.5;
  cr::BodyState cube;
  cube.id = "cube";
  cube.mass = m;
  cube.inertia = Matrix3d::Identity() * (m * side * side / 6.0);
  cube.position = Vector3d(0, 0.5 * side, 0);
  cube.linear_velocity = Vector3d(0, -1, 0);
  cr::Scene s;
  s.bodies = {fixed("ground"), cube};
  for (const double x : {-0.5, 0.5}) {
    for (const double z : {-0.5, 0.5}) {
      s.contacts.push_back(contact("ground", "cube", Vector3d(x, 0, z), Vector3d::UnitY(), e));
    }
  }
  for (const cr::SolverMethod method : kMethods) {
    SCOPED_TRACE(cr::toString(method));
    const auto r = solve(s, method);
    ASSERT_EQ(r.islands.size(), 1u);
    if (method == cr::SolverMethod::kIterative) {
      EXPECT_EQ(r.islands[0].methodName(), "iterative");
    }
    EXPECT_TRUE(r.islands[0].converged);
    expectVecNear(r.bodies[1].linear_velocity, Vector3d(0, 0.5, 0), 1e-8);
    expectVecNear(r.bodies[1].angular_velocity, Vector3d::Zero(), 1e-8);
    double total = 0.0;
    for (const auto& imp : r.impulses) {
      EXPECT_GE(imp.normal_impulse, 0.0);
      total += imp.normal_impulse;
    }
    EXPECT_NEAR(total, m * (1 + e) * 1.0, 1e-8);
    EXPECT_NEAR(r.kinetic_energy_before, 1.0, 1e-12);
    EXPECT_NEAR(r.kinetic_energy_after, 0.25, 1e-8);
  }
}

TEST(CubeLanding, RotatedCubeWithFrictionStillBouncesStraight) {
  // Same landing, cube turned 30 degrees about y (corners move, geometry symmetric), and rough:
  // no slip before impact and a symmetric answer, so friction stays zero and v' = (0, e, 0).
  const double m = 2.0, e = 0.5, a = 30.0 * kPi / 180.0;
  cr::BodyState cube;
  cube.id = "cube";
  cube.mass = m;
  cube.inertia = Matrix3d::Identity() * (m / 6.0);
  cube.position = Vector3d(1, 0.5, -2);
  cube.orientation = Quaterniond(Eigen::AngleAxisd(a, Vector3d::UnitY()));
  cube.linear_velocity = Vector3d(0, -1, 0);
  cr::Scene s;
  s.bodies = {cube, fixed("ground")};
  for (const double x : {-0.5, 0.5}) {
    for (const double z : {-0.5, 0.5}) {
      const Vector3d corner = cube.position + cube.orientation * Vector3d(x, -0.5, z);
      s.contacts.push_back(contact("cube", "ground", corner, -Vector3d::UnitY(), e, 0.5, 0.4));
    }
  }
  for (const cr::SolverMethod method : kMethods) {
    SCOPED_TRACE(cr::toString(method));
    const auto r = solve(s, method);
    EXPECT_TRUE(r.islands[0].converged);
    expectVecNear(r.bodies[0].linear_velocity, Vector3d(0, 0.5, 0), 1e-8);
    expectVecNear(r.bodies[0].angular_velocity, Vector3d::Zero(), 1e-8);
  }
}

// A cube sliding sideways lands flat on rough ground (common e, mu_s large enough to stick).
// Compression ends stuck with v = w = 0: friction -m v_x, and the corners under the leading edge
// carry P_lead - P_trail = m v_x more (torque about the horizontal axis balanced). Restitution
// adds R = e P_c, whose torque is -e m v_x s / 2 (side s); friction through restitution keeps the
// corners from slipping (v'_x = w'_y s / 2): T = -(6 / 10) e m v_x (I = m s^2 / 6). So v' = (T / m,
// 0, e), w' = (0, 2 T / (m s), 0) under Poisson, and under Stronge's two-phase scheme too (its
// release, 0.1318 J of the 0.1363 J allowed, needs no scaling). Without friction in the
// restitution phase the cube would leave spinning backwards with its corners sliding forward.
// Stronge integrated simultaneously (kAuto) ends each corner pair on its own work: the leading
// pair first, then the trailing one alone (sliding_cube_landing.h); the corners stay stuck.
TEST(CubeLanding, SlidingCubeLandingFlatKeepsItsCornersStuck) {
  const double m = 1.0, side = 1.0, e = 0.5, vx = 0.3;
  cr::BodyState cube;
  cube.id = "cube";
  cube.mass = m;
  cube.inertia = Matrix3d::Identity() * (m * side * side / 6.0);
  cube.position = Vector3d(0, 0, 0.5 * side);
  cube.linear_velocity = Vector3d(vx, 0, -1);
  cr::Scene s;
  s.bodies = {fixed("ground"), cube};
  for (const double x : {-0.5, 0.5}) {
    for (const double y : {-0.5, 0.5}) {
      s.contacts.push_back(
          contact("ground", "cube", Vector3d(x, y, 0), Vector3d::UnitZ(), e, 0.6, 0.5));
    }
  }
  const double T = -0.6 * e * m * vx;
  for (const cr::ImpactLaw law : {cr::ImpactLaw::kPoisson, cr::ImpactLaw::kStronge}) {
    for (const cr::SolverMethod method : kMethods) {
      SCOPED_TRACE(std::string(cr::toString(law)) + " " + cr::toString(method));
      cr::SolverOptions options;
      options.law = law;
      options.method = method;
      const auto r = cr::computeResponse(s, options);
      EXPECT_TRUE(r.islands[0].converged);
      if (law == cr::ImpactLaw::kStronge && method == cr::SolverMethod::kAuto) {
        const collision_response::testing::CubeMotion want =
            collision_response::testing::slidingCubeLandingUnderStronge();
        expectVecNear(r.bodies[1].linear_velocity, want.linear, 1e-8);
        expectVecNear(r.bodies[1].angular_velocity, want.angular, 1e-8);
      } else {
        expectVecNear(r.bodies[1].linear_velocity, Vector3d(T / m, 0, e), 1e-8);
        expectVecNear(r.bodies[1].angular_velocity, Vector3d(0, 2 * T / (m * side), 0), 1e-8);
      }
      for (const auto& imp : r.impulses) {
        if (imp.normal_impulse > 0.0) EXPECT_TRUE(imp.sticking);
      }
      EXPECT_LT(r.kinetic_energy_after, r.kinetic_energy_before);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Chains. Every contact impulse is internal (+P on b, -P on a at the same point), so with only
// free bodies the total linear momentum and the angular momentum about any point are unchanged,
// whatever the number of contacts, friction or convergence.
cr::Scene randomChain(Random& rnd, int n, bool with_friction) {
  cr::Scene s;
  for (int i = 0; i < n; ++i) s.bodies.push_back(rnd.body("b" + std::to_string(i)));
  for (int i = 0; i + 1 < n; ++i) {
    const double mu_s = with_friction ? rnd.uniform(0, 1) : 0.0;
    s.contacts.push_back(contact(s.bodies[i].id, s.bodies[i + 1].id, rnd.vec(-2, 2), rnd.unit(),
                                 rnd.uniform(0, 1), mu_s,
                                 with_friction ? rnd.uniform(0, mu_s) : 0.0));
  }
  // One extra contact closing a loop.
  s.contacts.push_back(contact(s.bodies[0].id, s.bodies[n - 1].id, rnd.vec(-2, 2), rnd.unit(),
                               rnd.uniform(0, 1), 0.3, 0.2));
  // Make the first contact approach so that something happens.
  cr::Contact& c0 = s.contacts[0];
  if (relVel(s.bodies, c0).dot(c0.normal) >= 0) c0.normal = -c0.normal;
  return s;
}

TEST(Chains, FreeBodiesConserveLinearAndAngularMomentum) {
  Random rnd(555);
  for (int k = 0; k < 60; ++k) {
    const cr::Scene s = randomChain(rnd, 3 + k % 5, k % 2 == 0);
    cr::SolverOptions o = newton(kMethods[k % 2]);
    o.max_iterations = 500;
    const auto r = cr::computeResponse(s, o);
    ASSERT_EQ(r.islands.size(), 1u);
    EXPECT_NE(r.islands[0].methodName(), "none");
    const Vector3d p0 = linearMomentum(s.bodies);
    double scale = 1.0;
    for (const auto& imp : r.impulses)
      scale += imp.total(Vector3d::Zero()).norm() + imp.normal_impulse;
    expectVecNear(linearMomentum(r.bodies), p0, kTol * (scale + p0.norm()));
    const Vector3d O = rnd.vec(-5, 5);
    for (const Vector3d& o : {Vector3d(Vector3d::Zero()), O}) {
      const Vector3d h0 = angularMomentum(s.bodies, o);
      expectVecNear(angularMomentum(r.bodies, o), h0, kTol * 10 * (scale + h0.norm()));
    }
  }
}

TEST(Chains, NewtonsCradleOfEqualBallsMovesTogetherUnderSimultaneousLaw) {
  // Three equal balls touching in a row, the first moving at V, e = 1, frictionless. Simultaneous
  // (LCP) Newton law: with j1, j2 >= 0 and all contacts active, u'_1 = -u_1 = V gives
  // v2' - v1' = V and u'_2 = 0 (it was not approaching, so its target is 0): v3' = v2'. Momentum
  // m V = m (v1' + 2 v2') gives v2' = v3' = 2V/3, v1' = -V/3 (j1 = 4mV/3, j2 = 2mV/3 > 0).
  const double m = 1.0, V = 3.0, R = 0.5;
  cr::Scene s;
  s.bodies = {sphere("b1", m, R, Vector3d(0, 0, 0), Vector3d(V, 0, 0)),
              sphere("b2", m, R, Vector3d(1, 0, 0), Vector3d::Zero()),
              sphere("b3", m, R, Vector3d(2, 0, 0), Vector3d::Zero())};
  s.contacts = {contact("b1", "b2", Vector3d(0.5, 0, 0), Vector3d::UnitX(), 1.0),
                contact("b2", "b3", Vector3d(1.5, 0, 0), Vector3d::UnitX(), 1.0)};
  for (const cr::SolverMethod method : kMethods) {
    SCOPED_TRACE(cr::toString(method));
    const auto r = solve(s, method);
    EXPECT_TRUE(r.islands[0].converged);
    expectVecNear(r.bodies[0].linear_velocity, Vector3d(-V / 3, 0, 0), kTol);
    expectVecNear(r.bodies[1].linear_velocity, Vector3d(2 * V / 3, 0, 0), kTol);
    expectVecNear(r.bodies[2].linear_velocity, Vector3d(2 * V / 3, 0, 0), kTol);
    EXPECT_NEAR(r.impulses[0].normal_impulse, 4 * m * V / 3, kTol);
    EXPECT_NEAR(r.impulses[1].normal_impulse, 2 * m * V / 3, kTol);
  }
}

// Random chains of touching spheres (central contacts) on a floor, with friction.
cr::Scene randomSphereChain(Random& rnd, int n) {
  cr::Scene s;
  s.bodies.push_back(fixed("floor"));
  std::vector<double> radius(n);
  std::vector<Vector3d> centre(n);
  for (int i = 0; i < n; ++i) {
    radius[i] = rnd.uniform(0.1, 0.6);
    if (i == 0) {
      centre[i] = Vector3d(0, radius[0], 0);
    } else {
      Vector3d d = rnd.unit();
      d.x() = std::abs(d.x()) + 0.5;
      d.normalize();
      centre[i] = centre[i - 1] + (radius[i - 1] + radius[i]) * d;
    }
    s.bodies.push_back(sphere("s" + std::to_string(i), rnd.uniform(0.2, 3.0), radius[i], centre[i],
                              rnd.vec(-2, 2), rnd.vec(-5, 5)));
  }
  const auto material = [&](cr::Contact c) {
    c.restitution = rnd.uniform(0, 1);
    c.static_friction = rnd.uniform(0, 1);
    c.dynamic_friction = rnd.uniform(0, c.static_friction);
    return c;
  };
  for (int i = 0; i + 1 < n; ++i) {
    const Vector3d nrm = (centre[i + 1] - centre[i]).normalized();
    s.contacts.push_back(material(
        contact(s.bodies[i + 1].id, s.bodies[i + 2].id, centre[i] + radius[i] * nrm, nrm, 0)));
  }
  s.contacts.push_back(
      material(contact("floor", s.bodies[1].id, Vector3d(0, 0, 0), Vector3d::UnitY(), 0)));
  return s;
}

// Checks the Newton + Coulomb conditions of every contact of a solved scene: no contact ends
// approaching (u'_n >= -e u_n, or >= 0 for one that was not approaching), an active contact
// (P_n > 0) ends exactly at its target, P_n >= 0, the impulse is tangent-plus-normal and lies in
// the static cone, a sticking contact has no slip left, a sliding one uses |P_t| = mu_d P_n.
void checkContactConditions(const cr::Scene& s, const cr::CollisionResult& r, int k) {
  double scale = 1.0;
  for (const auto& b : s.bodies) {
    scale = std::max(scale, b.linear_velocity.norm() + b.angular_velocity.norm());
  }
  const double tol = 1e-8 * scale;
  for (std::size_t c = 0; c < s.contacts.size(); ++c) {
    const cr::Contact& ct = s.contacts[c];
    const cr::ContactImpulse& imp = r.impulses[c];
    const double u_n = relVel(s.bodies, ct).dot(ct.normal);
    const Vector3d u_after = relVel(r.bodies, ct);
    const double u_n_after = u_after.dot(ct.normal);
    const double target = u_n < 0 ? -ct.restitution * u_n : 0.0;
    SCOPED_TRACE("case " + std::to_string(k) + " contact " + std::to_string(c));
    EXPECT_NEAR(imp.normal_velocity_before, u_n, 1e-12 * scale);
    EXPECT_NEAR(imp.normal_velocity_after, u_n_after, 1e-12 * scale);
    EXPECT_GE(u_n_after, target - tol);
    EXPECT_GE(imp.normal_impulse, 0.0);
    if (imp.normal_impulse > tol) {
      EXPECT_NEAR(u_n_after, target, tol);
    }
    EXPECT_NEAR(imp.friction_impulse.dot(ct.normal), 0.0, 1e-12 * scale);
    const double j_f = imp.friction_impulse.norm();
    EXPECT_LE(j_f, ct.static_friction * imp.normal_impulse + tol);
    if (imp.sticking) {
      EXPECT_LE((u_after - u_n_after * ct.normal).norm(), tol);
    } else if (imp.normal_impulse > tol) {
      EXPECT_NEAR(j_f, ct.dynamic_friction * imp.normal_impulse, tol);
    }
  }
}

TEST(Chains, SolvedContactsDoNotApproachAndImpulsesLieInTheirCones) {
  // One friction coefficient per contact (mu_d = mu_s): every island must converge.
  Random rnd(77);
  int solved = 0;
  for (int k = 0; k < 80; ++k) {
    cr::Scene s = randomSphereChain(rnd, 2 + k % 5);
    for (auto& c : s.contacts) c.dynamic_friction = c.static_friction;
    const auto r = solve(s, cr::SolverMethod::kIterative);
    ASSERT_EQ(r.islands.size(), 1u);
    if (r.islands[0].methodName() == "none") continue;
    ++solved;
    EXPECT_TRUE(r.islands[0].converged) << "case " << k;
    checkContactConditions(s, r, k);
  }
  EXPECT_GT(solved, 40);
}

TEST(Chains, WithStaticAboveDynamicFrictionConvergedIslandsSatisfyConditions) {
  // With mu_d < mu_s the stick/slip switch can cycle (no fixed point of the projected
  // Gauss-Seidel sweep); such islands must be reported as not converged, and all others must
  // satisfy the contact conditions.
  Random rnd(77);
  int solved = 0, converged = 0;
  for (int k = 0; k < 80; ++k) {
    const cr::Scene s = randomSphereChain(rnd, 2 + k % 5);
    cr::SolverOptions o = newton(cr::SolverMethod::kIterative);
    o.max_iterations = 2000;
    const auto r = cr::computeResponse(s, o);
    if (r.islands[0].methodName() == "none") continue;
    ++solved;
    if (!r.islands[0].converged) {
      EXPECT_GT(r.islands[0].residual, o.tolerance);
      EXPECT_EQ(r.islands[0].iterations, o.max_iterations);
      continue;
    }
    ++converged;
    EXPECT_LE(r.islands[0].residual, o.tolerance);
    checkContactConditions(s, r, k);
  }
  EXPECT_GT(solved, 40);
  EXPECT_GE(converged, solved * 9 / 10);
}

}  // namespace
