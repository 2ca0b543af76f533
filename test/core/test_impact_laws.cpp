// Impact laws on whole scenes through computeResponse(): the cube landing flat, Newton's cradle,
// the rod of docs/physics.md ("Worked examples"), and randomized property tests for every law and
// solver.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <random>

#include "collision_response/core/compute_response.h"
#include "collision_response/core/errors.h"
#include "collision_response/core/island_solver.h"
#include "collision_response/core/option_ranges.h"

#include "scene_builders.h"

namespace core = collision_response::core;
using collision_response::testing::contact;
using collision_response::testing::ground;

namespace {

core::SolverOptions options(core::ImpactLaw law,
                            core::SolverMethod method = core::SolverMethod::kAuto) {
  core::SolverOptions o;
  o.law = law;
  o.method = method;
  return o;
}

const core::ImpactLaw kLaws[] = {core::ImpactLaw::kNewton, core::ImpactLaw::kPoisson,
                                 core::ImpactLaw::kStronge};
const core::SolverMethod kMethods[] = {core::SolverMethod::kAuto, core::SolverMethod::kExact,
                                       core::SolverMethod::kIterative};

// Unit cube, 1 kg, I = 1/6 I3, flat on the ground (normal +y), falling at 1 m/s, 4 corner contacts,
// e = 0.5, frictionless. By symmetry the four normal impulses are equal and there is no torque:
// v' = e * 1 = 0.5 m/s up, no spin. Every law agrees (frictionless, central in sum).
TEST(ImpactLaws, CubeLandingFlatOnFourCornersBouncesWithoutSpin) {
  core::Scene scene;
  core::BodyState cube;
  cube.id = "cube";
  cube.mass = 1.0;
  cube.inertia = Eigen::Matrix3d::Identity() / 6.0;
  cube.position = {0.0, 0.5, 0.0};
  cube.linear_velocity = {0.0, -1.0, 0.0};
  scene.bodies = {ground(), cube};
  for (const double x : {-0.5, 0.5}) {
    for (const double z : {-0.5, 0.5}) {
      scene.contacts.push_back(
          contact("ground", "cube", {x, 0.0, z}, Eigen::Vector3d::UnitY(), 0.5));
    }
  }
  for (const core::ImpactLaw law : kLaws) {
    for (const core::SolverMethod method : kMethods) {
      SCOPED_TRACE(std::string(core::toString(law)) + " " + core::toString(method));
      const core::CollisionResult result = core::computeResponse(scene, options(law, method));
      const core::BodyState& after = result.bodies[1];
      EXPECT_NEAR((after.linear_velocity - Eigen::Vector3d(0.0, 0.5, 0.0)).norm(), 0.0, 1e-9);
      EXPECT_NEAR(after.angular_velocity.norm(), 0.0, 1e-9);
      ASSERT_EQ(result.islands.size(), 1u);
      EXPECT_TRUE(result.islands[0].converged);
      double total = 0.0;
      for (const auto& impulse : result.impulses) total += impulse.normal_impulse;
      EXPECT_NEAR(total, 1.5, 1e-9);  // m (v' - v) = 1.5 N s
    }
  }
}

// Newton's cradle of three equal balls in a row, the first moving at v into the two at rest, e = 1,
// frictionless. A simultaneous law solves both contacts at once. Newton: with both contacts active,
// u'_12 = v and u'_23 = 0 give impulses 4/3 m v and 2/3 m v, so the balls leave at (-1/3, 2/3, 2/3)
// v. Poisson (and the two-phase scheme for both laws): compression to a common velocity v/3 with
// impulses 2/3 and 1/3 m v, then restitution doubles them: the same (-1/3, 2/3, 2/3) v. Stronge
// integrated simultaneously (the default for Poisson and Stronge under kAuto; by hand in
// test_simultaneous_impact, "(6)"): the second contact did no compression work, so it has none to
// release and ends at once; the first releases its 1/3 alone, ball 2 then strikes ball 3 as a new
// cycle: (1/3 - 1/sqrt(3), 1/3, 1/3 + 1/sqrt(3)) v. Energy conserved in every case (e = 1). The
// cradle's real (0, 0, v) needs the impact to travel ball to ball (a sequential law); the
// simultaneous answer is what this package returns.
TEST(ImpactLaws, NewtonsCradleGivesTheSimultaneousAnswer) {
  core::Scene scene;
  for (int i = 0; i < 3; ++i) {
    core::BodyState ball;
    ball.id = "ball" + std::to_string(i);
    ball.mass = 1.0;
    ball.inertia = Eigen::Matrix3d::Identity() * 0.004;
    ball.position = {0.2 * i, 0.0, 0.0};
    scene.bodies.push_back(ball);
  }
  scene.bodies[0].linear_velocity = {1.0, 0.0, 0.0};
  scene.contacts = {contact("ball0", "ball1", {0.1, 0, 0}, Eigen::Vector3d::UnitX(), 1.0),
                    contact("ball1", "ball2", {0.3, 0, 0}, Eigen::Vector3d::UnitX(), 1.0)};
  for (const core::ImpactLaw law : kLaws) {
    for (const core::SolverMethod method : kMethods) {
      SCOPED_TRACE(std::string(core::toString(law)) + " " + core::toString(method));
      const core::CollisionResult result = core::computeResponse(scene, options(law, method));
      const bool integrated =
          law == core::ImpactLaw::kStronge && method == core::SolverMethod::kAuto;
      const double a = 1.0 / std::sqrt(3.0);
      const Eigen::Vector3d want = integrated
                                       ? Eigen::Vector3d(1.0 / 3.0 - a, 1.0 / 3.0, 1.0 / 3.0 + a)
                                       : Eigen::Vector3d(-1.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0);
      for (int i = 0; i < 3; ++i) {
        EXPECT_NEAR(result.bodies[i].linear_velocity.x(), want[i], 1e-9) << "ball " << i;
      }
      EXPECT_NEAR(result.kinetic_energy_after, result.kinetic_energy_before, 1e-9);
    }
  }
}

// The rod of docs/physics.md, "Worked examples" (scenes.h) on a rough floor, mu 0.8. Newton gains
// energy (ratio about 1.056 at e = 0.9, 1.172 at e = 1); Stronge never does and the tip separates.
core::Scene rodScene(double e) {
  return collision_response::testing::rodScene(e, 0.8, 0.8);
}

TEST(ImpactLaws, RodOnRoughFloorGainsEnergyUnderNewtonButNotStronge) {
  for (const double e : {0.9, 1.0}) {
    SCOPED_TRACE(e);
    const core::Scene scene = rodScene(e);
    const auto newton = core::computeResponse(scene, options(core::ImpactLaw::kNewton));
    const double newton_ratio = newton.kinetic_energy_after / newton.kinetic_energy_before;
    EXPECT_GT(newton_ratio, 1.0) << "Newton + Coulomb is expected to create energy here";
    const auto stronge = core::computeResponse(scene, options(core::ImpactLaw::kStronge));
    const double stronge_ratio = stronge.kinetic_energy_after / stronge.kinetic_energy_before;
    EXPECT_LE(stronge_ratio, 1.0 + 1e-12);
    EXPECT_GE(stronge.impulses[0].normal_velocity_after, 0.0);
    EXPECT_EQ(stronge.islands[0].methodName(), "impulse_space");
    const auto poisson = core::computeResponse(scene, options(core::ImpactLaw::kPoisson));
    const double poisson_ratio = poisson.kinetic_energy_after / poisson.kinetic_energy_before;
    std::printf("rod e = %.1f: kinetic energy ratio Newton %.6f, Poisson %.6f, Stronge %.6f\n", e,
                newton_ratio, poisson_ratio, stronge_ratio);
    // The rod stays in the x-z plane.
    EXPECT_NEAR(stronge.bodies[1].linear_velocity.y(), 0.0, 1e-12);
  }
}

// Random scenes: a few bodies (some immovable), several contacts between random pairs, random
// off-centre points and normals, frictional. Properties every law must keep: finite results; linear
// momentum conserved when no body is immovable; no active contact approaching after (u'_n >= -e u_n
// for Newton, >= 0 for Poisson / Stronge, up to the solver tolerance); impulses in the friction
// cone (the exact solver's pyramid lies inside it). Under Stronge, kinetic energy never increases.
struct RandomScene {
  core::Scene scene;
  bool any_immovable = false;
};

RandomScene randomScene(std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0), positive(0.2, 2.0), coefficient(0.0, 1.0);
  RandomScene out;
  const int bodies = 2 + static_cast<int>(rng() % 3);
  for (int i = 0; i < bodies; ++i) {
    core::BodyState body;
    body.id = "b" + std::to_string(i);
    if (i > 0 || rng() % 2 == 0) {
      body.mass = positive(rng);
      const double x = positive(rng), y = positive(rng);
      const double z = std::abs(x - y) + (x + y - std::abs(x - y)) * coefficient(rng);
      body.inertia = Eigen::Vector3d(x, y, z).asDiagonal();
    } else {
      out.any_immovable = true;
    }
    body.orientation = Eigen::Quaterniond(unit(rng), unit(rng), unit(rng), unit(rng)).normalized();
    body.position = Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    // An immovable body stays at rest: one with a prescribed velocity (a bat) may add energy.
    if (!body.immovable()) {
      body.linear_velocity = Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
      body.angular_velocity = Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    }
    out.scene.bodies.push_back(body);
  }
  const int contacts = 1 + static_cast<int>(rng() % 5);
  for (int c = 0; c < contacts; ++c) {
    int a = static_cast<int>(rng() % bodies), b = static_cast<int>(rng() % bodies);
    if (a == b) b = (a + 1) % bodies;
    if (out.scene.bodies[a].immovable() && out.scene.bodies[b].immovable()) continue;
    const double mu_s = 1.2 * coefficient(rng);
    out.scene.contacts.push_back(
        contact(out.scene.bodies[a].id, out.scene.bodies[b].id,
                Eigen::Vector3d(unit(rng), unit(rng), unit(rng)),
                Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized(), coefficient(rng),
                mu_s, mu_s * coefficient(rng)));
  }
  return out;
}

Eigen::Vector3d linearMomentum(const std::vector<core::BodyState>& bodies) {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (const auto& body : bodies) p += body.mass * body.linear_velocity;
  return p;
}

TEST(ImpactLaws, RandomScenesKeepMomentumConeSeparationAndStrongeEnergy) {
  const unsigned seed = 20261122;
  std::mt19937 rng(seed);
  int solved = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const RandomScene random = randomScene(rng);
    for (const core::ImpactLaw law : kLaws) {
      for (const core::SolverMethod method : kMethods) {
        core::SolverOptions o = options(law, method);
        o.tolerance = 1e-13;
        // The physics is under test here, not the time budget (SolverLimits tests that): under
        // sanitizers on a loaded machine a hard iterative scene can take longer than the 1 s
        // default.
        o.time_budget = 3600.0;
        const core::CollisionResult result = core::computeResponse(random.scene, o);
        const std::string trace = "seed " + std::to_string(seed) + " trial " +
                                  std::to_string(trial) + " law " + core::toString(law) +
                                  " method " + core::toString(method);
        SCOPED_TRACE(trace);
        bool converged = true;
        for (const auto& island : result.islands) converged = converged && island.converged;
        if (!converged) continue;  // counted below: most must converge
        ++solved;
        const double scale = 1.0 + result.kinetic_energy_before;
        for (const auto& body : result.bodies) {
          ASSERT_TRUE(body.linear_velocity.allFinite() && body.angular_velocity.allFinite());
        }
        if (!random.any_immovable) {
          const Eigen::Vector3d p0 = linearMomentum(random.scene.bodies);
          ASSERT_NEAR((linearMomentum(result.bodies) - p0).norm(), 0.0, 1e-8 * (1.0 + p0.norm()));
        }
        for (std::size_t c = 0; c < result.impulses.size(); ++c) {
          const auto& impulse = result.impulses[c];
          const auto& spec = random.scene.contacts[c];
          ASSERT_GE(impulse.normal_impulse, -1e-12);
          ASSERT_LE(impulse.friction_impulse.norm(), spec.static_friction * impulse.normal_impulse +
                                                         1e-9 * (1.0 + impulse.normal_impulse));
          const double floor =
              law == core::ImpactLaw::kNewton
                  ? -spec.restitution * std::min(impulse.normal_velocity_before, 0.0)
                  : 0.0;
          ASSERT_GE(impulse.normal_velocity_after,
                    floor - 1e-7 * (1.0 + std::abs(impulse.normal_velocity_before)))
              << "contact " << c << " still approaching";
        }
        if (law == core::ImpactLaw::kStronge) {
          ASSERT_LE(result.kinetic_energy_after, result.kinetic_energy_before + 1e-9 * scale);
        }
      }
    }
  }
  EXPECT_GT(solved, 3000 * 9 * 95 / 100) << "too many scenes did not converge";
}

}  // namespace

namespace {

// A row of n frictional spheres, the first moving into the rest: one island of n - 1 contacts.
core::Scene sphereRow(int n) {
  core::Scene scene;
  for (int i = 0; i < n; ++i) {
    core::BodyState ball;
    ball.id = "ball" + std::to_string(i);
    ball.mass = 1.0;
    ball.inertia = Eigen::Matrix3d::Identity() * 0.004;
    ball.position = {0.2 * i, 0.0, 0.0};
    scene.bodies.push_back(ball);
    if (i > 0) {
      scene.contacts.push_back(contact(scene.bodies[i - 1].id, ball.id, {0.2 * i - 0.1, 0.0, 0.0},
                                       Eigen::Vector3d::UnitX(), 0.5, 0.3, 0.2));
    }
  }
  scene.bodies[0].linear_velocity = {1.0, 0.0, 0.3};
  return scene;
}

// A solve that cannot finish in its time budget is an error, not a hang: a tolerance of 0 is never
// met and the iteration cap (the largest accepted, 1e8 sweeps of 300 contacts) is out of reach, so
// only the 10 ms budget stops it.
TEST(SolverLimits, TimeBudgetStopsAnEndlessSolve) {
  core::SolverOptions o = options(core::ImpactLaw::kNewton, core::SolverMethod::kIterative);
  o.tolerance = 0.0;
  o.max_iterations = static_cast<std::size_t>(core::option_ranges::kMaxIterations.max);
  o.time_budget = 0.01;
  EXPECT_THROW(core::computeResponse(sphereRow(300), o), core::SolverTimeout);
}

// The exact solver's dense tableau grows with the square of the contacts: asking it for an island
// beyond its limit is a clear error on options.solver; the automatic choice iterates instead.
TEST(SolverLimits, ExactSolverRefusesOversizedIslands) {
  const core::Scene scene = sphereRow(static_cast<int>(core::kExactSolverContactLimit) + 2);
  try {
    core::computeResponse(scene, options(core::ImpactLaw::kNewton, core::SolverMethod::kExact));
    FAIL() << "expected InvalidInput";
  } catch (const core::InvalidInput& e) {
    EXPECT_EQ(e.field(), "options.solver");
  }
  core::SolverOptions automatic = options(core::ImpactLaw::kNewton);
  automatic.time_budget = 600.0;  // not a speed test (sanitizer builds are slow)
  const auto result = core::computeResponse(scene, automatic);
  EXPECT_EQ(result.islands[0].methodName(), "iterative");
}

}  // namespace

// The two-phase scheme under Stronge (multi_contact two_phase): a contact struck along its normal
// (no initial slip) that sticks keeps its whole restitution. Its compression stops it (u_c = 0,
// impulse P_c = -K^-1 u); restitution applies e P_c,n n, and the friction that keeps it stuck is
// then e T_c (linearity, u_t = 0 before), so the phase releases exactly
// (1/2) e^2 P_c^T K P_c = e^2 D_c: the energy bound holds with equality, needs no scaling, and the
// contact leaves with u' = -e u (closed form). A second contact of the
// island, on the body's far side and separating fast, takes nothing. Random boxes, points and
// approaches; the bound's comparison is then decided by round-off, which used to scale the
// restitution down by the normal impulses' quadratic (about 1 % too little here, 3e-2 rad/s in a
// robot's joints) in some of them.
TEST(ImpactLaws, TwoPhaseStrongeKeepsTheFullRestitutionOfAContactStickingThroughIt) {
  std::mt19937 rng(41);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int checked = 0;
  for (int trial = 0; trial < 200; ++trial) {
    core::RigidBody box;
    box.inverse_mass = 1.0 / (1.0 + 0.5 * (u(rng) + 1.0));
    const Eigen::Matrix3d rotation =
        Eigen::AngleAxisd(3.0 * u(rng), Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized())
            .matrix();
    const Eigen::Vector3d inertia(0.1 + 0.05 * u(rng), 0.2 + 0.1 * u(rng), 0.15 + 0.1 * u(rng));
    box.inverse_inertia = rotation * inertia.cwiseInverse().asDiagonal() * rotation.transpose();
    box.com = Eigen::Vector3d(0.0, 0.0, 0.5);
    box.angular_velocity = Eigen::Vector3d(u(rng), u(rng), u(rng));
    const Eigen::Vector3d p0(0.3 * u(rng), 0.3 * u(rng), 0.0);
    // A normal strike: p0 moves straight down.
    box.linear_velocity =
        Eigen::Vector3d(0.0, 0.0, -1.0 + 0.2 * u(rng)) - box.angular_velocity.cross(p0 - box.com);
    // The far side, 1 m from the centre across the axis through p0, about which the box also
    // spins at 8 rad/s (p0's velocity unchanged): the normal there is that point's velocity, so
    // that it separates at 8 m/s.
    const Eigen::Vector3d axis = (p0 - box.com).normalized();
    box.angular_velocity += 8.0 * axis;
    const Eigen::Vector3d p1 = box.com + axis.unitOrthogonal();
    const Eigen::Vector3d v1 = box.pointVelocity(p1 - box.com);
    std::vector<core::RigidBody> bodies = {core::RigidBody(), box};  // ground: immovable
    const double e = 0.2 + 0.6 * (u(rng) + 1.0) / 2.0;
    std::vector<core::ContactPoint> contacts = {
        core::ContactPoint(0, 1, p0, Eigen::Vector3d::UnitZ(), e, 10.0, 10.0),
        core::ContactPoint(0, 1, p1, v1.normalized(), e, 10.0, 10.0)};
    const Eigen::Vector3d u0 = bodies[1].pointVelocity(p0 - box.com);  // b (box) minus a (ground)
    ASSERT_LT(u0.z(), 0.0) << trial;
    core::SolverOptions o = options(core::ImpactLaw::kStronge);
    o.simultaneous_impulse_space = false;
    std::vector<core::ContactImpulse> impulses(2);
    const core::SolveReport report = core::solveIsland(bodies, contacts, {0, 1}, o, impulses);
    ASSERT_EQ(report.methodName(), "two_phase_exact") << trial;
    ASSERT_EQ(impulses[1].normal_impulse, 0.0) << trial;
    const Eigen::Vector3d u0_after = bodies[1].pointVelocity(p0 - box.com);
    EXPECT_LE((u0_after + e * u0).norm(), 1e-9 * u0.norm())
        << trial << ": u " << u0.transpose() << " u' " << u0_after.transpose() << " e " << e;
    ++checked;
  }
  EXPECT_EQ(checked, 200);
}
