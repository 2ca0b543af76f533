#include "collision_response/core/island_solver.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>

#include "collision_response/core/errors.h"
#include "collision_response/core/exact_solver.h"
#include "collision_response/core/impulse_space_integrator.h"
#include "collision_response/core/iterative_solver.h"
#include "collision_response/core/single_contact.h"

namespace collision_response::core {
namespace {

double kineticEnergy(const RigidBody& body) {
  if (!body.movable()) return 0.0;
  const Eigen::Vector3d& w = body.angular_velocity;
  return 0.5 * body.linear_velocity.squaredNorm() / body.inverse_mass +
         0.5 * w.dot(body.inverse_inertia.ldlt().solve(w));
}

double kineticEnergy(const std::vector<RigidBody>& bodies, const std::vector<int>& indices) {
  double energy = 0.0;
  for (const int i : indices) energy += kineticEnergy(bodies[i]);
  return energy;
}

// True if a contact approaches faster than round-off of the largest contact speed.
bool approachingBeyondRoundOff(const std::vector<RigidBody>& bodies,
                               const std::vector<ContactRow>& rows) {
  double speed = 0.0, slowest = 0.0;
  for (const ContactRow& row : rows) {
    const Eigen::Vector3d u = row.space.relativeVelocity(bodies[row.body_a], bodies[row.body_b]);
    speed = std::max(speed, u.norm());
    slowest = std::min(slowest, u.dot(row.normal));
  }
  return slowest < -1e-12 * speed;
}

// Newton law on the listed rows with the exact or the iterative solver.
IslandStats solveNewton(SolverMethod method, std::vector<RigidBody>& bodies,
                        const std::vector<ContactRow>& rows, const std::vector<int>& island,
                        const SolverOptions& options, std::vector<ContactImpulse>& impulses) {
  IslandStats stats;
  if (method == SolverMethod::kExact) {
    const ExactStats exact = solveExact(bodies, rows, island, options, impulses);
    stats.method = "exact";
    stats.iterations = exact.pivots;
    stats.residual = exact.residual;
    stats.converged = exact.converged;
    if (!exact.converged && options.method == SolverMethod::kAuto) {
      // No complementarity solution (a jammed island; the exact solver applied nothing): under the
      // automatic choice the iterative solver gives its best effort, reported as not converged.
      stats = solveNewton(SolverMethod::kIterative, bodies, rows, island, options, impulses);
      stats.method = "exact_then_iterative";
    }
  } else {
    const IterativeStats iterative = solveIterative(bodies, rows, island, options, impulses);
    stats.method = "iterative";
    stats.iterations = iterative.iterations;
    stats.residual = iterative.residual;
    stats.converged = iterative.converged;
  }
  return stats;
}

// The two-phase Poisson / energetic scheme of solveIsland()'s documentation.
IslandStats solveTwoPhase(SolverMethod method, std::vector<RigidBody>& bodies,
                          const std::vector<ContactRow>& rows, const std::vector<int>& island,
                          const SolverOptions& options, std::vector<ContactImpulse>& impulses) {
  // The island's rows with e = 0, indexed locally; its movable bodies.
  std::vector<ContactRow> plastic;
  plastic.reserve(island.size());
  std::vector<int> local(island.size());
  std::vector<int> island_bodies;
  double e_max = 0.0;
  for (std::size_t i = 0; i < island.size(); ++i) {
    plastic.push_back(rows[island[i]]);
    plastic.back().restitution = 0.0;
    local[i] = static_cast<int>(i);
    e_max = std::max(e_max, rows[island[i]].restitution);
    for (const int body : {plastic.back().body_a, plastic.back().body_b}) {
      if (bodies[body].movable()) island_bodies.push_back(body);
    }
  }
  std::sort(island_bodies.begin(), island_bodies.end());
  island_bodies.erase(std::unique(island_bodies.begin(), island_bodies.end()), island_bodies.end());

  // 1. Compression.
  const double energy_before = kineticEnergy(bodies, island_bodies);
  std::vector<ContactImpulse> compression(island.size());
  const IslandStats first = solveNewton(method, bodies, plastic, local, options, compression);
  const double dissipated = std::max(energy_before - kineticEnergy(bodies, island_bodies), 0.0);

  // 2. Restitution: normal impulses R_i = s e_i P_c,i, and friction through the phase: with the
  // R_i fixed, each contact sticks if that needs |T_i| <= mu_s R_i, else slides with mu_d R_i
  // (Coulomb integrated over the phase; solveIterative() with fixed normal impulses).
  double linear = 0.0;  // R.u_c at s = 1
  for (std::size_t i = 0; i < island.size(); ++i) {
    const ContactRow& row = plastic[i];
    const double u_n =
        row.normal.dot(row.space.relativeVelocity(bodies[row.body_a], bodies[row.body_b]));
    linear += rows[island[i]].restitution * compression[i].normal_impulse * u_n;
  }
  std::vector<std::pair<int, RigidBody>> compressed;  // to undo the phase
  for (const int body : island_bodies) compressed.emplace_back(body, bodies[body]);
  const double energy_compressed = kineticEnergy(bodies, island_bodies);
  std::vector<double> restitution_normal(island.size());
  std::vector<ContactImpulse> restitution(island.size());
  const auto applyNormal = [&](double scale) {
    for (std::size_t i = 0; i < island.size(); ++i) {
      const ContactRow& row = plastic[i];
      restitution_normal[i] = scale * rows[island[i]].restitution * compression[i].normal_impulse;
      row.space.applyImpulse(bodies[row.body_a], bodies[row.body_b],
                             restitution_normal[i] * row.normal);
    }
  };
  const auto restitutionPhase = [&](double scale) {
    applyNormal(scale);
    IterativeStats friction;
    friction.converged = true;
    std::fill(restitution.begin(), restitution.end(), ContactImpulse{});
    for (std::size_t i = 0; i < island.size(); ++i) {
      if (!plastic[i].frictionless() && restitution_normal[i] > 0.0) {
        friction =
            solveIterative(bodies, plastic, local, options, restitution, &restitution_normal);
        break;
      }
    }
    return friction;
  };
  const auto undo = [&] {
    for (const auto& [index, body] : compressed) bodies[index] = body;
  };
  double scale = 1.0;
  IterativeStats friction = restitutionPhase(scale);
  if (options.law == ImpactLaw::kStronge) {
    // Stronge: the phase may release at most e_max^2 D_c. If it releases more at s = 1 (friction
    // included), the R_i are scaled down together: alone they release s linear + s^2 q, so the
    // largest s within the bound is taken from that, and friction (least energy over its cones,
    // T = 0 being feasible) can only lower it further.
    const double allowed = e_max * e_max * dissipated;
    if (kineticEnergy(bodies, island_bodies) - energy_compressed > allowed) {
      undo();
      applyNormal(1.0);
      const double q = kineticEnergy(bodies, island_bodies) - energy_compressed - linear;
      undo();
      scale =
          q > 0.0 ? (-linear + std::sqrt(linear * linear + 4.0 * q * allowed)) / (2.0 * q) : 0.0;
      scale = std::clamp(scale, 0.0, 1.0);
      friction = restitutionPhase(scale);
    }
  }

  // 3. No contact may end approaching.
  std::vector<ContactImpulse> cleanup(island.size());
  IslandStats third = solveNewton(method, bodies, plastic, local, options, cleanup);
  // Unequal e_i on coupled contacts can leave the restitution phase with contact velocities far
  // above the final ones, and the clean-up's round-off is relative to them. One more plastic
  // solve from its result removes what is left approaching, relative to the final velocities.
  if (third.converged && approachingBeyondRoundOff(bodies, plastic)) {
    std::vector<ContactImpulse> polish(island.size());
    const IslandStats again = solveNewton(method, bodies, plastic, local, options, polish);
    for (std::size_t i = 0; i < island.size(); ++i) {
      cleanup[i].normal_impulse += polish[i].normal_impulse;
      cleanup[i].friction_impulse += polish[i].friction_impulse;
    }
    third.iterations += again.iterations;
    third.residual = again.residual;
    third.converged = again.converged;
  }

  for (std::size_t i = 0; i < island.size(); ++i) {
    ContactImpulse& impulse = impulses[island[i]];
    impulse.normal_impulse =
        (1.0 + scale * rows[island[i]].restitution) * compression[i].normal_impulse +
        cleanup[i].normal_impulse;
    impulse.friction_impulse = compression[i].friction_impulse + restitution[i].friction_impulse +
                               cleanup[i].friction_impulse;
    // Sticking: no slip left at the end.
    const ContactRow& row = plastic[i];
    const Eigen::Vector3d u = row.space.relativeVelocity(bodies[row.body_a], bodies[row.body_b]);
    const double slip = (u - u.dot(row.normal) * row.normal).norm();
    impulse.sticking = !row.frictionless() && impulse.normal_impulse > 0.0 &&
                       slip <= 1e-9 * std::max(u.norm(), 1e-300);
  }
  IslandStats stats;
  stats.method = method == SolverMethod::kExact ? "two_phase_exact" : "two_phase_iterative";
  stats.iterations = first.iterations + friction.iterations + third.iterations;
  stats.residual = std::max({first.residual, friction.residual, third.residual});
  stats.converged = first.converged && friction.converged && third.converged;
  return stats;
}

}  // namespace

IslandStats solveIsland(std::vector<RigidBody>& bodies, const std::vector<ContactRow>& rows,
                        const std::vector<int>& island, const SolverOptions& options,
                        std::vector<ContactImpulse>& impulses) {
  IslandStats stats;
  const bool energetic = options.law == ImpactLaw::kPoisson || options.law == ImpactLaw::kStronge;
  if (options.law == ImpactLaw::kSeedOnePass ||
      (island.size() == 1 && options.method == SolverMethod::kAuto)) {
    for (const int c : island) {
      const ContactRow& row = rows[c];
      RigidBody& a = bodies[row.body_a];
      RigidBody& b = bodies[row.body_b];
      if (energetic) {
        IntegrationStats integration;
        impulses[c] = integrateSingleContact(a, b, row, options.law, options.integration_tolerance,
                                             &integration);
        stats.method = "impulse_space";
        stats.iterations = integration.steps + integration.segments;
        stats.residual = integration.error_estimate;
      } else {
        impulses[c] = solveSingleContact(a, b, row, options.law);
        stats.method = island.size() == 1 ? "closed_form" : "sequential";
        stats.iterations = island.size();
      }
      row.space.applyImpulse(a, b, impulses[c].total(row.normal));
    }
    return stats;
  }
  if (options.method == SolverMethod::kExact && island.size() > kExactSolverContactLimit) {
    throw InvalidInput("options.solver", "the exact solver takes islands of at most " +
                                             std::to_string(kExactSolverContactLimit) +
                                             " contacts; this one has " +
                                             std::to_string(island.size()) +
                                             ": use the iterative or the automatic solver");
  }
  const SolverMethod method = options.method != SolverMethod::kAuto      ? options.method
                              : island.size() <= kExactSolverMaxContacts ? SolverMethod::kExact
                                                                         : SolverMethod::kIterative;
  return energetic ? solveTwoPhase(method, bodies, rows, island, options, impulses)
                   : solveNewton(method, bodies, rows, island, options, impulses);
}

}  // namespace collision_response::core
