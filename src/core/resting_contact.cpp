#include "collision_response/core/resting_contact.h"

#include <Eigen/Geometry>
#include <cmath>

#include "collision_response/core/iterative_solver.h"
#include "collision_response/core/single_contact.h"

namespace collision_response::core {
namespace {

// A body whose "velocities" are its accelerations under its wrench alone: a = F / m and
// alpha = Iw^-1 (tau - w x Iw w).
RigidBody accelerationBody(const BodyState& state, const RigidBody& body) {
  RigidBody out = body;
  out.linear_velocity = body.inverse_mass * state.force;
  out.angular_velocity.setZero();
  if (body.movable()) {
    const Eigen::Vector3d& w = body.angular_velocity;
    // Iw w from the body-frame tensor (not by inverting Iw^-1, which loses the small moments).
    const Eigen::Matrix3d R = state.orientation.normalized().toRotationMatrix();
    const Eigen::Vector3d Iw_w = R * (state.inertia * (R.transpose() * w));
    out.angular_velocity = body.inverse_inertia * (state.torque - w.cross(Iw_w));
  }
  return out;
}

Eigen::Vector3d centripetal(const RigidBody& body, const Eigen::Vector3d& r) {
  return body.angular_velocity.cross(body.angular_velocity.cross(r));
}

}  // namespace

IslandStats solveRestingIsland(const std::vector<BodyState>& states,
                               const std::vector<RigidBody>& bodies,
                               const std::vector<ContactRow>& rows, const std::vector<int>& island,
                               const SolverOptions& options,
                               std::vector<ContactImpulse>& impulses) {
  // The island's resting contacts as rows on accelerations, indexed locally.
  std::vector<ContactRow> resting;
  std::vector<int> resting_index;
  std::vector<RigidBody> accelerations;  // local copies of the bodies involved
  std::vector<int> local_of(bodies.size(), -1);
  const auto localBody = [&](int i) {
    if (local_of[i] < 0) {
      local_of[i] = static_cast<int>(accelerations.size());
      accelerations.push_back(accelerationBody(states[i], bodies[i]));
    }
    return local_of[i];
  };
  for (const int c : island) {
    const ContactRow& row = rows[c];
    const Eigen::Vector3d u = row.space.relativeVelocity(bodies[row.body_a], bodies[row.body_b]);
    const double u_n = u.dot(row.normal);
    if (std::abs(u_n) > options.resting_velocity) continue;
    ContactRow local = row;
    local.body_a = localBody(row.body_a);
    local.body_b = localBody(row.body_b);
    local.restitution = 0.0;
    local.space.bias = centripetal(bodies[row.body_b], row.space.r_b) -
                       centripetal(bodies[row.body_a], row.space.r_a);
    const Eigen::Vector3d u_t = u - u_n * row.normal;
    if (!row.frictionless() && u_t.norm() > options.resting_velocity) {
      local.slip_direction = u_t.normalized();
    }
    resting.push_back(local);
    resting_index.push_back(c);
  }
  IslandStats stats;
  if (resting.empty()) return stats;

  std::vector<ContactImpulse> forces(resting.size());
  if (resting.size() == 1) {
    stats.method = "resting_closed_form";
    stats.iterations = 1;
    const ContactRow& row = resting[0];
    RigidBody& a = accelerations[row.body_a];
    RigidBody& b = accelerations[row.body_b];
    if (row.slip_direction.isZero(0.0)) {
      forces[0] = solveSingleContact(a, b, row, ImpactLaw::kNewton);
    } else {
      // Sliding: F = f_n (n - mu_d s) with a'_n = 0.
      const Eigen::Vector3d direction = row.normal - row.dynamic_friction * row.slip_direction;
      const double a_n = row.normal.dot(row.space.relativeVelocity(a, b));
      const double denominator = row.normal.dot(row.space.K * direction);
      if (a_n < 0.0 && denominator > 0.0) {
        const double f_n = -a_n / denominator;
        forces[0].normal_impulse = f_n;
        forces[0].friction_impulse = -row.dynamic_friction * f_n * row.slip_direction;
      } else if (a_n < 0.0) {
        stats.converged = false;  // Painleve: no consistent sliding force exists
      }
    }
    row.space.applyImpulse(a, b, forces[0].total(row.normal));
  } else {
    std::vector<int> all(resting.size());
    for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
    const IterativeStats iterative = solveIterative(accelerations, resting, all, options, forces);
    stats.method = "resting_iterative";
    stats.iterations = iterative.iterations;
    stats.residual = iterative.residual;
    stats.converged = iterative.converged;
  }

  for (std::size_t i = 0; i < resting.size(); ++i) {
    const ContactRow& row = resting[i];
    ContactImpulse& out = impulses[resting_index[i]];
    out.resting = true;
    out.normal_force = forces[i].normal_impulse;
    out.friction_force = forces[i].friction_impulse;
    // Sticking: no slip now and no tangential relative acceleration left.
    const Eigen::Vector3d a =
        row.space.relativeVelocity(accelerations[row.body_a], accelerations[row.body_b]);
    const Eigen::Vector3d a_t = a - a.dot(row.normal) * row.normal;
    const Eigen::Vector3d a_free = a - row.space.K * forces[i].total(row.normal);
    out.sticking = row.slip_direction.isZero(0.0) && !row.frictionless() &&
                   a_t.norm() <= 1e-9 * std::max(a_free.norm(), 1e-300);
  }
  return stats;
}

}  // namespace collision_response::core
