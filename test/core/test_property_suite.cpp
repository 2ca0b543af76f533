// Randomized property suite for computeResponse(): at least 100,000 random scenes (1-4 movable
// bodies plus 0-2 immovable ones at rest, 1-6 contacts at random off-centre points with random
// normals, e, mu_s >= mu_d, random laws and methods), each checked for physical validity with the
// same checks as test_stress.cpp: finite; impulse-momentum consistency per body (and momentum
// conservation without immovable bodies); in islands reported converged: P_n >= 0, friction in
// the static cone, no contact left approaching (u'_n >= -e u_n for Newton, >= 0 for Poisson and
// Stronge; not checked for the two-pass seed_one_pass law, documented to break it); no kinetic
// energy gain under Stronge. Islands not converged are counted; their share must stay small.
//
// Reproducible: scene i is drawn from std::mt19937 seeded with seed_seq{seed, i}; a failure
// prints the seed, the index, law, method and the whole scene at full precision. Replay one
// scene with CR_PROPERTY_SEED=<seed> CR_PROPERTY_SCENE=<i>; CR_PROPERTY_SCENES=<n> changes n.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <chrono>
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
#include "collision_response/core/errors.h"
#include "collision_response/core/rigid_body.h"
#include "env_number.h"
#include "physics_checks.h"

namespace core = collision_response::core;

namespace {

core::Scene randomScene(std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0), u01(0.0, 1.0);
  auto logUniform = [&](double lo, double hi) {
    return std::exp(std::log(lo) + (std::log(hi) - std::log(lo)) * u01(rng));
  };
  auto randomUnit = [&]() {
    Eigen::Vector3d v;
    do {
      v = Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    } while (v.norm() < 0.1 || v.norm() > 1.0);
    return Eigen::Vector3d(v.normalized());
  };
  core::Scene scene;
  const int movable = 1 + int(rng() % 4);
  const int immovable = movable == 1 ? 1 + int(rng() % 2) : int(rng() % 3);
  for (int i = 0; i < movable + immovable; ++i) {
    core::BodyState body;
    body.id = "b" + std::to_string(i);
    body.position = Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    body.orientation = Eigen::Quaterniond(unit(rng), unit(rng), unit(rng), unit(rng)).normalized();
    if (i < movable) {
      body.mass = logUniform(1e-2, 1e2);
      // Principal moments from a box of random size (triangle inequality by construction).
      const Eigen::Vector3d size(logUniform(0.05, 1.0), logUniform(0.05, 1.0),
                                 logUniform(0.05, 1.0));
      const Eigen::Vector3d s2 = size.cwiseProduct(size);
      body.inertia =
          (body.mass / 12.0 * Eigen::Vector3d(s2.y() + s2.z(), s2.x() + s2.z(), s2.x() + s2.y()))
              .asDiagonal();
      if (rng() % 4 == 0) body.com = 0.1 * Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
      const double speed = logUniform(1e-2, 1e1);
      body.linear_velocity = speed * Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
      body.angular_velocity = speed * Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    }
    scene.bodies.push_back(body);
  }
  const int bodies = movable + immovable;
  const int contacts = 1 + int(rng() % 6);
  for (int c = 0; c < contacts; ++c) {
    const int a = int(rng() % bodies);
    int b = int(rng() % bodies);
    if (a == b) b = (a + 1) % bodies;
    if (scene.bodies[a].immovable() && scene.bodies[b].immovable()) b = int(rng() % movable);
    if (a == b) continue;
    core::Contact contact;
    contact.body_a = scene.bodies[a].id;
    contact.body_b = scene.bodies[b].id;
    // A point between the two bodies, off both centres of mass.
    const double t = u01(rng);
    contact.point = (1.0 - t) * scene.bodies[a].worldCom() + t * scene.bodies[b].worldCom() +
                    0.3 * Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    contact.normal = randomUnit();
    const unsigned kind = rng() % 10;
    contact.restitution = kind == 0 ? 0.0 : kind == 1 ? 1.0 : u01(rng);
    const unsigned friction = rng() % 5;
    if (friction > 0) {
      contact.static_friction = 1.2 * u01(rng);
      contact.dynamic_friction =
          friction == 1 ? contact.static_friction : contact.static_friction * u01(rng);
    }
    scene.contacts.push_back(contact);
  }
  return scene;
}

using collision_response::testing::envOr;

std::string replay(unsigned long seed, long index, core::ImpactLaw law, core::SolverMethod method) {
  return "seed " + std::to_string(seed) + " scene " + std::to_string(index) + " law " +
         core::toString(law) + " method " + core::toString(method) +
         " (replay: CR_PROPERTY_SEED=" + std::to_string(seed) +
         " CR_PROPERTY_SCENE=" + std::to_string(index) + ")";
}

void runSuite(long default_count, long minimum_scenes) {
  const unsigned long seed = static_cast<unsigned long>(envOr("CR_PROPERTY_SEED", 20261122));
  const long only = envOr("CR_PROPERTY_SCENE", -1);
  const long count = envOr("CR_PROPERTY_SCENES", default_count);
  // Separation to 1e-7 of the velocity scale: the two-phase exact scheme chains three solves whose
  // Lemke tolerance is 1e-12 x max |q| with pivoting on Delassus matrices of spread up to ~1e4
  // (masses 1e-2..1e2 kg, lever arms to ~1 m); observed residuals reach 1.1e-8 (scene 29833 with
  // 1e-9 failed at -9.2e-8 m/s for a scale of 26 m/s). The Lemke failures this suite found are
  // off by O(1) or more. Iterative islands get the PGS allowance of checkPhysics() on top.
  Tolerances tol;
  tol.velocity = 1e-7;
  const auto start = std::chrono::steady_clock::now();
  long scenes = 0, failures = 0, islands = 0, impact_islands = 0, not_converged = 0;
  std::map<std::string, long> not_converged_by_method;
  for (long i = only >= 0 ? only : 0; i < (only >= 0 ? only + 1 : count); ++i) {
    std::seed_seq seq{static_cast<unsigned>(seed), static_cast<unsigned>(seed >> 32),
                      static_cast<unsigned>(i)};
    std::mt19937 rng(seq);
    const core::Scene scene = randomScene(rng);
    const core::ImpactLaw law = kAllLaws[rng() % 4];
    const core::SolverMethod method = kAllMethods[rng() % 3];
    const core::SolverOptions o = options(law, method);
    core::CollisionResult result;
    try {
      result = core::computeResponse(scene, o);
    } catch (const std::exception& error) {
      ADD_FAILURE() << replay(seed, i, law, method) << ": threw " << error.what() << "\n"
                    << describe(scene);
      ++failures;
      continue;
    }
    ++scenes;
    const CheckResult check = checkPhysics(scene, o, result, tol);
    islands += check.islands;
    not_converged += check.not_converged;
    for (const auto& island : result.islands) {
      if (!isImpactIsland(result, island)) continue;
      ++impact_islands;
      if (!island.converged) ++not_converged_by_method[island.methodName()];
    }
    if (!check.ok()) {
      ++failures;
      if (failures <= 20) {
        ADD_FAILURE() << replay(seed, i, law, method) << ":\n"
                      << check.text() << "scene:\n"
                      << describe(scene);
      }
    }
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf(
      "property suite: %ld scenes checked in %.1f s (seed %lu), %ld islands (%ld impact), "
      "%ld not converged (%.3f%% of impact islands), %ld scenes failed\n",
      scenes, seconds, seed, islands, impact_islands, not_converged,
      impact_islands > 0 ? 100.0 * not_converged / impact_islands : 0.0, failures);
  for (const auto& [method, n] : not_converged_by_method) {
    std::printf("  not converged, method %s: %ld\n", method.c_str(), n);
  }
  EXPECT_EQ(failures, 0);
  if (only < 0) {
    EXPECT_GE(scenes,
              std::min(minimum_scenes, count * 2 / 3));  // fewer when CR_PROPERTY_SCENES asks
    // Non-convergence is allowed only where reported, and must stay rare. Random normals at
    // random points often wedge a body (infeasible Newton problems: exact reports no solution,
    // PGS hits its cap) and redundant frictional rows make PGS drift: measured 1.9% of impact
    // islands for seed 20261122 (mostly two_phase_iterative and iterative). Bound: 3%.
    // (Newton through Lemke alone: 3.4% measured, wedged bodies being infeasible for e > 0; 5%.)
    const long percent = 3;
    EXPECT_LE(not_converged, percent * impact_islands / 100)
        << "more than " << percent << "% of impact islands not converged";
  }
}

// Every law and method except Newton through Lemke's method: >= 100,000 scenes.
// Every law and method. (Newton through the exact solver used to be held out: Lemke's path could
// lose feasibility and still report "solved"; lcp.cpp now tracks z0's row, judges ratio ties on
// the right scale, and checks the answer before calling it solved.)
TEST(PropertySuite, RandomScenesArePhysicallyValid) {
  runSuite(150000, 100000);
}

}  // namespace
