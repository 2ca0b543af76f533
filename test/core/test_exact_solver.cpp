// Unit tests of the Lemke LCP solver and of the exact (LCP) multi-contact solver, against
// hand-derived closed forms, the single-contact closed form, the iterative solver, and invariants
// on random scenes.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <utility>
#include <vector>

#include "collision_response/core/body_state.h"
#include "collision_response/core/constants.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/exact_solver.h"
#include "collision_response/core/iterative_solver.h"
#include "collision_response/core/lcp.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/single_contact.h"
#include "collision_response/core/solver_options.h"

#include "rigid_contact.h"

namespace cr = collision_response::core;
using collision_response::testing::spaceOf;
using collision_response::testing::velocityAt;
using Eigen::Matrix3d;
using Eigen::MatrixXd;
using Eigen::Vector3d;
using Eigen::VectorXd;

namespace {

constexpr double kTol = 1e-9;
constexpr int kD = cr::kPyramidDirections;
using collision_response::core::kPi;

void expectVecNear(const Vector3d& got, const Vector3d& want, double tol) {
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(got[i], want[i], tol) << "component " << i;
}

cr::RigidBody body(double mass, const Matrix3d& inertia, const Vector3d& com, const Vector3d& v,
                   const Vector3d& w = Vector3d::Zero()) {
  cr::RigidBody b;
  b.inverse_mass = 1.0 / mass;
  b.inverse_inertia = inertia.inverse();
  b.com = com;
  b.linear_velocity = v;
  b.angular_velocity = w;
  return b;
}

cr::RigidBody sphere(double mass, double radius, const Vector3d& com, const Vector3d& v,
                     const Vector3d& w = Vector3d::Zero()) {
  return body(mass, Matrix3d::Identity() * (0.4 * mass * radius * radius), com, v, w);
}

// Unit cube, 1 kg, inertia I/6, resting on the ground y = 0 (centre at y = 0.5).
cr::RigidBody cube(const Vector3d& v, const Vector3d& w = Vector3d::Zero()) {
  return body(1.0, Matrix3d::Identity() / 6.0, Vector3d(0, 0.5, 0), v, w);
}

const cr::RigidBody kGround;  // immovable

double normalVelocity(const std::vector<cr::RigidBody>& bodies, const cr::ContactPoint& row) {
  return row.normal.dot(velocityAt(row, bodies[row.body_a], bodies[row.body_b]));
}

std::vector<int> allRows(std::size_t n) {
  std::vector<int> island(n);
  for (std::size_t i = 0; i < n; ++i) island[i] = static_cast<int>(i);
  return island;
}

// Contacts of the cube (body 1) with the ground (body 0) at the given points of its bottom face.
std::vector<cr::ContactPoint> groundContacts(const std::vector<cr::RigidBody>& bodies,
                                             const std::vector<Vector3d>& points, double e,
                                             double mu_s = 0.0, double mu_d = 0.0) {
  std::vector<cr::ContactPoint> rows;
  for (const Vector3d& p : points) {
    rows.emplace_back(0, 1, p, Vector3d::UnitY(), e, mu_s, mu_d);
  }
  return rows;
}

const std::vector<Vector3d> kCorners = {Vector3d(0.5, 0, 0.5), Vector3d(0.5, 0, -0.5),
                                        Vector3d(-0.5, 0, 0.5), Vector3d(-0.5, 0, -0.5)};

// ---------------------------------------------------------------------------------------------
// Exact solver: hand-derived scenes

// A cube falling flat at 1 m/s onto 4 corner contacts, e = 0.5: by symmetry v' = (0, e, 0),
// w' = 0, total normal impulse m (1 + e) = 1.5 N s (its split among the corners is not unique).
TEST(ExactSolver, CubeLandsFlatOnFourCorners) {
  std::vector<cr::RigidBody> bodies = {kGround, cube(Vector3d(0, -1, 0))};
  const auto rows = groundContacts(bodies, kCorners, 0.5);
  std::vector<cr::ContactImpulse> impulses(rows.size());
  const cr::SolveReport stats =
      cr::solveExact(bodies, rows, allRows(rows.size()), cr::SolverOptions{}, impulses);
  ASSERT_TRUE(stats.converged);
  EXPECT_LE(stats.residual, 1e-12);
  expectVecNear(bodies[1].linear_velocity, Vector3d(0, 0.5, 0), kTol);
  expectVecNear(bodies[1].angular_velocity, Vector3d::Zero(), kTol);
  double total = 0.0;
  for (std::size_t c = 0; c < rows.size(); ++c) {
    EXPECT_GE(impulses[c].normal_impulse, 0.0);
    EXPECT_EQ(impulses[c].friction_impulse, Vector3d::Zero());
    EXPECT_FALSE(impulses[c].sticking);
    EXPECT_NEAR(normalVelocity(bodies, rows[c]), 0.5, kTol);
    total += impulses[c].normal_impulse;
  }
  EXPECT_NEAR(total, 1.5, kTol);
}

// The same with every corner listed twice (8 rows, A of rank 3), and with 8 distinct points of the
// face (corners and edge midpoints): same velocities.
TEST(ExactSolver, CubeLandsFlatOnRedundantContacts) {
  std::vector<Vector3d> doubled = kCorners;
  doubled.insert(doubled.end(), kCorners.begin(), kCorners.end());
  std::vector<Vector3d> face = kCorners;
  for (const Vector3d& p :
       {Vector3d(0.5, 0, 0), Vector3d(-0.5, 0, 0), Vector3d(0, 0, 0.5), Vector3d(0, 0, -0.5)}) {
    face.push_back(p);
  }
  for (const auto& points : {doubled, face}) {
    std::vector<cr::RigidBody> bodies = {kGround, cube(Vector3d(0, -1, 0))};
    const auto rows = groundContacts(bodies, points, 0.5);
    std::vector<cr::ContactImpulse> impulses(rows.size());
    const cr::SolveReport stats =
        cr::solveExact(bodies, rows, allRows(rows.size()), cr::SolverOptions{}, impulses);
    ASSERT_TRUE(stats.converged);
    EXPECT_LE(stats.residual, 1e-12);
    expectVecNear(bodies[1].linear_velocity, Vector3d(0, 0.5, 0), kTol);
    expectVecNear(bodies[1].angular_velocity, Vector3d::Zero(), kTol);
    double total = 0.0;
    for (const cr::ContactImpulse& impulse : impulses) {
      EXPECT_GE(impulse.normal_impulse, 0.0);
      total += impulse.normal_impulse;
    }
    EXPECT_NEAR(total, 1.5, kTol);
  }
}

// One contact: the LCP must reproduce solveSingleContact's closed form (frictionless, sticking,
// and sliding along a pyramid direction, where pyramid and cone coincide).
TEST(ExactSolver, SingleContactMatchesClosedForm) {
  struct Case {
    Vector3d v, w;
    double mu_s, mu_d;
    bool sticking;
  };
  // Sphere m = 2, R = 0.5 on the ground, contact at r = (0, -R, 0): K = diag(3.5, 1, 3.5) / m.
  // Sticking: |P_t| = m |u_t| / 3.5, P_n = (1 + e) m |u_n|; sliding along -x (d_2 = t2 = -x).
  const Case cases[] = {
      {Vector3d(0.3, -1, 0.2), Vector3d(1, 0.5, -2), 0.0, 0.0, false},
      {Vector3d(0.3, -1, 0.2), Vector3d(1, 0.5, -2), 1.5, 1.0, true},
      {Vector3d(2, -1, 0), Vector3d::Zero(), 0.25, 0.2, false},
  };
  for (const Case& c : cases) {
    std::vector<cr::RigidBody> bodies = {kGround, sphere(2.0, 0.5, Vector3d(0, 0.5, 0), c.v, c.w)};
    const std::vector<cr::ContactPoint> rows = {
        cr::ContactPoint(0, 1, Vector3d::Zero(), Vector3d::UnitY(), 0.7, c.mu_s, c.mu_d)};
    const cr::ContactImpulse want =
        cr::solveSingleContact(bodies[0], bodies[1], rows[0], cr::ImpactLaw::kNewton);
    std::vector<cr::ContactImpulse> impulses(1);
    const cr::SolveReport stats = cr::solveExact(bodies, rows, {0}, cr::SolverOptions{}, impulses);
    ASSERT_TRUE(stats.converged);
    EXPECT_LE(stats.residual, 1e-12);
    EXPECT_NEAR(impulses[0].normal_impulse, want.normal_impulse, kTol);
    EXPECT_NEAR(impulses[0].normal_impulse, 1.7 * 2.0, kTol);
    expectVecNear(impulses[0].friction_impulse, want.friction_impulse, kTol);
    EXPECT_EQ(impulses[0].sticking, c.sticking);
    EXPECT_EQ(want.sticking, c.sticking);
    EXPECT_NEAR(normalVelocity(bodies, rows[0]), 0.7, kTol);
  }
}

// Wall (x = 0), sphere 1 (m1 = 1, R = 1) touching it, sphere 2 (m2 = 2) touching sphere 1, e = 0.5.
TEST(ExactSolver, TwoSpheresInARowAgainstAWall) {
  const double e = 0.5;
  auto scene = [](const Vector3d& v1, const Vector3d& v2) {
    return std::vector<cr::RigidBody>{kGround, sphere(1.0, 1.0, Vector3d(1, 0, 0), v1),
                                      sphere(2.0, 1.0, Vector3d(3, 0, 0), v2)};
  };
  auto contacts = [&](const std::vector<cr::RigidBody>& b) {
    return std::vector<cr::ContactPoint>{
        cr::ContactPoint(0, 1, Vector3d::Zero(), Vector3d::UnitX(), e, 0, 0),
        cr::ContactPoint(1, 2, Vector3d(2, 0, 0), Vector3d::UnitX(), e, 0, 0)};
  };
  {
    // Sphere 1 at rest, sphere 2 at -1 m/s. Both contacts active: u'_1 = v1' = 0 (it was not
    // approaching), u'_2 = v2' - v1' = e, so v2' = e and P_2 = P_1 = m2 (1 + e) = 3.
    std::vector<cr::RigidBody> bodies = scene(Vector3d::Zero(), Vector3d(-1, 0, 0));
    const auto rows = contacts(bodies);
    std::vector<cr::ContactImpulse> impulses(2);
    ASSERT_TRUE(cr::solveExact(bodies, rows, {0, 1}, cr::SolverOptions{}, impulses).converged);
    expectVecNear(bodies[1].linear_velocity, Vector3d::Zero(), kTol);
    expectVecNear(bodies[2].linear_velocity, Vector3d(e, 0, 0), kTol);
    EXPECT_NEAR(impulses[0].normal_impulse, 3.0, kTol);
    EXPECT_NEAR(impulses[1].normal_impulse, 3.0, kTol);
  }
  {
    // Both at -1 m/s: v1' = e (wall), v2' - v1' = 0, so v1' = v2' = e; P_2 = m2 (1 + e) = 3 and
    // P_1 = (m1 + m2)(1 + e) = 4.5.
    std::vector<cr::RigidBody> bodies = scene(Vector3d(-1, 0, 0), Vector3d(-1, 0, 0));
    const auto rows = contacts(bodies);
    std::vector<cr::ContactImpulse> impulses(2);
    ASSERT_TRUE(cr::solveExact(bodies, rows, {0, 1}, cr::SolverOptions{}, impulses).converged);
    expectVecNear(bodies[1].linear_velocity, Vector3d(e, 0, 0), kTol);
    expectVecNear(bodies[2].linear_velocity, Vector3d(e, 0, 0), kTol);
    EXPECT_NEAR(impulses[0].normal_impulse, 4.5, kTol);
    EXPECT_NEAR(impulses[1].normal_impulse, 3.0, kTol);
  }
}

// Ball (m = 2, R = 1) dropped at 1 m/s into a V-groove whose faces are inclined 30 degrees:
// normals (+-1/2, sqrt(3)/2, 0), coupled (n1.n2 = 1/2). By symmetry v' = (0, e, 0), and each
// face gives P = m (1 + e) / (2 cos 30) = 3 / sqrt(3) = sqrt(3).
TEST(ExactSolver, BallInSymmetricVGroove) {
  const double e = 0.5;
  std::vector<cr::RigidBody> bodies = {kGround,
                                       sphere(2.0, 1.0, Vector3d::Zero(), Vector3d(0, -1, 0))};
  const Vector3d n1(0.5, std::sqrt(3.0) / 2, 0), n2(-0.5, std::sqrt(3.0) / 2, 0);
  const std::vector<cr::ContactPoint> rows = {cr::ContactPoint(0, 1, -n1, n1, e, 0, 0),
                                              cr::ContactPoint(0, 1, -n2, n2, e, 0, 0)};
  std::vector<cr::ContactImpulse> impulses(2);
  ASSERT_TRUE(cr::solveExact(bodies, rows, {0, 1}, cr::SolverOptions{}, impulses).converged);
  expectVecNear(bodies[1].linear_velocity, Vector3d(0, e, 0), kTol);
  expectVecNear(bodies[1].angular_velocity, Vector3d::Zero(), kTol);
  EXPECT_NEAR(impulses[0].normal_impulse, std::sqrt(3.0), kTol);
  EXPECT_NEAR(impulses[1].normal_impulse, std::sqrt(3.0), kTol);
}

// The cube landing flat while sliding along +x, v = (1, -1, 0), e = 0.5, mu_s = 0.5, mu_d = 0.3.
// Seen in the x-y plane, with S the total normal impulse and P_F, P_B the normal impulses of the
// front (x = +1/2) and back corners, all corners sliding with friction -mu P_n along x:
//   v'_y = -1 + S,  v'_x = 1 - mu S,
//   w'_z = 6 (1/2 (P_F - P_B) - 1/2 mu S)       (normal and friction moments about the centre),
// and u'_n = v'_y +- w'_z / 2 = e at both ends gives w'_z = 0, S = 1.5, P_F - P_B = mu S.
// With mu_s: v'_x = 0.25 > 0, so the corners slide and mu_d applies: v' = (0.55, 0.5, 0), w' = 0,
// P_F = 0.975, P_B = 0.525.
TEST(ExactSolver, SlidingCubeLandsFlatWithFriction) {
  std::vector<cr::RigidBody> bodies = {kGround, cube(Vector3d(1, -1, 0))};
  const auto rows = groundContacts(bodies, kCorners, 0.5, 0.5, 0.3);
  std::vector<cr::ContactImpulse> impulses(rows.size());
  const cr::SolveReport stats =
      cr::solveExact(bodies, rows, allRows(rows.size()), cr::SolverOptions{}, impulses);
  ASSERT_TRUE(stats.converged);
  EXPECT_LE(stats.residual, 1e-12);
  expectVecNear(bodies[1].linear_velocity, Vector3d(0.55, 0.5, 0), kTol);
  expectVecNear(bodies[1].angular_velocity, Vector3d::Zero(), kTol);
  double front = 0.0, back = 0.0;
  for (std::size_t c = 0; c < rows.size(); ++c) {
    const double P_n = impulses[c].normal_impulse;
    (kCorners[c].x() > 0 ? front : back) += P_n;
    const double P_t = impulses[c].friction_impulse.norm();
    EXPECT_LE(P_t, 0.3 * P_n + kTol);
    EXPECT_GE(P_t, cr::pyramidFactor() * 0.3 * P_n - kTol);
    EXPECT_NEAR(P_t, 0.3 * P_n, kTol);  // -x is a pyramid direction: exact here
    EXPECT_NEAR(impulses[c].friction_impulse.x(), -P_t, kTol);
    EXPECT_FALSE(impulses[c].sticking);
  }
  EXPECT_NEAR(front, 0.975, kTol);
  EXPECT_NEAR(back, 0.525, kTol);
}

// A thin plate (2 kg, 1 m along x, 0.6 m along z, its centre of mass in the plane of its corners)
// landing flat on its 4 corners while sliding at 1 m/s at 28 degrees from x, approaching at 1 m/s;
// e = 0.5, mu = 0.3. By symmetry it is one contact at its centre, through the centre of mass:
// P_n = (1 + e) m 1 = 3 N s; sticking would need m 1 = 2 N s > mu P_n = 0.9 N s, so it slides,
// friction mu P_n against the slip, whose direction the impact keeps:
//   v' = (1 - 0.9 / 2) (cos 28, 0, sin 28) + (0, e, 0),  w' = 0.
// 28 degrees is no direction of a fixed 8-direction pyramid (45 degree steps): its facets would
// give friction turned off the slip and up to cos(pi/8) short; the pyramid is turned to the slip.
TEST(ExactSolver, PlateSlidingObliquelyLandsFlatAsOneContact) {
  const double m = 2.0, a = 1.0, b = 0.6, angle = 28.0 * kPi / 180.0;
  const Vector3d slip(std::cos(angle), 0, std::sin(angle));
  const Matrix3d inertia =
      Vector3d(m * b * b / 12, m * (a * a + b * b) / 12, m * a * a / 12).asDiagonal();
  std::vector<cr::RigidBody> bodies = {
      kGround, body(m, inertia, Vector3d::Zero(), slip - Vector3d::UnitY())};
  const std::vector<Vector3d> corners = {Vector3d(a / 2, 0, b / 2), Vector3d(a / 2, 0, -b / 2),
                                         Vector3d(-a / 2, 0, b / 2), Vector3d(-a / 2, 0, -b / 2)};
  const auto rows = groundContacts(bodies, corners, 0.5, 0.3, 0.3);
  std::vector<cr::ContactImpulse> impulses(rows.size());
  const cr::SolveReport stats =
      cr::solveExact(bodies, rows, allRows(rows.size()), cr::SolverOptions{}, impulses);
  ASSERT_TRUE(stats.converged);
  expectVecNear(bodies[1].linear_velocity, (1 - 0.9 / 2) * slip + Vector3d(0, 0.5, 0), kTol);
  expectVecNear(bodies[1].angular_velocity, Vector3d::Zero(), kTol);
  double total = 0.0;
  for (const cr::ContactImpulse& impulse : impulses) total += impulse.normal_impulse;
  EXPECT_NEAR(total, 3.0, kTol);
}

// The cube turned 30 degrees about z, landing on its lowest edge (two corners, r = (r_x, r_y,
// +-1/2)), v = (0, -1, 0), e = 0.5, frictionless. By symmetry both impulses are P (along +y):
//   v'_y = -1 + 2P,  w'_z = 6 (2 r_x P),  u'_n = v'_y + w'_z r_x = e
// so P = (1 + e) / (2 + 12 r_x^2).
TEST(ExactSolver, TiltedCubeLandsOnAnEdge) {
  const double e = 0.5, angle = kPi / 6;
  const double r_x = -0.5 * std::cos(angle) + 0.5 * std::sin(angle);
  const double r_y = -0.5 * std::sin(angle) - 0.5 * std::cos(angle);
  std::vector<cr::RigidBody> bodies = {
      kGround, body(1.0, Matrix3d::Identity() / 6.0, Vector3d(0, -r_y, 0), Vector3d(0, -1, 0))};
  const auto rows = groundContacts(bodies, {Vector3d(r_x, 0, 0.5), Vector3d(r_x, 0, -0.5)}, e);
  std::vector<cr::ContactImpulse> impulses(2);
  ASSERT_TRUE(cr::solveExact(bodies, rows, {0, 1}, cr::SolverOptions{}, impulses).converged);
  const double P = (1 + e) / (2 + 12 * r_x * r_x);
  EXPECT_NEAR(impulses[0].normal_impulse, P, kTol);
  EXPECT_NEAR(impulses[1].normal_impulse, P, kTol);
  expectVecNear(bodies[1].linear_velocity, Vector3d(0, -1 + 2 * P, 0), kTol);
  expectVecNear(bodies[1].angular_velocity, Vector3d(0, 0, 12 * r_x * P), kTol);
  EXPECT_NEAR(normalVelocity(bodies, rows[0]), e, kTol);
}

// A body wedged between two walls cannot bounce off one of them (Newton's law has no solution):
// reported, nothing applied.
TEST(ExactSolver, InfeasibleRestitutionIsReported) {
  std::vector<cr::RigidBody> bodies = {kGround,
                                       sphere(1.0, 1.0, Vector3d::Zero(), Vector3d(-1, 0, 0))};
  const std::vector<cr::ContactPoint> rows = {
      cr::ContactPoint(0, 1, Vector3d(-1, 0, 0), Vector3d::UnitX(), 0.5, 0, 0),
      cr::ContactPoint(0, 1, Vector3d(1, 0, 0), -Vector3d::UnitX(), 0.5, 0, 0)};
  std::vector<cr::ContactImpulse> impulses(2);
  const cr::SolveReport stats = cr::solveExact(bodies, rows, {0, 1}, cr::SolverOptions{}, impulses);
  EXPECT_FALSE(stats.converged);
  EXPECT_GT(stats.residual, 0.1);
  expectVecNear(bodies[1].linear_velocity, Vector3d(-1, 0, 0), 0.0);
  EXPECT_EQ(impulses[0].normal_impulse, 0.0);
  EXPECT_EQ(impulses[1].normal_impulse, 0.0);
}

// ---------------------------------------------------------------------------------------------
// Exact solver: random scenes

struct RandomScene {
  std::vector<cr::RigidBody> bodies;
  std::vector<cr::ContactPoint> rows;
};

// `movable` random bodies (index 0 is an immovable ground if `ground`), `contacts` contacts
// between random pairs with random points, normals (roughly from a to b) and materials.
RandomScene randomScene(std::mt19937& rng, int movable, int contacts, bool ground, bool friction) {
  std::uniform_real_distribution<double> uniform(-1.0, 1.0), unit(0.0, 1.0);
  auto vec = [&] { return Vector3d(uniform(rng), uniform(rng), uniform(rng)); };
  RandomScene s;
  if (ground) s.bodies.push_back(kGround);
  for (int i = 0; i < movable; ++i) {
    const Matrix3d R = Eigen::Quaterniond(uniform(rng), uniform(rng), uniform(rng), uniform(rng))
                           .normalized()
                           .toRotationMatrix();
    const Vector3d diag(0.2 + unit(rng), 0.2 + unit(rng), 0.2 + unit(rng));
    s.bodies.push_back(body(0.5 + 2.5 * unit(rng), R * diag.asDiagonal() * R.transpose(),
                            2.0 * vec(), vec(), vec()));
  }
  const int n = static_cast<int>(s.bodies.size());
  std::uniform_int_distribution<int> pick(0, n - 1);
  for (int c = 0; c < contacts; ++c) {
    int a = pick(rng), b = pick(rng);
    while (b == a || (!s.bodies[a].movable() && !s.bodies[b].movable())) b = pick(rng);
    const Vector3d point = 0.5 * (s.bodies[a].com + s.bodies[b].com) + 0.3 * vec();
    const Vector3d normal =
        ((s.bodies[b].com - s.bodies[a].com).normalized() + 0.5 * vec()).normalized();
    const double mu_s = friction ? unit(rng) : 0.0;
    s.rows.emplace_back(a, b, point, normal, unit(rng), mu_s, mu_s * (0.5 + 0.5 * unit(rng)));
  }
  return s;
}

Vector3d linearMomentum(const std::vector<cr::RigidBody>& bodies) {
  Vector3d p = Vector3d::Zero();
  for (const auto& b : bodies)
    if (b.movable()) p += b.linear_velocity / b.inverse_mass;
  return p;
}

Vector3d angularMomentum(const std::vector<cr::RigidBody>& bodies) {
  Vector3d L = Vector3d::Zero();
  for (const auto& b : bodies) {
    if (!b.movable()) continue;
    L += b.inverse_inertia.inverse() * b.angular_velocity +
         b.com.cross(b.linear_velocity / b.inverse_mass);
  }
  return L;
}

// Frictionless: the velocities u' = u + A P are unique, so Lemke and projected Gauss-Seidel must
// agree; momentum is conserved without the ground.
TEST(ExactSolver, RandomFrictionlessScenesAgreeWithIterative) {
  std::mt19937 rng(11);
  int compared = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const bool ground = trial % 2 == 0;
    RandomScene s = randomScene(rng, 2 + trial % 3, 2 + trial % 6, ground, false);
    const std::vector<int> island = allRows(s.rows.size());
    std::vector<cr::RigidBody> exact = s.bodies, iterative = s.bodies;
    std::vector<cr::ContactImpulse> exact_impulses(s.rows.size()),
        iterative_impulses(s.rows.size());
    const cr::SolveReport stats =
        cr::solveExact(exact, s.rows, island, cr::SolverOptions{}, exact_impulses);
    ASSERT_TRUE(stats.converged) << "trial " << trial;
    EXPECT_LE(stats.residual, 1e-9) << "trial " << trial;

    double scale = 0.0;
    for (const auto& row : s.rows)
      scale = std::max(scale, velocityAt(row, s.bodies[row.body_a], s.bodies[row.body_b]).norm());
    for (std::size_t c = 0; c < s.rows.size(); ++c) {
      const double u_n = normalVelocity(s.bodies, s.rows[c]);
      const double target = u_n < 0 ? -s.rows[c].restitution * u_n : 0.0;
      EXPECT_GE(normalVelocity(exact, s.rows[c]), target - 1e-9 * scale);
      EXPECT_GE(exact_impulses[c].normal_impulse, 0.0);
    }
    if (!ground) {
      expectVecNear(linearMomentum(exact), linearMomentum(s.bodies), 1e-9);
      expectVecNear(angularMomentum(exact), angularMomentum(s.bodies), 1e-9);
    }

    const cr::SolveReport it =
        cr::solveIterative(iterative, s.rows, island, cr::SolverOptions{}, iterative_impulses);
    if (!it.converged) continue;
    ++compared;
    for (std::size_t i = 0; i < s.bodies.size(); ++i) {
      expectVecNear(exact[i].linear_velocity, iterative[i].linear_velocity, 1e-6 * scale);
      expectVecNear(exact[i].angular_velocity, iterative[i].angular_velocity, 1e-6 * scale);
    }
  }
  EXPECT_GE(compared, 150);
}

// With friction: solved, no contact approaching, impulses inside the pyramid (hence the cone),
// friction opposing the slip, sliding friction saturated to within the pyramid factor, momentum.
TEST(ExactSolver, RandomFrictionalScenesSatisfyCoulomb) {
  std::mt19937 rng(23);
  for (int trial = 0; trial < 200; ++trial) {
    const bool ground = trial % 2 == 0;
    RandomScene s = randomScene(rng, 2 + trial % 3, 2 + trial % 6, ground, true);
    std::vector<cr::RigidBody> bodies = s.bodies;
    std::vector<cr::ContactImpulse> impulses(s.rows.size());
    const cr::SolveReport stats =
        cr::solveExact(bodies, s.rows, allRows(s.rows.size()), cr::SolverOptions{}, impulses);
    ASSERT_TRUE(stats.converged) << "trial " << trial;
    EXPECT_LE(stats.residual, 1e-9) << "trial " << trial;
    double scale = 0.0;
    for (const auto& row : s.rows)
      scale = std::max(scale, velocityAt(row, s.bodies[row.body_a], s.bodies[row.body_b]).norm());
    double largest = 0.0;  // impulse scale
    for (const auto& impulse : impulses) largest = std::max(largest, impulse.normal_impulse);
    for (std::size_t c = 0; c < s.rows.size(); ++c) {
      const cr::ContactPoint& row = s.rows[c];
      const cr::ContactImpulse& impulse = impulses[c];
      const double u_n = normalVelocity(s.bodies, row);
      const double target = u_n < 0 ? -row.restitution * u_n : 0.0;
      const Vector3d u = velocityAt(row, bodies[row.body_a], bodies[row.body_b]);
      const Vector3d u_t = u - u.dot(row.normal) * row.normal;
      const double P_n = impulse.normal_impulse, P_t = impulse.friction_impulse.norm();
      EXPECT_GE(u.dot(row.normal), target - 1e-9 * scale) << "trial " << trial;
      EXPECT_GE(P_n, 0.0);
      EXPECT_NEAR(impulse.friction_impulse.dot(row.normal), 0.0, 1e-12);
      EXPECT_LE(P_t, row.static_friction * P_n + 1e-10 * largest) << "trial " << trial;
      EXPECT_LE(impulse.friction_impulse.dot(u_t), 1e-9 * scale * (P_n + 1e-10 * largest));
      if (impulse.sticking) {
        EXPECT_LE(u_t.norm(), 1e-8 * scale);
      } else if (P_n > 1e-6 * largest && u_t.norm() > 1e-6 * scale) {
        // Sliding (so on mu_d): friction on the boundary of the dynamic pyramid.
        EXPECT_GE(P_t, cr::pyramidFactor() * row.dynamic_friction * P_n - 1e-10 * largest)
            << "trial " << trial;
        EXPECT_LE(P_t, row.dynamic_friction * P_n + 1e-10 * largest) << "trial " << trial;
      }
    }
    if (!ground) {
      expectVecNear(linearMomentum(bodies), linearMomentum(s.bodies), 1e-9);
      expectVecNear(angularMomentum(bodies), angularMomentum(s.bodies), 1e-9);
    }
  }
}

}  // namespace

// A cube sliding onto the ground flat on four corners (m = 1 kg, I = 1/6 kg m^2, v = (0.3, -1,
// 0.1), e = 0.5, ground normal +y). With enough static friction every corner sticks and bounces:
// the velocity field -e u_n n at four non-collinear points is the rigid motion v' = (0, 0.5, 0),
// w' = 0, reached by one linear solve (the all-sticking answer, no pivot). With mu_s = 0.1 the
// sticking impulse (|P_t| = m |v_t| = 0.316 > 0.1 x 1.5) leaves the cones: Lemke pivots, every
// corner still leaves at -e u_n (v'_y = 0.5, P_n = 1.5 in all), and the cube slides on with a
// total friction impulse of mu_d P_n, at least the pyramid's cos(pi/8) of it.
TEST(ExactSolver, AllStickingAnswerIsTakenWhenInsideTheCones) {
  for (const double mu_s : {0.5, 0.1}) {
    SCOPED_TRACE("mu_s " + std::to_string(mu_s));
    std::vector<cr::RigidBody> bodies(2);
    bodies[1].inverse_mass = 1.0;
    bodies[1].inverse_inertia = Matrix3d::Identity() * 6.0;
    bodies[1].com = Vector3d(0, 0.5, 0);
    bodies[1].linear_velocity = Vector3d(0.3, -1.0, 0.1);
    std::vector<cr::ContactPoint> rows;
    std::vector<int> island;
    for (const double x : {-0.5, 0.5}) {
      for (const double z : {-0.5, 0.5}) {
        rows.emplace_back(0, 1, Vector3d(x, 0, z), Vector3d::UnitY(), 0.5, mu_s, 0.8 * mu_s);
        island.push_back(static_cast<int>(island.size()));
      }
    }
    std::vector<cr::ContactImpulse> impulses(rows.size());
    const cr::SolveReport stats = cr::solveExact(bodies, rows, island, {}, impulses);
    ASSERT_TRUE(stats.converged);
    EXPECT_LT(stats.residual, 1e-12);
    Vector3d friction = Vector3d::Zero();
    double normal = 0.0;
    for (const auto& p : impulses) {
      EXPECT_GE(p.normal_impulse, 0.0);
      EXPECT_LE(p.friction_impulse.norm(), mu_s * p.normal_impulse * (1 + 1e-12));
      friction += p.friction_impulse;
      normal += p.normal_impulse;
    }
    EXPECT_NEAR(normal, 1.5, 1e-12);
    EXPECT_NEAR(bodies[1].linear_velocity.y(), 0.5, 1e-12);
    if (mu_s == 0.5) {
      EXPECT_EQ(stats.iterations, 0u);  // one linear solve
      EXPECT_LT((bodies[1].linear_velocity - Vector3d(0, 0.5, 0)).norm(), 1e-12);
      EXPECT_LT(bodies[1].angular_velocity.norm(), 1e-12);
      for (const auto& p : impulses) EXPECT_TRUE(p.sticking);
    } else {
      EXPECT_GT(stats.iterations, 0u);
      EXPECT_LE(friction.norm(), 0.08 * 1.5 * (1 + 1e-12));
      EXPECT_GE(friction.norm(), cr::pyramidFactor() * 0.08 * 1.5 * (1 - 1e-12));
      EXPECT_GT(bodies[1].linear_velocity.x(), 0.0);  // still sliding forward
    }
  }
}

// A body of random mass, inertia and orientation lands, sliding and tumbling a little, on 3 to 8
// points of its flat underside spread around the centre's projection (or all on one line through
// it), with cones wide enough to hold it. Closed form: every point ends at u'_n = -e u_n and
// u'_t = 0; spread points fix the rigid motion w' = -e w_p (w_p: w's part in the ground plane),
// v' = -e v_n n + h w' x n (h: the centre's height), while on a line the rotation about it follows
// from the impulses. The solver takes the all-sticking answer (no pivot); the impulses give the
// momenta exactly and are the least-norm ones: orthogonal to every self-equilibrated set of contact
// impulses (J^T P = 0 in body space), as for any redundant contact set.
TEST(ExactSolver, AllStickingLandingOnManyPointsIsTheRigidClosedFormWithLeastNormImpulses) {
  std::mt19937 rng(20261123);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), positive(0.5, 2.0);
  const Vector3d n = Vector3d::UnitY();
  const double e = 0.4, h = 0.3;
  for (int scene = 0; scene < 60; ++scene) {
    const bool collinear = scene % 4 == 3;  // rank-deficient: rotation about the edge is free
    const int points = 3 + scene % 6;
    SCOPED_TRACE("scene " + std::to_string(scene) + (collinear ? " (on one line)" : ""));
    std::vector<cr::RigidBody> bodies(2);
    const double mass = positive(rng);
    const Matrix3d R =
        Eigen::Quaterniond(unit(rng), unit(rng), unit(rng), unit(rng)).normalized().matrix();
    const Vector3d inertia = 0.1 * mass * Vector3d(positive(rng), positive(rng), positive(rng));
    cr::RigidBody& body = bodies[1];
    body.inverse_mass = 1.0 / mass;
    body.inverse_inertia = R * inertia.cwiseInverse().asDiagonal() * R.transpose();
    body.com = Vector3d(unit(rng), h, unit(rng));
    body.angular_velocity = Vector3d(0.2 * unit(rng), unit(rng), 0.2 * unit(rng));
    if (collinear) body.angular_velocity.x() = body.angular_velocity.z() = 0.0;
    body.linear_velocity = Vector3d(0.5 * unit(rng), -2.0, 0.5 * unit(rng));
    const Vector3d v = body.linear_velocity, w = body.angular_velocity;
    std::vector<cr::ContactPoint> rows;
    std::vector<int> island;
    const double phase = kPi * unit(rng);
    for (int k = 0; k < points; ++k) {
      Vector3d point;
      if (collinear) {  // along the direction of angle `phase`, spread over [-1, 1]
        const double s = -1.0 + 2.0 * k / (points - 1) + 0.2 * unit(rng) / points;
        point = body.com + s * Vector3d(std::cos(phase), 0.0, std::sin(phase));
      } else {  // around the centre, at radius 0.5 to 1
        const double angle = phase + 2.0 * kPi * (k + 0.25 * unit(rng)) / points;
        const double radius = 0.75 + 0.25 * unit(rng);
        point = body.com + radius * Vector3d(std::cos(angle), 0.0, std::sin(angle));
      }
      rows.emplace_back(0, 1, Vector3d(point.x(), 0.0, point.z()), n, e, 10.0, 8.0);
      island.push_back(k);
    }
    std::vector<double> u_n(rows.size());
    for (std::size_t k = 0; k < rows.size(); ++k) {
      u_n[k] = n.dot(velocityAt(rows[k], bodies[0], bodies[1]));
      ASSERT_LT(u_n[k], 0.0);
    }
    std::vector<cr::ContactImpulse> impulses(rows.size());
    const cr::SolveReport stats = cr::solveExact(bodies, rows, island, {}, impulses);
    ASSERT_TRUE(stats.converged);
    EXPECT_EQ(stats.iterations, 0u);

    const Vector3d w_plane = w - w.dot(n) * n;
    const Vector3d w_after = -e * w_plane;
    if (!collinear) expectVecNear(body.angular_velocity, w_after, 1e-9);
    Vector3d linear = Vector3d::Zero(), angular = Vector3d::Zero();
    Eigen::MatrixXd JT(6, 3 * rows.size());  // body-space columns [d; r x d] of every impulse
    VectorXd P(3 * rows.size());
    for (std::size_t k = 0; k < rows.size(); ++k) {
      const Vector3d u = velocityAt(rows[k], bodies[0], bodies[1]);
      EXPECT_NEAR(u.dot(n), -e * u_n[k], 1e-9);
      EXPECT_LT((u - u.dot(n) * n).norm(), 1e-9);
      EXPECT_TRUE(impulses[k].sticking);
      const Vector3d p = impulses[k].total(n);
      linear += p;
      angular += spaceOf(rows[k], bodies[0], bodies[1]).r_b.cross(p);
      for (int a = 0; a < 3; ++a) {
        JT.col(3 * k + a) << Vector3d::Unit(a),
            spaceOf(rows[k], bodies[0], bodies[1]).r_b.cross(Vector3d::Unit(a));
        P(3 * k + a) = p(a);
      }
    }
    expectVecNear(linear, mass * (body.linear_velocity - v), 1e-9);
    expectVecNear(body.inverse_inertia * angular, body.angular_velocity - w, 1e-9);
    const Eigen::MatrixXd equilibrated = Eigen::FullPivLU<Eigen::MatrixXd>(JT).kernel();
    EXPECT_LT((equilibrated.transpose() * P).cwiseAbs().maxCoeff(), 1e-9 * P.norm());
    if (!collinear)
      expectVecNear(body.linear_velocity, -e * v.dot(n) * n + h * w_after.cross(n), 1e-9);
  }
}

// Found by the property suite (seed 20261122, scene 109354): a light, small body (48 g, radius of
// gyration 4 cm) pressed against the ground at six points 1 m away, two of them frictional. With
// some floating-point rounding, Lemke's tableau ends on z with huge cancelling impulses whose
// complementarity holds only relative to their own scale, leaving a contact approaching at
// 130 m/s. The solver judges the answer by the velocities it gives: either every contact meets its
// law (to 1e-3 of the island's speed, far above round-off here), or it reports not converged and
// applies nothing.
TEST(ExactSolver, AnswerLeavingAContactApproachingIsRefused) {
  cr::BodyState light;
  light.mass = 0.048179054480993223;
  light.inertia =
      Eigen::Vector3d(6.3209910216037766e-05, 7.6420468496528495e-05, 0.0001068246254077742)
          .asDiagonal();
  light.position = Vector3d(-0.32138509096029777, -0.28672959393658237, 0.15188008495664573);
  light.orientation = Eigen::Quaterniond(-0.23046323535012914, -0.80524582516777432,
                                         0.54016577998301796, -0.081772784819638511);
  light.linear_velocity = Vector3d(-0.19021170398770554, 0.97866835891365223, 0.21915735593543367);
  light.angular_velocity =
      Vector3d(0.16081324275248499, -0.81768443866901153, 0.067837957175669913);
  std::vector<cr::RigidBody> bodies = {cr::makeRigidBody(light), cr::makeRigidBody({})};
  const cr::RigidBody before = bodies[0];
  struct Row {
    int a, b;
    Vector3d p, n;
    double e, mu_s, mu_d;
  };
  const std::vector<Row> table = {
      {1,
       0,
       {0.26769722130741025, -0.67860648136046842, -0.26975003479057691},
       {0.99205728603276899, 0.094282758208903999, 0.083265255261832039},
       0,
       0,
       0},
      {0,
       1,
       {0.95378934148797156, -0.70127234795784243, -0.5041443642445318},
       {-0.38449506788068444, 0.77250851756605676, -0.50536534612428774},
       0.078354403440148185,
       1.0115487116601292,
       0.63603536920824488},
      {1,
       0,
       {0.058862015051188016, -0.42415102819561429, -0.14118253729761998},
       {-0.51520095322857107, -0.19753616537629651, -0.83399486878565399},
       0,
       0,
       0},
      {1,
       0,
       {0.77058814892203642, -0.89584359715210427, -0.02392381354577755},
       {0.96812481670462702, 0.19304168186135462, -0.15959087801240929},
       0,
       1.0774279725681348,
       1.0774279725681348},
      {0,
       1,
       {0.1162017529794086, -0.41811765357666025, -0.076850242243724859},
       {0.18623734088841812, -0.80076733568529979, 0.56928668257590342},
       0.048449497182974491,
       0.7521973553123682,
       0.36355925157458402},
      {0,
       1,
       {0.2663755026657314, -0.4439782288600122, 0.069483920305678432},
       {0.064676708937387528, 0.7829165750131506, -0.61875565443129998},
       0.70155519310037773,
       0,
       0}};
  std::vector<cr::ContactPoint> rows;
  std::vector<int> island;
  std::vector<double> u_n;
  double speed = 0.0;
  for (const Row& r : table) {
    rows.emplace_back(r.a, r.b, r.p, r.n.normalized(), r.e, r.mu_s, r.mu_d);
    island.push_back(static_cast<int>(island.size()));
    const Vector3d u = velocityAt(rows.back(), bodies[r.a], bodies[r.b]);
    u_n.push_back(u.dot(rows.back().normal));
    speed = std::max(speed, u.norm());
  }
  std::vector<cr::ContactImpulse> impulses(rows.size());
  const cr::SolveReport stats = cr::solveExact(bodies, rows, island, {}, impulses);
  if (!stats.converged) {
    expectVecNear(bodies[0].linear_velocity, before.linear_velocity, 0.0);
    expectVecNear(bodies[0].angular_velocity, before.angular_velocity, 0.0);
    for (const auto& p : impulses) EXPECT_EQ(p.normal_impulse, 0.0);
    return;
  }
  EXPECT_LE(stats.residual, 1e-3);
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const Vector3d u = velocityAt(rows[k], bodies[rows[k].body_a], bodies[rows[k].body_b]);
    const double bound = u_n[k] < 0.0 ? -rows[k].restitution * u_n[k] : 0.0;
    EXPECT_GE(u.dot(rows[k].normal), bound - 1e-6 * speed) << "contact " << k;
  }
}

// A row of N touching balls (1 kg, frictionless), the first struck into the others at v: with
// every contact active, ball 1 leaves at v(1 + e)/N - e v and the rest move together at
// v(1 + e)/N, pushed by P_k = (N - k) v(1 + e)/N >= 0 between balls k and k + 1. That is the
// LCP's unique solution, reached by one linear solve although only the first contact approaches.
TEST(ExactSolver, StruckRowOfTouchingBallsIsOneLinearSolve) {
  for (const int N : {2, 3, 16}) {
    SCOPED_TRACE("balls " + std::to_string(N));
    const double e = 0.5, v = 2.0;
    std::vector<cr::RigidBody> bodies(N);
    for (int k = 0; k < N; ++k) {
      bodies[k].inverse_mass = 1.0;
      bodies[k].inverse_inertia = Matrix3d::Identity() / 0.004;
      bodies[k].com = Vector3d(0.2 * k, 0, 0);
    }
    bodies[0].linear_velocity = Vector3d(v, 0, 0);
    std::vector<cr::ContactPoint> rows;
    std::vector<int> island;
    for (int k = 0; k + 1 < N; ++k) {
      rows.emplace_back(k, k + 1, Vector3d(0.2 * k + 0.1, 0, 0), Vector3d::UnitX(), e, 0.0, 0.0);
      island.push_back(k);
    }
    std::vector<cr::ContactImpulse> impulses(rows.size());
    const cr::SolveReport stats = cr::solveExact(bodies, rows, island, {}, impulses);
    ASSERT_TRUE(stats.converged);
    EXPECT_EQ(stats.iterations, 0u);
    const double V = v * (1.0 + e) / N;
    expectVecNear(bodies[0].linear_velocity, Vector3d(V - e * v, 0, 0), 1e-12);
    for (int k = 1; k < N; ++k) expectVecNear(bodies[k].linear_velocity, Vector3d(V, 0, 0), 1e-12);
    for (int k = 0; k + 1 < N; ++k) EXPECT_NEAR(impulses[k].normal_impulse, (N - 1 - k) * V, 1e-12);
  }
}

// A stack of 2 to 4 unit boxes of one random mass, all descending at v = (0.3, -1, 0.1) m/s onto
// the ground, four corner contacts per face (e = 0.5, mu = 0.5): the closed form is the stack
// moving as one, v' = (0, 0.5, 0), w' = 0, every ground corner leaving at -e u_n, every face
// between boxes at u'_n = 0, every contact stuck. The contacts pin each box (more unknowns than the
// boxes' degrees of freedom): one body-space solve, no pivot. The impulses give each box its
// momentum change and are the least-norm ones (orthogonal to every self-equilibrated set).
TEST(ExactSolver, DescendingStackLandsAsOneWithLeastNormImpulses) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> mass_of(0.5, 2.0);
  for (const int boxes : {2, 3, 4}) {
    SCOPED_TRACE(std::to_string(boxes) + " boxes");
    std::vector<cr::RigidBody> bodies(boxes + 1);  // 0: the ground
    std::vector<double> mass(boxes + 1, 0.0);
    const double box_mass = mass_of(rng);  // unequal boxes tip: a light one under heavy ones
    for (int k = 1; k <= boxes; ++k) {
      mass[k] = box_mass;
      bodies[k].inverse_mass = 1.0 / mass[k];
      bodies[k].inverse_inertia = Matrix3d::Identity() * 6.0 / mass[k];
      bodies[k].com = Vector3d(0, k - 0.5, 0);
      bodies[k].linear_velocity = Vector3d(0.06, -1.0, 0.02);
    }
    std::vector<cr::ContactPoint> rows;
    std::vector<int> island;
    for (int k = 1; k <= boxes; ++k) {
      for (const double x : {-0.5, 0.5}) {
        for (const double z : {-0.5, 0.5}) {
          rows.emplace_back(k - 1, k, Vector3d(x, k - 1, z), Vector3d::UnitY(), 0.5, 0.5, 0.5);
          island.push_back(static_cast<int>(island.size()));
        }
      }
    }
    const std::vector<cr::RigidBody> before = bodies;
    std::vector<cr::ContactImpulse> impulses(rows.size());
    const cr::SolveReport stats = cr::solveExact(bodies, rows, island, {}, impulses);
    ASSERT_TRUE(stats.converged);
    EXPECT_EQ(stats.iterations, 0u);
    for (int k = 1; k <= boxes; ++k) {
      expectVecNear(bodies[k].linear_velocity, Vector3d(0, 0.5, 0), 1e-12);
      expectVecNear(bodies[k].angular_velocity, Vector3d::Zero(), 1e-12);
    }
    // Momentum of each box from the impulses; J^T over all boxes for the least-norm check.
    std::vector<Vector3d> linear(boxes + 1, Vector3d::Zero()), angular(boxes + 1, Vector3d::Zero());
    MatrixXd JT = MatrixXd::Zero(6 * boxes, 3 * rows.size());
    VectorXd P(3 * rows.size());
    for (std::size_t i = 0; i < rows.size(); ++i) {
      EXPECT_TRUE(impulses[i].sticking);
      const Vector3d p = impulses[i].total(rows[i].normal);
      P.segment<3>(3 * i) = p;
      const int sides[2] = {rows[i].body_a, rows[i].body_b};
      const cr::ContactSpace space =
          spaceOf(rows[i], before[rows[i].body_a], before[rows[i].body_b]);
      const Vector3d r[2] = {space.r_a, space.r_b};
      for (int side = 0; side < 2; ++side) {
        const int k = sides[side];
        if (k == 0) continue;
        const double sign = side == 0 ? -1.0 : 1.0;
        linear[k] += sign * p;
        angular[k] += sign * r[side].cross(p);
        for (int a = 0; a < 3; ++a) {
          const Vector3d unit = sign * Vector3d::Unit(a);
          JT.block<6, 1>(6 * (k - 1), 3 * i + a) << unit, r[side].cross(unit);
        }
      }
    }
    for (int k = 1; k <= boxes; ++k) {
      expectVecNear(linear[k], mass[k] * (bodies[k].linear_velocity - before[k].linear_velocity),
                    1e-12);
      expectVecNear(angular[k], Vector3d::Zero(), 1e-12);
    }
    const MatrixXd equilibrated = Eigen::FullPivLU<MatrixXd>(JT).kernel();
    EXPECT_LT((equilibrated.transpose() * P).cwiseAbs().maxCoeff(), 1e-9 * P.norm());
  }
}

// ---------------------------------------------------------------------------------------------
// Exact solver against Lemke's method on box landings (the sampled uncertainty's scenes)

// The answer of exact_solver.h's law for one free rigid body on the immovable ground, written out
// here from the header's definition and solved by Lemke's method alone (solveLcp(), no all-sticking
// guess, no modes): the pyramid of each contact turned to its pre-impact slip (d_0 along it, d_2 =
// n x d_0), every contact on mu_s first, and every contact that comes out slipping moved to mu_d
// and the LCP solved again, until none on mu_s slips. Returns the body's velocity change (dv, dw)
// and, per contact, whether it stuck in the first (mu_s) round with friction above mu_d P_n.
struct LemkeLanding {
  bool solved = false;
  Vector3d dv = Vector3d::Zero(), dw = Vector3d::Zero();
  int rounds = 0;
  std::vector<bool> in_band;  // sticking on mu_s with mu_d P_n < |P_t| (<= mu_s P_n)
};

LemkeLanding lemkeLanding(const cr::RigidBody& b, const std::vector<cr::ContactPoint>& rows) {
  const int count = static_cast<int>(rows.size());
  const int per = kD + 2;  // P_n, beta_0..D-1, lambda
  std::vector<Vector3d> r(count), u(count);
  std::vector<Eigen::Matrix<double, 3, kD + 1>> D(count);
  double speed = 0.0;
  for (int i = 0; i < count; ++i) {
    r[i] = rows[i].point - b.com;
    u[i] = b.linear_velocity + b.angular_velocity.cross(r[i]);
    speed = std::max(speed, u[i].norm());
    const Vector3d& n = rows[i].normal;
    const Vector3d t1 = (u[i] - u[i].dot(n) * n).normalized(), t2 = n.cross(t1);
    D[i].col(0) = n;
    for (int k = 0; k < kD; ++k) {
      const double angle = 2.0 * kPi * k / kD;
      D[i].col(1 + k) = std::cos(angle) * t1 + std::sin(angle) * t2;
    }
  }
  const auto skew = [](const Vector3d& v) {
    Matrix3d m;
    m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
    return m;
  };
  // Impulse P at r_j changes the velocity at r_i by W_ij P.
  const auto W = [&](int i, int j) {
    return Matrix3d(Matrix3d::Identity() * b.inverse_mass -
                    skew(r[i]) * b.inverse_inertia * skew(r[j]));
  };
  MatrixXd M = MatrixXd::Zero(per * count, per * count);
  VectorXd q = VectorXd::Zero(per * count);
  for (int i = 0; i < count; ++i) {
    for (int j = 0; j < count; ++j)
      M.block(per * i, per * j, kD + 1, kD + 1) = D[i].transpose() * W(i, j) * D[j];
    q.segment(per * i, kD + 1) = D[i].transpose() * u[i];
    const double u_n = u[i].dot(rows[i].normal);
    q(per * i) += u_n < 0.0 ? rows[i].restitution * u_n : 0.0;  // u'_n >= -e u_n
    M.block(per * i + 1, per * i + kD + 1, kD, 1).setOnes();
    M.block(per * i + kD + 1, per * i + 1, 1, kD).setConstant(-1.0);
    M(per * i + kD + 1, per * i) = rows[i].static_friction;
  }
  LemkeLanding out;
  out.in_band.assign(count, false);
  std::vector<bool> dynamic(count, false);
  while (true) {
    ++out.rounds;
    const cr::LcpResult lcp = cr::solveLcp(M, q);
    if (lcp.status != cr::LcpStatus::kSolved) return out;
    out.dv.setZero();
    out.dw.setZero();
    std::vector<Vector3d> P(count);
    for (int i = 0; i < count; ++i) {
      P[i] = D[i] * lcp.z.segment<kD + 1>(per * i);
      out.dv += b.inverse_mass * P[i];
      out.dw += b.inverse_inertia * r[i].cross(P[i]);
    }
    bool changed = false;
    for (int i = 0; i < count; ++i) {
      const Vector3d& n = rows[i].normal;
      const Vector3d after = u[i] + out.dv + out.dw.cross(r[i]);
      const double slip = (after - after.dot(n) * n).norm();
      const double P_n = P[i].dot(n), P_t = (P[i] - P_n * n).norm();
      if (out.rounds == 1 && slip <= 1e-9 * speed && P_t > rows[i].dynamic_friction * P_n)
        out.in_band[i] = true;
      if (slip > 1e-9 * speed && !dynamic[i] &&
          rows[i].dynamic_friction != rows[i].static_friction) {
        dynamic[i] = true;
        M(per * i + kD + 1, per * i) = rows[i].dynamic_friction;
        changed = true;
      }
    }
    if (!changed) break;
  }
  out.solved = true;
  return out;
}

// A box landing on the 4 corners of its bottom face (a random plane), tilted velocity and spin,
// each corner with its own e (so Newton's targets lie on no rigid motion: one corner leaves with
// P = 0), mu_s > mu_d: the exact solver, which answers these without Lemke (all-sticking guess,
// then its modes), must give the velocities of Lemke's method on the LCP written out above, both
// where corners slip (the mu_d round) and where they stick with friction between mu_d P_n and
// mu_s P_n (which a switch to mu_d too early would let slip).
TEST(ExactSolver, BoxLandingsWithUnequalRestitutionsAreLemkesAnswer) {
  std::mt19937 rng(26);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0), unit(0.0, 1.0);
  int compared = 0, slipping = 0, in_band = 0, unsolved = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const Matrix3d Q = Eigen::Quaterniond::UnitRandom().toRotationMatrix();
    const Matrix3d yaw =
        Eigen::AngleAxisd(kPi * uniform(rng), Vector3d::UnitZ()).toRotationMatrix();
    const Vector3d half(0.1 + unit(rng), 0.1 + unit(rng), 0.1 + unit(rng));
    const double mass = 0.5 + 4.0 * unit(rng);
    const Vector3d principal(mass / 3.0 * (half.y() * half.y() + half.z() * half.z()),
                             mass / 3.0 * (half.x() * half.x() + half.z() * half.z()),
                             mass / 3.0 * (half.x() * half.x() + half.y() * half.y()));
    const Matrix3d R = Q * yaw;
    const Vector3d normal = Q.col(2);  // the ground's, from the ground (a) to the box (b)
    const Vector3d com = R * Vector3d(0, 0, half.z());
    // Approaching at 0.3 to 2 m/s, sliding at up to 2 m/s, spinning at up to 2 rad/s (less on
    // every third trial: more sticking).
    const double spin = trial % 3 == 0 ? 0.2 : 2.0;
    const Vector3d v = Q * Vector3d(2.0 * uniform(rng), 2.0 * uniform(rng), -0.3 - 1.7 * unit(rng));
    const Vector3d w = spin * Vector3d(uniform(rng), uniform(rng), uniform(rng));
    std::vector<cr::RigidBody> bodies = {
        kGround, body(mass, R * principal.asDiagonal() * R.transpose(), com, v, w)};
    std::vector<cr::ContactPoint> rows;
    for (const double x : {-1.0, 1.0}) {
      for (const double y : {-1.0, 1.0}) {
        const double mu_s = 0.1 + 0.9 * unit(rng);
        rows.emplace_back(0, 1, R * Vector3d(x * half.x(), y * half.y(), 0.0), normal,
                          0.2 + 0.6 * unit(rng), mu_s, mu_s * (0.5 + 0.49 * unit(rng)));
      }
    }
    const LemkeLanding lemke = lemkeLanding(bodies[1], rows);
    const cr::RigidBody before = bodies[1];
    std::vector<cr::ContactImpulse> impulses(rows.size());
    const cr::SolveReport report =
        cr::solveExact(bodies, rows, allRows(rows.size()), cr::SolverOptions{}, impulses);
    if (!lemke.solved) {
      ++unsolved;
      continue;
    }
    ASSERT_TRUE(report.converged) << "trial " << trial;
    const double speed = std::max(v.norm(), w.norm() * half.norm());
    const Vector3d dv = bodies[1].linear_velocity - before.linear_velocity;
    const Vector3d dw = bodies[1].angular_velocity - before.angular_velocity;
    EXPECT_LT((dv - lemke.dv).norm(), 1e-9 * speed) << "trial " << trial;
    EXPECT_LT(half.norm() * (dw - lemke.dw).norm(), 1e-9 * speed) << "trial " << trial;
    ++compared;
    if (lemke.rounds > 1) ++slipping;
    if (std::count(lemke.in_band.begin(), lemke.in_band.end(), true) > 0) ++in_band;
  }
  std::printf(
      "box landings: %d compared with Lemke (%d with a mu_d round, %d with a corner "
      "sticking between mu_d P_n and mu_s P_n), %d Lemke did not solve\n",
      compared, slipping, in_band, unsolved);
  EXPECT_GE(compared, 390);
  EXPECT_GE(slipping, 100);
  EXPECT_GE(in_band, 50);
}
