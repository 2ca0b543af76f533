// Physical-validity checks shared by the stress and property suites: one scene, one law and method,
// and everything a result must satisfy (finite numbers, momentum, friction cone, no approaching
// contact left, no energy gain under Stronge), with tolerances scaled to the scene.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "collision_response/core/compute_response.h"
#include "collision_response/core/contact_space.h"
#include "collision_response/core/rigid_body.h"

namespace core = collision_response::core;

// Unnamed: each test program that includes this has its own copy.
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
  // Measurement hook (docs/physics.md, "Simultaneous impulse-space integration"):
  // CR_SIMULTANEOUS=velocity_consistent (the default) or =spring chooses the sharing rule of the
  // simultaneous integration, =two_phase switches it off.
  if (const char* rule = std::getenv("CR_SIMULTANEOUS")) {
    const std::string name(rule);
    if (name == "velocity_consistent" || name == "spring") {
      o.simultaneous_impulse_space = true;
      o.simultaneous_sharing = name == "spring" ? core::SimultaneousSharing::kSpring
                                                : core::SimultaneousSharing::kVelocityConsistent;
    } else if (name == "two_phase") {
      o.simultaneous_impulse_space = false;
    }
  }
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

bool isImpactIsland(const core::CollisionResult& r, const core::SolveReport& island) {
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
//    u'_n >= -e u_n (Newton; 0 for contacts that were not approaching). The one-pass law is
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
    const bool pgs = island.methodName().find("iterative") != std::string::npos;
    for (const int c : island.contacts) {
      const core::Contact& contact = scene.contacts[c];
      const core::ContactImpulse& p = r.impulses[c];
      const Eigen::Vector3d n = contact.normal.normalized();
      const double P = std::hypot(p.normal_impulse, p.friction_impulse.norm());
      std::ostringstream where;
      where.precision(17);
      where << "contact " << c << " (island method " << island.methodName() << "): ";
      if (std::abs(p.friction_impulse.dot(n)) > 1e-9 * P) {
        fail(where.str() + "friction impulse not tangential");
      }
      const bool painleve = o.law == core::ImpactLaw::kNewton &&
                            island.methodName() == "closed_form" && p.sticking &&
                            painleveCase(scene, index, contact);
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

}  // namespace
