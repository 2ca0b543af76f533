// Numerical stress tests of computeResponse(): extreme mass and inertia ratios, velocity scales,
// coordinates far from the origin, grazing approaches, contacts at the centre of mass, many
// redundant contacts and a body squeezed between two walls. Every result is checked for physical
// validity (checkPhysics below); where the answer is unique, it is also compared with a closed
// form or with an equivalent, better conditioned scene.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "collision_response/core/compute_response.h"
#include "collision_response/core/contact_space.h"
#include "collision_response/core/island_solver.h"
#include "collision_response/core/rigid_body.h"
#include "env_number.h"
#include "physics_checks.h"

namespace core = collision_response::core;

namespace {

core::BodyState makeBody(const std::string& id, double mass, const Eigen::Vector3d& moments,
                         const Eigen::Vector3d& position,
                         const Eigen::Quaterniond& orientation = Eigen::Quaterniond::Identity(),
                         const Eigen::Vector3d& v = Eigen::Vector3d::Zero(),
                         const Eigen::Vector3d& w = Eigen::Vector3d::Zero()) {
  core::BodyState body;
  body.id = id;
  body.mass = mass;
  body.inertia = moments.asDiagonal();
  body.position = position;
  body.orientation = orientation;
  body.linear_velocity = v;
  body.angular_velocity = w;
  return body;
}

core::BodyState wall(const std::string& id, const Eigen::Vector3d& position = {0, 0, 0}) {
  return makeBody(id, 0.0, Eigen::Vector3d::Zero(), position);
}

Eigen::Vector3d boxMoments(double m, const Eigen::Vector3d& size) {
  const Eigen::Vector3d s2 = size.cwiseProduct(size);
  return m / 12.0 * Eigen::Vector3d(s2.y() + s2.z(), s2.x() + s2.z(), s2.x() + s2.y());
}

core::Contact makeContact(const std::string& a, const std::string& b, const Eigen::Vector3d& point,
                          const Eigen::Vector3d& normal, double e, double mu_s = 0.0,
                          double mu_d = 0.0) {
  core::Contact c;
  c.body_a = a;
  c.body_b = b;
  c.point = point;
  c.normal = normal.normalized();
  c.restitution = e;
  c.static_friction = mu_s;
  c.dynamic_friction = mu_d;
  return c;
}

std::string name(core::ImpactLaw law, core::SolverMethod method) {
  return std::string(core::toString(law)) + "/" + core::toString(method);
}

// Runs one scene under one law and method, checks it, and returns the result.
core::CollisionResult solveAndCheck(const core::Scene& scene, core::ImpactLaw law,
                                    core::SolverMethod method, const Tolerances& tol = Tolerances(),
                                    CheckResult* check_out = nullptr) {
  const core::SolverOptions o = options(law, method);
  const core::CollisionResult r = core::computeResponse(scene, o);
  const CheckResult check = checkPhysics(scene, o, r, tol);
  EXPECT_TRUE(check.ok()) << name(law, method) << " failed:\n"
                          << check.text() << "scene:\n"
                          << describe(scene);
  if (check_out) *check_out = check;
  return r;
}

bool allConverged(const core::CollisionResult& r) {
  for (const auto& island : r.islands) {
    if (!island.converged) return false;
  }
  return true;
}

double maxVelocityDifference(const core::CollisionResult& x, const core::CollisionResult& y,
                             double length = 1.0) {
  double d = 0.0;
  for (std::size_t i = 0; i < x.bodies.size(); ++i) {
    d = std::max(d, (x.bodies[i].linear_velocity - y.bodies[i].linear_velocity).norm());
    d = std::max(d, length * (x.bodies[i].angular_velocity - y.bodies[i].angular_velocity).norm());
  }
  return d;
}

Eigen::Quaterniond tilt(double angle, const Eigen::Vector3d& axis) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, axis.normalized()));
}

// ---------------------------------------------------------------------------------------------
// Mass ratios 1 .. 1e12: a 1 g cube (1 cm) strikes, with one corner, the top face of a block of
// 1e-3 x ratio kg (1 m cube) off its centre, with friction. Momentum is conserved (no immovable
// body). As the ratio grows the light cube's answer must tend to the answer against an immovable
// block, with a relative difference of order 1 / ratio (the block's share of K).
core::Scene lightOnHeavy(double ratio, bool block_immovable, bool heavy_moving) {
  const double m = 1e-3, M = m * ratio;
  core::BodyState block = makeBody("block", block_immovable ? 0.0 : M,
                                   boxMoments(M, Eigen::Vector3d::Ones()), {0.2, -0.5, 0.1});
  if (heavy_moving && !block_immovable) block.linear_velocity = {0.1, 0.5, -0.2};
  const Eigen::Quaterniond q = tilt(0.4, {1.0, 0.3, -0.2});
  const Eigen::Vector3d corner_body(-0.005, -0.005, -0.005);
  const Eigen::Vector3d corner = Eigen::Vector3d(0.0, 0.0, 0.0);
  // Place the part so that its corner is at the origin, on the block's top face (y = 0).
  core::BodyState part = makeBody("part", m, boxMoments(m, Eigen::Vector3d::Constant(0.01)),
                                  corner - q * corner_body, q, {0.3, -1.0, 0.2}, {5.0, -3.0, 2.0});
  core::Scene scene;
  scene.bodies = {block, part};
  scene.contacts = {makeContact("block", "part", corner, Eigen::Vector3d::UnitY(), 0.5, 0.6, 0.5)};
  return scene;
}

TEST(Stress, MassRatiosUpTo1e12OneCorner) {
  for (const double ratio : {1.0, 1e3, 1e6, 1e9, 1e12}) {
    for (const bool heavy_moving : {false, true}) {
      const core::Scene scene = lightOnHeavy(ratio, false, heavy_moving);
      const core::Scene fixed = lightOnHeavy(ratio, true, false);
      for (const core::ImpactLaw law : kAllLaws) {
        for (const core::SolverMethod method : kAllMethods) {
          SCOPED_TRACE("ratio " + std::to_string(ratio) + " heavy moving " +
                       std::to_string(heavy_moving) + " " + name(law, method));
          const core::CollisionResult r = solveAndCheck(scene, law, method);
          EXPECT_TRUE(allConverged(r));
          if (ratio < 1e6 || heavy_moving) continue;
          // Against the immovable block: the light part's velocities agree to ~ 1/ratio (K changes
          // by at most a relative 1/ratio x (lever arm ratio)^2 ~ 20/ratio here), plus the solver
          // tolerance (impulse-space integration 1e-10, iteration 1e-12) times the condition.
          const core::CollisionResult rf = solveAndCheck(fixed, law, method);
          const double v = scene.bodies[1].linear_velocity.norm() +
                           0.01 * scene.bodies[1].angular_velocity.norm();
          const double d =
              (r.bodies[1].linear_velocity - rf.bodies[1].linear_velocity).norm() +
              0.01 * (r.bodies[1].angular_velocity - rf.bodies[1].angular_velocity).norm();
          EXPECT_LE(d, (100.0 / ratio + 1e-8) * v);
        }
      }
    }
  }
}

// The same light cube lands flat on the heavy block on its four bottom corners: a coupled
// 4-contact island (exact and iterative solvers, two-phase schemes).
core::Scene lightCubeOnFourCorners(double ratio) {
  const double m = 1e-3, M = m * ratio;
  core::Scene scene;
  scene.bodies = {
      makeBody("block", M, boxMoments(M, Eigen::Vector3d::Ones()), {0.3, -0.5, -0.2}),
      makeBody("part", m, boxMoments(m, Eigen::Vector3d::Constant(0.01)), {0.0, 0.005, 0.0},
               Eigen::Quaterniond::Identity(), {0.4, -1.0, 0.1}, {1.0, 2.0, -3.0})};
  for (const double x : {-0.005, 0.005}) {
    for (const double z : {-0.005, 0.005}) {
      scene.contacts.push_back(
          makeContact("block", "part", {x, 0.0, z}, Eigen::Vector3d::UnitY(), 0.7, 0.3, 0.2));
    }
  }
  return scene;
}

void fourCorners(const std::vector<core::SolverMethod>& methods) {
  for (const double ratio : {1.0, 1e3, 1e6, 1e9, 1e12}) {
    const core::Scene scene = lightCubeOnFourCorners(ratio);
    for (const core::ImpactLaw law : kAllLaws) {
      for (const core::SolverMethod method : methods) {
        SCOPED_TRACE("ratio " + std::to_string(ratio) + " " + name(law, method));
        const core::CollisionResult r = solveAndCheck(scene, law, method);
        EXPECT_TRUE(allConverged(r));
      }
    }
  }
}

TEST(Stress, MassRatiosUpTo1e12FourCornersIterative) {
  fourCorners({core::SolverMethod::kIterative});
}

// OPEN (lcp.cpp): the wrong answers this test found are fixed (Lemke's exit test read z0's old row
// and its ratio ties were judged against the largest ratio; solveLcp now also verifies its answer),
// so the exact solver now reports these islands converged = false and applies nothing (kAuto then
// iterates). It still ends on a ray for some of them although a solution exists; enable this test
// when the pivoting handles them. History of the original failure:
// Reproduction: lightCubeOnFourCorners(1.0) (block 1 g, I = 1/6e3 I3 at (0.3, -0.5, -0.2); part
// 1 g, I = 1/6e8 I3 at (0, 0.005, 0), v = (0.4, -1, 0.1), w = (1, 2, -3); four contacts
// block->part at (+-0.005, 0, +-0.005), n = +y, e = 0.7, mu_s = 0.3, mu_d = 0.2), law kNewton,
// method kExact: island "exact" reported converged with residual 0.95; contact 1 leaves at
// u'_n = 0.627 < -e u_n = 0.693 and contact 2 has P_n > 0 with u'_n = 1.749 != 0.707 (the
// iterative solver meets every target). Instrumenting solveLcp() shows the second LCP stops with
// z0 = -0.19 (basic values down to -0.38): the loop's exit test `T(z0_row, rhs) <= z0_zero`
// accepts a negative z0 as "round-off zero", after a ratio test whose tie tolerance
// (keepMinimumRatios: minimum + tolerance x the LARGEST |ratio| among the candidates) lets a
// row with a clearly larger ratio leave, making the basis infeasible. Under Poisson / Stronge
// with kExact the same scene (ratios 1, 1e6, 1e9, 1e12) ends with converged = false (ray
// termination of the plastic LCP, nothing applied).
TEST(Stress, DISABLED_MassRatiosUpTo1e12FourCornersExact) {
  fourCorners({core::SolverMethod::kAuto, core::SolverMethod::kExact});
}

// A light ball between two heavy movable blocks closing in on it (ratios to 1e12). The Delassus
// matrix [[1/m + 1/M, 1/m], [1/m, 1/m + 1/M]] has condition ~ 2 M / m: projected Gauss-Seidel
// contracts by about 1 - m / M per sweep and cannot converge at large ratios; the exact solver
// pivots and is unaffected. Property: everything finite and momentum-consistent always; where an
// island is reported converged, the full checks; under the exact solver, convergence.
TEST(Stress, LightBallBetweenHeavyBlocks) {
  for (const double ratio : {1.0, 1e3, 1e6, 1e9, 1e12}) {
    const double m = 1e-3, M = m * ratio;
    core::Scene scene;
    scene.bodies = {makeBody("left", M, boxMoments(M, Eigen::Vector3d::Ones()), {-0.51, 0, 0},
                             Eigen::Quaterniond::Identity(), {1.0, 0, 0}),
                    makeBody("ball", m, Eigen::Vector3d::Constant(0.4 * m * 1e-4), {0, 0, 0},
                             Eigen::Quaterniond::Identity(), {0.0, 0.3, 0}),
                    makeBody("right", M, boxMoments(M, Eigen::Vector3d::Ones()), {0.51, 0, 0},
                             Eigen::Quaterniond::Identity(), {-1.0, 0, 0})};
    scene.contacts = {
        makeContact("left", "ball", {-0.01, 0, 0}, Eigen::Vector3d::UnitX(), 0.5, 0.4, 0.3),
        makeContact("ball", "right", {0.01, 0, 0}, Eigen::Vector3d::UnitX(), 0.5, 0.4, 0.3)};
    int iterative_unconverged = 0;
    for (const core::ImpactLaw law : kAllLaws) {
      for (const core::SolverMethod method : kAllMethods) {
        SCOPED_TRACE("ratio " + std::to_string(ratio) + " " + name(law, method));
        const core::CollisionResult r = solveAndCheck(scene, law, method);
        if (method == core::SolverMethod::kExact || law == core::ImpactLaw::kSeedOnePass) {
          EXPECT_TRUE(allConverged(r));
        } else if (!allConverged(r)) {
          ++iterative_unconverged;
        }
      }
    }
    std::printf("light ball between blocks, ratio %.0e: %d iterative solves not converged\n", ratio,
                iterative_unconverged);
  }
}

// ---------------------------------------------------------------------------------------------
// Inertia ratios to 1e9: a thin rod (along / across = 6 r^2 / L^2) and a thin strip plate, both
// spinning about their thin axis, striking the ground with a tip / corner, and two crossed rods
// striking each other (no immovable body: momentum conserved).
core::BodyState rod(const std::string& id, double ratio, const Eigen::Vector3d& position,
                    const Eigen::Quaterniond& q, const Eigen::Vector3d& v,
                    const Eigen::Vector3d& w) {
  const double m = 1.0, L = 1.0;
  const double r = L / std::sqrt(6.0 * ratio);  // along / across = 1 / ratio (r << L)
  const double across = m * (3.0 * r * r + L * L) / 12.0, along = 0.5 * m * r * r;
  return makeBody(id, m, {along, across, across}, position, q, v, w);
}

TEST(Stress, ThinRodsAndPlatesToInertiaRatio1e9) {
  for (const double ratio : {1e3, 1e6, 1e9}) {
    const double r = 1.0 / std::sqrt(6.0 * ratio);
    // Rod axis (body x) tilted 50 degrees, then turned about the vertical; tip (and a point on
    // its surface, r off the axis) on the ground.
    const Eigen::Quaterniond q =
        tilt(0.3, Eigen::Vector3d::UnitY()) * tilt(-0.87, Eigen::Vector3d::UnitZ());
    const Eigen::Vector3d tip_body(-0.5, -r, 0.0);
    const Eigen::Vector3d tip = {0.0, 0.0, 0.0};
    core::Scene ground_scene;
    ground_scene.bodies = {wall("ground"),
                           rod("rod", ratio, tip - q * tip_body, q, {0.4, -1.0, 0.1},
                               q * Eigen::Vector3d(30.0, 0.5, -0.2))};
    ground_scene.contacts = {
        makeContact("ground", "rod", tip, Eigen::Vector3d::UnitY(), 0.8, 0.8, 0.6)};

    // Strip plate (a ruler) 1 m x t x b, b = 1 / sqrt(ratio), t = b / 10: moments
    // (b^2 + t^2, 1 + t^2, 1 + b^2) m / 12, so Ixx / Izz ~ 1 / ratio.
    const double m = 1.0, b = 1.0 / std::sqrt(ratio), t = 0.1 * b;
    const Eigen::Vector3d size(1.0, t, b);
    core::Scene plate_scene;
    const Eigen::Vector3d corner_body(0.5, -0.5 * t, 0.5 * b);
    const Eigen::Quaterniond qp =
        tilt(0.2, Eigen::Vector3d::UnitX()) * tilt(0.35, Eigen::Vector3d::UnitZ());
    plate_scene.bodies = {wall("ground"),
                          makeBody("plate", m, boxMoments(m, size), tip - qp * corner_body, qp,
                                   {-0.3, -2.0, 0.5}, qp * Eigen::Vector3d(30.0, 0.4, 0.3))};
    plate_scene.contacts = {
        makeContact("ground", "plate", tip, Eigen::Vector3d::UnitY(), 0.6, 1.0, 0.9)};

    // Two crossed rods, both movable, touching at a point off both centres.
    core::Scene crossed;
    const Eigen::Quaterniond qa = tilt(0.1, Eigen::Vector3d::UnitZ());
    const Eigen::Quaterniond qb = tilt(1.4, Eigen::Vector3d::UnitY());
    const Eigen::Vector3d touch(0.0, 0.0, 0.0);
    crossed.bodies = {rod("a", ratio, touch - qa * Eigen::Vector3d(0.3, r, 0.0), qa,
                          {0.0, 1.0, 0.2}, qa * Eigen::Vector3d(-20.0, 0.0, 0.3)),
                      rod("b", ratio, touch - qb * Eigen::Vector3d(-0.2, -r, 0.0), qb,
                          {0.1, -1.0, 0.0}, qb * Eigen::Vector3d(10.0, 0.2, 0.0))};
    crossed.contacts = {makeContact("a", "b", touch, Eigen::Vector3d::UnitY(), 0.9, 0.5, 0.4)};

    // A square sheet 1 m x 1 m x 1e-6 m: moments (1, 2, 1) m / 12 up to 1e-12, the triangle
    // inequality of principal moments holding with equality (to 1e-12).
    core::Scene sheet_scene;
    const Eigen::Vector3d sheet(1.0, 1e-6, 1.0);
    sheet_scene.bodies = {
        wall("ground"),
        makeBody("sheet", m, boxMoments(m, sheet), tip - qp * Eigen::Vector3d(0.5, -0.5e-6, 0.5),
                 qp, {0.2, -1.0, 0.1}, qp * Eigen::Vector3d(1.0, 2.0, 0.3))};
    sheet_scene.contacts = {
        makeContact("ground", "sheet", tip, Eigen::Vector3d::UnitY(), 0.6, 1.0, 0.9)};

    for (const core::Scene* scene : {&ground_scene, &plate_scene, &sheet_scene, &crossed}) {
      for (const core::ImpactLaw law : kAllLaws) {
        for (const core::SolverMethod method : kAllMethods) {
          SCOPED_TRACE("ratio " + std::to_string(ratio) + " " + scene->bodies[1].id + " " +
                       name(law, method));
          const core::CollisionResult r = solveAndCheck(*scene, law, method);
          EXPECT_TRUE(allConverged(r));
          EXPECT_LT(r.impulses[0].normal_velocity_before, 0.0);  // it is an impact
        }
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Velocities from 1e-12 to 1e4 m/s. Every law is positively homogeneous of degree 1 in the
// velocities (impulses and post-impact velocities scale with them; every solver tolerance is
// relative), so v'(s) = s v'(1) must hold to round-off and solver tolerance: 1e-8 relative.
core::Scene velocityScene(double s, int kind) {
  core::Scene scene;
  const double m = 2.0;
  const Eigen::Vector3d size(0.4, 0.2, 0.3);
  const Eigen::Quaterniond q = tilt(0.25, {0.3, 0.0, 1.0});
  if (kind == 0) {  // one corner
    const Eigen::Vector3d corner_body = -0.5 * size;
    scene.bodies = {wall("ground"), makeBody("box", m, boxMoments(m, size), -(q * corner_body), q,
                                             s * Eigen::Vector3d(1.0, -2.0, 0.5),
                                             s * Eigen::Vector3d(3.0, 1.0, -2.0))};
    scene.contacts = {
        makeContact("ground", "box", {0, 0, 0}, Eigen::Vector3d::UnitY(), 0.5, 0.5, 0.4)};
  } else if (kind == 1) {  // flat on four corners, sliding and spinning
    scene.bodies = {
        wall("ground"),
        makeBody("box", m, boxMoments(m, size), {0, 0.1, 0}, Eigen::Quaterniond::Identity(),
                 s * Eigen::Vector3d(1.0, -2.0, 0.5), s * Eigen::Vector3d(0.3, 1.0, -0.2))};
    for (const double x : {-0.2, 0.2}) {
      for (const double z : {-0.15, 0.15}) {
        scene.contacts.push_back(
            makeContact("ground", "box", {x, 0, z}, Eigen::Vector3d::UnitY(), 0.5, 0.5, 0.4));
      }
    }
  } else {  // box corner on a movable ball, off-centre for the box
    scene.bodies = {
        makeBody("ball", 1.0, Eigen::Vector3d::Constant(0.004), {0, -0.1, 0},
                 Eigen::Quaterniond::Identity(), s * Eigen::Vector3d(0.2, 1.0, 0),
                 s * Eigen::Vector3d(0, 0, 5.0)),
        makeBody("box", m, boxMoments(m, size), -(q * (-0.5 * size)), q,
                 s * Eigen::Vector3d(-0.5, -1.0, 0.3), s * Eigen::Vector3d(1.0, 2.0, 0.0))};
    scene.contacts = {
        makeContact("ball", "box", {0, 0, 0}, Eigen::Vector3d::UnitY(), 0.8, 0.7, 0.6)};
  }
  return scene;
}

TEST(Stress, VelocitiesFrom1e12To1e4AreHomogeneous) {
  for (int kind = 0; kind < 3; ++kind) {
    for (const core::ImpactLaw law : kAllLaws) {
      for (const core::SolverMethod method : kAllMethods) {
        const core::CollisionResult unit = solveAndCheck(velocityScene(1.0, kind), law, method);
        for (const double s : {1e-12, 1e-9, 1e-6, 1e-3, 1e2, 1e4}) {
          SCOPED_TRACE("kind " + std::to_string(kind) + " speed " + std::to_string(s) + " " +
                       name(law, method));
          const core::CollisionResult r = solveAndCheck(velocityScene(s, kind), law, method);
          EXPECT_TRUE(allConverged(r));
          for (std::size_t i = 0; i < r.bodies.size(); ++i) {
            const double scale = s * (unit.bodies[i].linear_velocity.norm() +
                                      unit.bodies[i].angular_velocity.norm());
            EXPECT_LE((r.bodies[i].linear_velocity - s * unit.bodies[i].linear_velocity).norm(),
                      1e-8 * scale);
            EXPECT_LE((r.bodies[i].angular_velocity - s * unit.bodies[i].angular_velocity).norm(),
                      1e-8 * scale);
          }
        }
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Far from the origin: the same scenes shifted by 1e5 m. Only r = p - c is affected: p and c are
// each rounded to half an ulp of 1e5 (7.3e-12 m) per coordinate, so |dr| <= 2.6e-11 m, a relative
// perturbation of r of at most 2.6e-11 / 0.11 m = 2.4e-10 here (shortest lever arm ~0.11 m).
// The post-impact velocities are Lipschitz in r with a constant of the order of the condition of
// the contact problem (K's condition ~ 10 for these boxes, x 10 for the multi-contact solvers'
// pivoting and the tangential coupling), so we allow 1e-7 x the velocity scale: ~40x above
// kappa x dr / r with kappa = 100, and far below any physical change.
TEST(Stress, FarFromOriginEqualsAtOrigin) {
  const Eigen::Vector3d offset(1e5, -1e5, 1e5);
  for (int kind = 0; kind < 3; ++kind) {
    const core::Scene near = velocityScene(1.0, kind);
    core::Scene far = near;
    for (auto& b : far.bodies) b.position += offset;
    for (auto& c : far.contacts) c.point += offset;
    for (const core::ImpactLaw law : kAllLaws) {
      for (const core::SolverMethod method : kAllMethods) {
        SCOPED_TRACE("kind " + std::to_string(kind) + " " + name(law, method));
        const core::CollisionResult a = solveAndCheck(near, law, method);
        const core::CollisionResult b = solveAndCheck(far, law, method);
        double v_scale = 0.0;
        for (const auto& body : near.bodies) {
          v_scale =
              std::max(v_scale, body.linear_velocity.norm() + 0.25 * body.angular_velocity.norm());
        }
        EXPECT_LE(maxVelocityDifference(a, b, 0.25), 1e-7 * v_scale);
        for (std::size_t c = 0; c < near.contacts.size(); ++c) {
          EXPECT_NEAR(a.impulses[c].normal_velocity_after, b.impulses[c].normal_velocity_after,
                      1e-7 * v_scale);
        }
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Normals nearly tangent to the relative velocity: a solid ball (central contact, K_tn = 0)
// slides at 10 m/s and approaches the ground at angle theta down to 1e-14 rad. Every law agrees
// on the normal impulse P_n = (1 + e) m |u_n|; the contact keeps sliding, so the friction is
// mu_d P_n opposite the slip (exact solver: its inscribed pyramid, between cos(pi/8) and 1 of
// that). The two-phase scheme (Poisson / Stronge with the exact or iterative solver) applies
// friction through compression and restitution alike: the same mu_d P_n.
TEST(Stress, GrazingApproachOfASlidingBall) {
  const double m = 0.5, R = 0.1, e = 0.6, mu_s = 0.5, mu_d = 0.4;
  for (const double theta : {1e-2, 1e-6, 1e-10, 1e-14}) {
    core::Scene scene;
    const Eigen::Vector3d v(10.0 * std::cos(theta), -10.0 * std::sin(theta), 0.0);
    scene.bodies = {wall("ground"), makeBody("ball", m, Eigen::Vector3d::Constant(0.4 * m * R * R),
                                             {0, R, 0}, Eigen::Quaterniond::Identity(), v)};
    scene.contacts = {
        makeContact("ground", "ball", {0, 0, 0}, Eigen::Vector3d::UnitY(), e, mu_s, mu_d)};
    for (const core::ImpactLaw law : kAllLaws) {
      for (const core::SolverMethod method : kAllMethods) {
        SCOPED_TRACE("theta " + std::to_string(theta) + " " + name(law, method));
        const core::CollisionResult r = solveAndCheck(scene, law, method);
        const double u_n = v.y();
        const double P_n = (1.0 + e) * m * -u_n;
        const core::ContactImpulse& p = r.impulses[0];
        // Round-off is relative to the problem's velocity scale |u| = 10 m/s, not to u_n (the
        // exact solver's pivoting tolerance is 1e-12 x max |q|, q holding u_t): impulses to
        // 1e-12 x m |u|. At theta = 1e-14 that exceeds P_n itself: the exact solver may treat
        // the contact as not approaching (P = 0, u'_n = u_n = -1e-13 m/s, within tolerance).
        const double impulse_tol = 1e-12 * m * 10.0;
        EXPECT_NEAR(p.normal_impulse, P_n, impulse_tol);
        EXPECT_NEAR(p.normal_velocity_after, -e * u_n, 1e-12 * 10.0);
        const double expected = mu_d * P_n;
        const double lower =
            method == core::SolverMethod::kExact ? std::cos(std::acos(-1.0) / 8.0) : 1.0;
        EXPECT_LE(p.friction_impulse.norm(), expected + impulse_tol);
        EXPECT_GE(p.friction_impulse.norm(), lower * expected - impulse_tol);
        if (p.normal_impulse > 0.0) {
          EXPECT_LT(p.friction_impulse.x(), 0.0);
          EXPECT_FALSE(p.sticking);
        }
      }
    }
  }
}

// The same grazing approach off-centre: a box edge, where normal and tangential problems couple
// (K_tn != 0), and a grazing ball-ball pair (both movable). Properties only (checkPhysics).
TEST(Stress, GrazingApproachOffCentre) {
  for (const double theta : {1e-2, 1e-6, 1e-10, 1e-14}) {
    const Eigen::Vector3d v(10.0 * std::cos(theta), -10.0 * std::sin(theta), 0.0);
    const Eigen::Vector3d size(0.4, 0.2, 0.3);
    const Eigen::Quaterniond q = tilt(0.3, Eigen::Vector3d::UnitZ());
    core::Scene box;
    box.bodies = {wall("ground"), makeBody("box", 1.0, boxMoments(1.0, size),
                                           -(q * Eigen::Vector3d(-0.2, -0.1, -0.15)), q, v)};
    box.contacts = {
        makeContact("ground", "box", {0, 0, 0}, Eigen::Vector3d::UnitY(), 0.7, 0.6, 0.5)};
    core::Scene balls;
    const Eigen::Vector3d n(std::sin(theta), std::cos(theta), 0.0);  // nearly perpendicular to x
    balls.bodies = {makeBody("a", 1.0, Eigen::Vector3d::Constant(0.004), -0.1 * n,
                             Eigen::Quaterniond::Identity(), {5.0, 0, 0}, {0, 0, 3.0}),
                    makeBody("b", 2.0, Eigen::Vector3d::Constant(0.008), 0.1 * n,
                             Eigen::Quaterniond::Identity(), {-5.0, 0, 0}, {1.0, 0, 0})};
    balls.contacts = {makeContact("a", "b", {0, 0, 0}, n, 0.9, 0.3, 0.3)};
    for (const core::Scene* scene : {&box, &balls}) {
      for (const core::ImpactLaw law : kAllLaws) {
        for (const core::SolverMethod method : kAllMethods) {
          SCOPED_TRACE("theta " + std::to_string(theta) + " " + scene->bodies[1].id + " " +
                       name(law, method));
          const core::CollisionResult r = solveAndCheck(*scene, law, method);
          EXPECT_TRUE(allConverged(r));
        }
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Contacts at the centre of mass (r = 0: no angular coupling, K = (1/m_a + 1/m_b) I, a particle
// collision). Closed form for every law: P_n = (1 + e) m* |u_n| with m* the reduced mass; the
// contact sticks (u'_t = 0, P_t = -m* u_t) if m* |u_t| <= mu_s P_n, otherwise slides with
// |P_t| = mu_d P_n (pyramid of the exact solver: at least cos(pi/8) of that). Also three
// redundant contacts at the same centre of mass: the velocities are those of one contact.
TEST(Stress, ContactsAtTheCentreOfMass) {
  const double e = 0.5;
  for (const double slip : {0.1, 5.0}) {  // sticks, slides
    core::Scene scene;
    const Eigen::Vector3d va(0.0, 0.0, 0.0), vb(slip, -1.0, 0.0);
    scene.bodies = {
        makeBody("a", 3.0, {0.1, 0.2, 0.25}, {0, 0, 0}, tilt(0.3, {1, 1, 0}), va, {0.0, 1.0, 0.0}),
        makeBody("b", 1.0, {0.01, 0.01, 0.015}, {0, 0, 0}, tilt(1.0, {0, 1, 1}), vb,
                 {2.0, 0.0, 0.0})};
    scene.contacts = {makeContact("a", "b", {0, 0, 0}, Eigen::Vector3d::UnitY(), e, 0.5, 0.4)};
    core::Scene redundant = scene;
    redundant.contacts.push_back(redundant.contacts[0]);
    redundant.contacts.push_back(redundant.contacts[0]);
    const double m_star = 3.0 * 1.0 / 4.0;
    const double P_n = (1.0 + e) * m_star * 1.0;
    const bool sticks = m_star * slip <= 0.5 * P_n;
    for (const core::ImpactLaw law : kAllLaws) {
      for (const core::SolverMethod method : kAllMethods) {
        SCOPED_TRACE("slip " + std::to_string(slip) + " " + name(law, method));
        const core::CollisionResult r = solveAndCheck(scene, law, method);
        EXPECT_TRUE(allConverged(r));
        const core::ContactImpulse& p = r.impulses[0];
        EXPECT_NEAR(p.normal_impulse, P_n, 1e-12 * P_n);
        // Angular velocities unchanged (no moment).
        EXPECT_LE((r.bodies[0].angular_velocity - scene.bodies[0].angular_velocity).norm(), 1e-14);
        EXPECT_LE((r.bodies[1].angular_velocity - scene.bodies[1].angular_velocity).norm(), 1e-14);
        if (sticks) {
          EXPECT_NEAR(p.friction_impulse.x(), -m_star * slip, 1e-12);
          EXPECT_TRUE(p.sticking);
        } else if (law != core::ImpactLaw::kSeedOnePass) {
          const double expected = 0.4 * P_n;
          const double lower =
              method == core::SolverMethod::kExact ? std::cos(std::acos(-1.0) / 8.0) : 1.0;
          EXPECT_LE(p.friction_impulse.norm(), expected * (1.0 + 1e-12));
          EXPECT_GE(p.friction_impulse.norm(), lower * expected * (1.0 - 1e-12));
        }
        // Three identical contacts: the impulse split is not unique, the velocities are (for
        // frictionless rows; with friction the pyramid split is also non-unique, so only the
        // total normal impulse, which the normal velocity fixes through m*, is compared).
        const core::CollisionResult rr = solveAndCheck(redundant, law, method);
        if (law == core::ImpactLaw::kSeedOnePass) continue;  // sequential: 3 passes differ
        EXPECT_TRUE(allConverged(rr));
        double total = 0.0;
        for (const auto& q : rr.impulses) total += q.normal_impulse;
        EXPECT_NEAR(total, P_n, 1e-9 * P_n);
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// 8, 100 and 1000 nearly coplanar contacts with nearly parallel normals (heights jittered by up
// to 1e-9 m, normals tilted by up to 1e-7 rad): a 1 kg, 1 m x 0.5 m x 0.8 m box lands flat. The
// normal rows are (nearly) linearly dependent: the impulse split is not unique; the velocities
// are (up to the jitter). Frictionless: every law gives v' = (0, e v, 0) and no spin, up to a
// relative 1e-6 (jitter x lever arms x conditioning). With friction and a sliding, spinning
// landing: the properties of checkPhysics. kIterative for all; kAuto must choose exact up to
// kExactSolverMaxContacts and iterative above; kExact for 8 and (frictionless) 100.
core::Scene flatBox(int points, bool friction, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const Eigen::Vector3d size(1.0, 0.5, 0.8);
  core::Scene scene;
  scene.bodies = {
      wall("ground"),
      makeBody("box", 1.0, boxMoments(1.0, size), {0, 0.25, 0}, Eigen::Quaterniond::Identity(),
               friction ? Eigen::Vector3d(1.0, -2.0, 0.5) : Eigen::Vector3d(0, -2, 0),
               friction ? Eigen::Vector3d(0.0, 3.0, 0.0) : Eigen::Vector3d::Zero())};
  for (int k = 0; k < points; ++k) {
    Eigen::Vector3d p;
    if (k < 4) {  // the four corners always
      p = {(k & 1) ? 0.5 : -0.5, 0.0, (k & 2) ? 0.4 : -0.4};
    } else {
      p = {0.5 * unit(rng), 0.0, 0.4 * unit(rng)};
    }
    p.y() = 1e-9 * unit(rng);
    const Eigen::Vector3d n =
        (Eigen::Vector3d::UnitY() + 1e-7 * Eigen::Vector3d(unit(rng), 0, unit(rng))).normalized();
    scene.contacts.push_back(
        makeContact("ground", "box", p, n, 0.5, friction ? 0.6 : 0.0, friction ? 0.5 : 0.0));
  }
  return scene;
}

// Frictional rows with redundant normals leave the friction split undetermined: projected
// Gauss-Seidel keeps moving impulse along that null space and stops at max_iterations with a
// relative impulse change of ~1e-7 (reported not converged, as documented). What must still hold
// there: the physics to a looser tolerance, 1e-6 of the velocity scale (residual 1e-7 x the
// number of rows sharing the body, bounded by the measured values).
void manyContacts(const std::vector<int>& counts, bool friction,
                  const std::vector<core::SolverMethod>& methods) {
  // CR_STRESS_MAX_CONTACTS=<n> (scripts/sanitize.sh: 100) leaves out the larger counts: 100
  // contacts already take kAuto's iterative path (above kExactSolverMaxContacts).
  // The smallest count always runs, whatever the setting.
  const long cap = collision_response::testing::envOr("CR_STRESS_MAX_CONTACTS", 1L << 30);
  for (const int points : counts) {
    if (points > cap && points != counts.front()) continue;
    const core::Scene scene = flatBox(points, friction, 7u + unsigned(points));
    for (const core::ImpactLaw law : kAllLaws) {
      for (const core::SolverMethod method : methods) {
        if (method == core::SolverMethod::kExact && (points > 100 || (points > 8 && friction))) {
          continue;  // Lemke on 1000+ unknowns: out of scope for a unit test's time budget
        }
        SCOPED_TRACE(std::to_string(points) + " points, friction " + std::to_string(friction) +
                     " " + name(law, method));
        const bool pgs =
            law != core::ImpactLaw::kSeedOnePass &&
            (method == core::SolverMethod::kIterative ||
             (method == core::SolverMethod::kAuto && points > int(core::kExactSolverMaxContacts)));
        Tolerances tol;
        if (friction && pgs) {
          tol.check_unconverged = true;
          tol.velocity = tol.cone = 1e-6;
          tol.energy = 1e-8;
        }
        const core::CollisionResult r = solveAndCheck(scene, law, method, tol);
        ASSERT_EQ(r.islands.size(), 1u);
        const core::SolveReport& island = r.islands[0];
        if (method == core::SolverMethod::kAuto && law != core::ImpactLaw::kSeedOnePass) {
          // Few contacts: Newton by the exact solver, Poisson and Stronge by the simultaneous
          // impulse-space integration; many: the iterative solver (two-phase for those two).
          const bool few = points <= int(core::kExactSolverMaxContacts);
          const bool energetic = law != core::ImpactLaw::kNewton;
          const char* expected =
              !few ? "iterative" : (energetic ? "simultaneous_impulse_space" : "exact");
          EXPECT_NE(island.methodName().find(expected), std::string::npos) << island.methodName();
        }
        std::printf("%4d points friction %d %-14s %-9s: %-20s %6zu iterations residual %.2e%s\n",
                    points, int(friction), core::toString(law), core::toString(method),
                    island.methodName().c_str(), island.iterations, island.residual,
                    island.converged ? "" : " NOT CONVERGED");
        if (law == core::ImpactLaw::kSeedOnePass) continue;  // sequential: not the flat answer
        if (!(friction && pgs)) {
          EXPECT_TRUE(island.converged);
        }
        if (!friction) {
          EXPECT_LE((r.bodies[1].linear_velocity - Eigen::Vector3d(0, 1.0, 0)).norm(), 1e-6);
          EXPECT_LE(r.bodies[1].angular_velocity.norm(), 1e-6);
        }
      }
    }
  }
}

TEST(Stress, ManyNearlyCoplanarContactsFrictionless) {
  manyContacts({8, 100, 1000}, false, {kAllMethods[0], kAllMethods[1], kAllMethods[2]});
}

TEST(Stress, ManyNearlyCoplanarContactsWithFriction) {
  manyContacts({8, 100, 1000}, true, {core::SolverMethod::kAuto, core::SolverMethod::kIterative});
}

// OPEN (as DISABLED_MassRatiosUpTo1e12FourCornersExact: Lemke ends on a ray although a solution
// exists; reported converged = false, nothing wrong is returned):
// flatBox(8, true, 15) (1 kg box 1 x 0.5 x 0.8 m at (0, 0.25, 0), v = (1, -2, 0.5),
// w = (0, 3, 0), 8 contacts ground->box with heights and normals jittered by seed 15 through
// std::mt19937, e = 0.5, mu_s = 0.6, mu_d = 0.5) under kPoisson or kStronge with kExact: island
// "two_phase_exact" reported converged = false after 137 pivots (ray termination of a plastic
// frictional LCP that has a solution: kAuto's iterative fallback and the two-phase kAuto path
// solve it). Newton + kExact on the same scene succeeds.
TEST(Stress, DISABLED_ManyNearlyCoplanarContactsWithFrictionExact) {
  manyContacts({8}, true, {core::SolverMethod::kExact});
}

// ---------------------------------------------------------------------------------------------
// A ball squeezed between two immovable walls (x = -R and x = +R) while moving across (along y)
// and slightly towards the left wall. The normal rows are exactly opposite: the Delassus matrix
// [[k, -k], [-k, k]] is singular.
//  - e = 0 (and the plastic phases of Poisson / Stronge): feasible; the normal velocity after is
//    unique (v'_x = 0) but the impulse split is not (any P_right >= 0 with P_left = P_right +
//    m |v_x| works), and with friction neither is the tangential velocity (a larger squeeze
//    brakes more). Property: v'_x = 0, converged, friction in the cone, no energy gain.
//  - e > 0 under Newton: infeasible (bouncing off the left wall means approaching the right
//    one). The exact solver must report not converged and apply nothing (documented); the
//    iterative one cannot converge (its impulses grow every sweep) and must say so. Property:
//    finite, reported not converged.
//  - e > 0 under Poisson / Stronge: the two-phase scheme ends with a plastic solve, so it is
//    feasible: v'_x = 0, converged, no energy gain (Stronge).
TEST(Stress, BallSqueezedBetweenTwoWalls) {
  const double m = 1.0, R = 0.1;
  for (const double e : {0.0, 0.5}) {
    for (const double mu : {0.0, 0.5}) {
      core::Scene scene;
      scene.bodies = {wall("left", {-R, 0, 0}),
                      makeBody("ball", m, Eigen::Vector3d::Constant(0.4 * m * R * R), {0, 0, 0},
                               Eigen::Quaterniond::Identity(), {-0.2, 3.0, 0.0}, {0, 0, 1.0}),
                      wall("right", {R, 0, 0})};
      scene.contacts = {
          makeContact("left", "ball", {-R, 0, 0}, Eigen::Vector3d::UnitX(), e, mu, mu),
          makeContact("right", "ball", {R, 0, 0}, -Eigen::Vector3d::UnitX(), e, mu, mu)};
      for (const core::ImpactLaw law : kAllLaws) {
        for (const core::SolverMethod method : kAllMethods) {
          SCOPED_TRACE("e " + std::to_string(e) + " mu " + std::to_string(mu) + " " +
                       name(law, method));
          const core::CollisionResult r = solveAndCheck(scene, law, method);
          ASSERT_EQ(r.islands.size(), 1u);
          const core::SolveReport& island = r.islands[0];
          std::printf("squeeze e %.1f mu %.1f %-14s %-9s: %-20s %5zu it, vx' %+.3e vy' %+.6f %s\n",
                      e, mu, core::toString(law), core::toString(method),
                      island.methodName().c_str(), island.iterations,
                      r.bodies[1].linear_velocity.x(), r.bodies[1].linear_velocity.y(),
                      island.converged ? "" : "NOT CONVERGED");
          if (law == core::ImpactLaw::kSeedOnePass) continue;  // sequential: no joint property
          const bool infeasible = e > 0.0 && law == core::ImpactLaw::kNewton;
          if (infeasible) {
            EXPECT_FALSE(island.converged);
            if (method == core::SolverMethod::kExact) {
              EXPECT_EQ(r.bodies[1].linear_velocity, scene.bodies[1].linear_velocity);
            }
            continue;
          }
          EXPECT_TRUE(island.converged);
          EXPECT_NEAR(r.bodies[1].linear_velocity.x(), 0.0, 1e-9);
          // The speed across never grows (friction only brakes, walls at rest).
          EXPECT_LE(std::abs(r.bodies[1].linear_velocity.y()), 3.0 * (1.0 + 1e-12));
        }
      }
    }
  }
}

}  // namespace
