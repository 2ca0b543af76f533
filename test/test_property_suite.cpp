// Randomized property suite for computeResponse(): at least 100,000 random scenes (1-4 movable
// bodies plus 0-2 immovable ones at rest, 1-6 contacts at random off-centre points with random
// normals, e, mu_s >= mu_d, random laws and methods), each checked for physical validity with the
// same checks as test_stress.cpp: finite; impulse-momentum consistency per body (and momentum
// conservation without immovable bodies); in islands reported converged: P_n >= 0, friction in
// the static cone, no contact left approaching (u'_n >= -e u_n for Newton, >= 0 for Poisson and
// Stronge; not checked for the seed's one-pass law, documented to break it); no kinetic energy
// gain under Stronge. Islands not converged are counted; their share must stay small.
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

#include "collision_response/collision_solver.h"
#include "collision_response/contact_space.h"
#include "collision_response/errors.h"
#include "collision_response/rigid_body.h"

namespace core = collision_response::core;

namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();

const core::ImpactLaw kAllLaws[] = {core::ImpactLaw::kNewton, core::ImpactLaw::kSeedOnePass,
                                    core::ImpactLaw::kPoisson, core::ImpactLaw::kStronge};
const core::SolverMethod kAllMethods[] = {core::SolverMethod::kAuto, core::SolverMethod::kExact,
                                          core::SolverMethod::kIterative};

core::SolverOptions options(core::ImpactLaw law, core::SolverMethod method) {
  core::SolverOptions o;
  o.law = law;
  o.method = method;
  o.time_budget = 600.0;  // validity, not speed, is tested here: never depend on the machine's load
  return o;
}

// Full-precision dump, so that a failing scene can be replayed.
std::string describe(const core::Scene& scene) {
  std::ostringstream out;
  out.precision(17);
  for (const auto& b : scene.bodies) {
    out << "body " << b.id << " m=" << b.mass << " I=[" << b.inertia.row(0) << "; "
        << b.inertia.row(1) << "; " << b.inertia.row(2) << "] com=(" << b.com.transpose()
        << ") pos=(" << b.position.transpose() << ") q(wxyz)=(" << b.orientation.w() << " "
        << b.orientation.x() << " " << b.orientation.y() << " " << b.orientation.z() << ") v=("
        << b.linear_velocity.transpose() << ") w=(" << b.angular_velocity.transpose() << ")\n";
  }
  for (const auto& c : scene.contacts) {
    out << "contact " << c.body_a << "->" << c.body_b << " p=(" << c.point.transpose() << ") n=("
        << c.normal.transpose() << ") e=" << c.restitution << " mu_s=" << c.static_friction
        << " mu_d=" << c.dynamic_friction << "\n";
  }
  return out.str();
}

// Relative tolerances of checkPhysics(), all dimensionless.
struct Tolerances {
  // Impulse-momentum consistency: relative to the momentum scale of the body, m (|v| + |v'|) +
  // sum |J|. Every operation is a few flops on these magnitudes; iterative solvers accumulate
  // round-off over many sweeps, hence far above eps.
  double momentum = 1e-10;
  // Kinetic energy gain under Stronge: relative to the kinetic energy before plus the magnitudes
  // of the per-body energy changes.
  double energy = 1e-10;
  // u'_n (Newton: u'_n + e u_n) >= -velocity x (velocity scale at the contact).
  double velocity = 1e-9;
  // |P_t| <= mu_s P_n + cone x |P|.
  double cone = 1e-9;
  // Also apply the cone / separation / energy checks to islands reported not converged (used with
  // looser tolerances where an iterative solver stops at its cap with a small residual).
  bool check_unconverged = false;
};

struct CheckResult {
  std::vector<std::string> failures;
  int islands = 0;
  int not_converged = 0;
  bool ok() const { return failures.empty(); }
  std::string text() const {
    std::string s;
    for (const auto& f : failures) s += "  " + f + "\n";
    return s;
  }
};

bool isImpactIsland(const core::CollisionResult& r, const core::IslandReport& island) {
  for (const int c : island.contacts) {
    if (r.impulses[c].normal_velocity_before < 0.0) return true;
  }
  return false;
}

// Newton's closed form returns the sticking impulse outside the cone when the sliding impulse
// would drive the contact deeper (documented in single_contact.h). True if that is the case here.
bool painleveCase(const core::Scene& scene, const std::map<std::string, int>& index,
                  const core::Contact& c) {
  const core::RigidBody a = core::makeRigidBody(scene.bodies[index.at(c.body_a)]);
  const core::RigidBody b = core::makeRigidBody(scene.bodies[index.at(c.body_b)]);
  const core::ContactSpace space(a, b, c.point);
  const Eigen::Vector3d n = c.normal.normalized();
  const Eigen::Vector3d u = space.relativeVelocity(a, b);
  const double u_n = u.dot(n);
  const Eigen::Vector3d P = space.K.inverse() * (-(1.0 + c.restitution) * u_n * n - (u - u_n * n));
  const Eigen::Vector3d P_t = P - P.dot(n) * n;
  if (P_t.norm() == 0.0) return false;
  return !(n.dot(space.K * (n + c.dynamic_friction / P_t.norm() * P_t)) > 0.0);
}

// The physical validity checks of the brief:
//  - every number finite;
//  - for each movable body, m (v' - v) = sum of the impulses on it and Iw (w' - w) = sum of their
//    moments (this holds with or without immovable bodies); with no immovable body, total linear
//    momentum is conserved;
//  - in islands the solver reports converged, where something approached (an impact island):
//    P_n >= 0, |P_t| <= mu_s P_n, and no contact left approaching: u'_n >= 0 (Poisson, Stronge) or
//    u'_n >= -e u_n (Newton; 0 for contacts that were not approaching). The seed's one-pass law is
//    documented to break the restitution law off-centre, so only its cone is checked;
//  - under Stronge, with immovable bodies at rest, kinetic energy does not increase.
CheckResult checkPhysics(const core::Scene& scene, const core::SolverOptions& o,
                         const core::CollisionResult& r, const Tolerances& tol = Tolerances()) {
  CheckResult out;
  auto fail = [&](const std::string& s) { out.failures.push_back(s); };
  std::map<std::string, int> index;
  for (std::size_t i = 0; i < scene.bodies.size(); ++i) index[scene.bodies[i].id] = int(i);
  if (r.bodies.size() != scene.bodies.size() || r.impulses.size() != scene.contacts.size()) {
    fail("result sizes differ from the scene");
    return out;
  }
  bool finite = std::isfinite(r.kinetic_energy_before) && std::isfinite(r.kinetic_energy_after);
  for (const auto& b : r.bodies) {
    finite = finite && b.linear_velocity.allFinite() && b.angular_velocity.allFinite();
  }
  for (const auto& p : r.impulses) {
    finite = finite && std::isfinite(p.normal_impulse) && p.friction_impulse.allFinite() &&
             std::isfinite(p.normal_velocity_before) && std::isfinite(p.normal_velocity_after) &&
             std::isfinite(p.normal_force) && p.friction_force.allFinite();
  }
  if (!finite) {
    fail("non-finite number in the result");
    return out;
  }

  // Impulse-momentum consistency per movable body.
  bool any_immovable = false, immovable_at_rest = true;
  for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
    const core::BodyState& before = scene.bodies[i];
    const core::BodyState& after = r.bodies[i];
    if (before.immovable()) {
      any_immovable = true;
      immovable_at_rest = immovable_at_rest && before.linear_velocity.isZero(0.0) &&
                          before.angular_velocity.isZero(0.0);
      if (after.linear_velocity != before.linear_velocity ||
          after.angular_velocity != before.angular_velocity) {
        fail("immovable body " + before.id + " changed velocity");
      }
      continue;
    }
    Eigen::Vector3d J = Eigen::Vector3d::Zero(), L = Eigen::Vector3d::Zero();
    double J_scale = 0.0, L_scale = 0.0;
    const Eigen::Vector3d com = before.worldCom();
    for (std::size_t c = 0; c < scene.contacts.size(); ++c) {
      const core::Contact& contact = scene.contacts[c];
      const double sign = contact.body_b == before.id   ? 1.0
                          : contact.body_a == before.id ? -1.0
                                                        : 0.0;
      if (sign == 0.0) continue;
      const Eigen::Vector3d P = sign * r.impulses[c].total(contact.normal.normalized());
      J += P;
      L += (contact.point - com).cross(P);
      J_scale += P.norm();
      L_scale += (contact.point - com).norm() * P.norm();
    }
    const double m = before.mass;
    const double dp_error = (m * (after.linear_velocity - before.linear_velocity) - J).norm();
    const double dp_scale =
        m * (before.linear_velocity.norm() + after.linear_velocity.norm()) + J_scale;
    if (!(dp_error <= tol.momentum * dp_scale)) {
      std::ostringstream s;
      s << "body " << before.id << ": m dv - sum J = " << dp_error << " (scale " << dp_scale << ")";
      fail(s.str());
    }
    const Eigen::Matrix3d R = before.orientation.normalized().toRotationMatrix();
    const Eigen::Matrix3d inverse_inertia = R * before.inertia.inverse() * R.transpose();
    const Eigen::Vector3d dw = after.angular_velocity - before.angular_velocity;
    const double dw_error = (dw - inverse_inertia * L).norm();
    const double dw_scale = before.angular_velocity.norm() + after.angular_velocity.norm() +
                            inverse_inertia.norm() * L_scale;
    if (!(dw_error <= tol.momentum * dw_scale)) {
      std::ostringstream s;
      s << "body " << before.id << ": dw - Iw^-1 sum r x J = " << dw_error << " (scale " << dw_scale
        << ")";
      fail(s.str());
    }
  }
  if (!any_immovable) {
    Eigen::Vector3d p0 = Eigen::Vector3d::Zero(), p1 = Eigen::Vector3d::Zero();
    double scale = 0.0;
    for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
      p0 += scene.bodies[i].mass * scene.bodies[i].linear_velocity;
      p1 += r.bodies[i].mass * r.bodies[i].linear_velocity;
      scale += scene.bodies[i].mass *
               (scene.bodies[i].linear_velocity.norm() + r.bodies[i].linear_velocity.norm());
    }
    if (!((p1 - p0).norm() <= tol.momentum * scale)) {
      std::ostringstream s;
      s << "linear momentum changed by " << (p1 - p0).norm() << " (scale " << scale << ")";
      fail(s.str());
    }
  }

  // Per island: cone and separation where the solver reports convergence.
  bool all_converged = true;
  for (const auto& island : r.islands) {
    ++out.islands;
    if (!island.converged) {
      ++out.not_converged;
      if (!tol.check_unconverged) {
        all_converged = false;
        continue;
      }
    }
    if (!isImpactIsland(r, island)) continue;
    // Projected Gauss-Seidel stops when the last sweep changed no impulse by more than
    // options.tolerance x the island's LARGEST impulse, so a contact on a light body, whose own
    // impulses are much smaller, keeps a velocity residual up to ~ tolerance x P_max x n^T K n
    // (x the number of rows coupling it): allowed below, with a factor 100.
    double P_max = 0.0;
    for (const int c : island.contacts) {
      P_max = std::max(
          P_max, std::hypot(r.impulses[c].normal_impulse, r.impulses[c].friction_impulse.norm()));
    }
    const bool pgs = island.method.find("iterative") != std::string::npos;
    for (const int c : island.contacts) {
      const core::Contact& contact = scene.contacts[c];
      const core::ContactImpulse& p = r.impulses[c];
      const Eigen::Vector3d n = contact.normal.normalized();
      const double P = std::hypot(p.normal_impulse, p.friction_impulse.norm());
      std::ostringstream where;
      where.precision(17);
      where << "contact " << c << " (island method " << island.method << "): ";
      if (std::abs(p.friction_impulse.dot(n)) > 1e-9 * P) {
        fail(where.str() + "friction impulse not tangential");
      }
      const bool painleve = o.law == core::ImpactLaw::kNewton && island.method == "closed_form" &&
                            p.sticking && painleveCase(scene, index, contact);
      if (!painleve) {
        if (!(p.normal_impulse >= -tol.cone * P)) {
          where << "normal impulse " << p.normal_impulse << " < 0";
          fail(where.str());
          continue;
        }
        if (!(p.friction_impulse.norm() <=
              contact.static_friction * p.normal_impulse + tol.cone * P)) {
          where << "friction " << p.friction_impulse.norm()
                << " outside the cone mu_s P_n = " << contact.static_friction * p.normal_impulse;
          fail(where.str());
        }
      }
      if (o.law == core::ImpactLaw::kSeedOnePass) continue;
      // Velocity scale at the contact: the speeds of both material points, before and after.
      double v_scale = 0.0;
      for (const auto* states : {&scene.bodies, &r.bodies}) {
        for (const std::string& id : {contact.body_a, contact.body_b}) {
          const core::BodyState& b = (*states)[index.at(id)];
          v_scale += b.linear_velocity.norm() +
                     b.angular_velocity.norm() * (contact.point - b.worldCom()).norm();
        }
      }
      double pgs_allowance = 0.0;
      if (pgs) {
        const core::RigidBody a = core::makeRigidBody(scene.bodies[index.at(contact.body_a)]);
        const core::RigidBody b = core::makeRigidBody(scene.bodies[index.at(contact.body_b)]);
        const core::ContactSpace space(a, b, contact.point);
        pgs_allowance =
            100.0 * double(island.contacts.size()) * o.tolerance * P_max * n.dot(space.K * n);
      }
      const double u_n = p.normal_velocity_before;
      const double floor = o.law == core::ImpactLaw::kNewton && !painleve
                               ? -contact.restitution * std::min(u_n, 0.0)
                               : 0.0;
      if (!(p.normal_velocity_after >= floor - tol.velocity * v_scale - pgs_allowance)) {
        where << "still approaching: u_n " << u_n << " -> " << p.normal_velocity_after << ", bound "
              << floor << " (velocity scale " << v_scale << ", PGS allowance " << pgs_allowance
              << ")";
        fail(where.str());
      }
    }
  }

  // Energy under Stronge: the change computed body by body as (x' - x).(x' + x) / 2 weighted by
  // the mass (inertia), so that a heavy body's large kinetic energy does not hide a light body's
  // gain; tolerance relative to the energy before and to the magnitudes of the changes.
  if (o.law == core::ImpactLaw::kStronge && immovable_at_rest && all_converged) {
    double gain = 0.0, magnitude = 0.0, energy = 0.0;
    for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
      const core::BodyState& b0 = scene.bodies[i];
      const core::BodyState& b1 = r.bodies[i];
      if (b0.immovable()) continue;
      const Eigen::Matrix3d R = b0.orientation.normalized().toRotationMatrix();
      const Eigen::Matrix3d I = R * b0.inertia * R.transpose();
      const double linear =
          0.5 * b0.mass *
          (b1.linear_velocity - b0.linear_velocity).dot(b1.linear_velocity + b0.linear_velocity);
      const double angular = 0.5 * (b1.angular_velocity - b0.angular_velocity)
                                       .dot(I * (b1.angular_velocity + b0.angular_velocity));
      gain += linear + angular;
      magnitude += std::abs(linear) + std::abs(angular);
      energy += core::kineticEnergy(b0);
    }
    if (!(gain <= tol.energy * (energy + magnitude) + 1e3 * std::numeric_limits<double>::min())) {
      std::ostringstream s;
      s.precision(17);
      s << "Stronge gained kinetic energy " << gain << " J of " << energy << " J";
      fail(s.str());
    }
  }
  return out;
}

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

long envOr(const char* name, long fallback) {
  const char* value = std::getenv(name);
  return value ? std::strtol(value, nullptr, 10) : fallback;
}

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
    law == core::ImpactLaw::kNewton&& method != core::SolverMethod::kIterative;
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
      if (!island.converged) ++not_converged_by_method[island.method];
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
