#include "collision_response/core/iterative_solver.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>

namespace collision_response::core {
namespace {

// Per-row data fixed for the whole solve.
struct RowState {
  Eigen::Vector3d t1 = Eigen::Vector3d::Zero();  // tangent basis (frictional rows only)
  Eigen::Vector3d t2 = Eigen::Vector3d::Zero();
  double inverse_k_nn = 0.0;                               // 1 / (n^T K n)
  Eigen::Matrix2d inverse_k_tt = Eigen::Matrix2d::Zero();  // (T^T K T)^-1, T = [t1 t2]
  double target_u_n = 0.0;                        // -e u_n for approaching contacts, else 0
  double P_n = 0.0;                               // accumulated normal impulse
  Eigen::Vector2d P_t = Eigen::Vector2d::Zero();  // accumulated tangential impulse, (t1, t2)
  double mu = 0.0;  // cone of the current pass: mu_s until the contact is found sliding, then mu_d
  bool sliding = false;  // the last sweep had to project onto the cone
};

}  // namespace

IterativeStats solveIterative(std::vector<RigidBody>& bodies, const std::vector<ContactRow>& rows,
                              const std::vector<int>& island, const SolverOptions& options,
                              std::vector<ContactImpulse>& impulses,
                              const std::vector<double>* fixed_normal_impulses) {
  const bool friction_only = fixed_normal_impulses != nullptr;
  std::vector<RowState> state(island.size());
  for (std::size_t i = 0; i < island.size(); ++i) {
    const ContactRow& row = rows[island[i]];
    RowState& s = state[i];
    const Eigen::Matrix3d& K = row.space.K;
    s.inverse_k_nn = 1.0 / row.normal.dot(K * row.normal);
    const double u_n =
        row.normal.dot(row.space.relativeVelocity(bodies[row.body_a], bodies[row.body_b]));
    s.target_u_n = u_n < 0.0 ? -row.restitution * u_n : 0.0;
    s.mu = row.static_friction;
    if (friction_only) s.P_n = (*fixed_normal_impulses)[i];
    if (!row.frictionless()) {
      tangentBasis(row.normal, s.t1, s.t2);
      Eigen::Matrix2d k_tt;
      k_tt << s.t1.dot(K * s.t1), s.t1.dot(K * s.t2), s.t2.dot(K * s.t1), s.t2.dot(K * s.t2);
      s.inverse_k_tt = k_tt.inverse();
    }
  }

  // The island's movable bodies as they were, to restore if the sweeps diverge.
  std::vector<int> touched;
  touched.reserve(2 * island.size());
  for (const int c : island) {
    for (const int body : {rows[c].body_a, rows[c].body_b}) {
      if (bodies[body].movable()) touched.push_back(body);
    }
  }
  std::sort(touched.begin(), touched.end());
  touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
  std::vector<std::pair<int, RigidBody>> initial;
  initial.reserve(touched.size());
  for (const int body : touched) initial.emplace_back(body, bodies[body]);

  IterativeStats stats;
  for (stats.iterations = 1; stats.iterations <= options.max_iterations; ++stats.iterations) {
    if (stats.iterations % 16 == 0) options.deadline.check("the iterative solver");
    double largest_change = 0.0;
    double largest_impulse = 0.0;
    for (std::size_t i = 0; i < island.size(); ++i) {
      const ContactRow& row = rows[island[i]];
      RowState& s = state[i];
      RigidBody& a = bodies[row.body_a];
      RigidBody& b = bodies[row.body_b];

      // Normal row: drive u_n to its target, keep the accumulated impulse compressive.
      double change = 0.0;
      if (!friction_only) {
        const double u_n = row.normal.dot(row.space.relativeVelocity(a, b));
        const double P_n = std::max(s.P_n - (u_n - s.target_u_n) * s.inverse_k_nn, 0.0);
        const double dP_n = P_n - s.P_n;
        s.P_n = P_n;
        row.space.applyImpulse(a, b, dP_n * row.normal);
        change = std::abs(dP_n);
      }
      const double P_n = s.P_n;

      // Tangential block: stop the slip, then project onto the Coulomb cone.
      if (!row.frictionless()) {
        const Eigen::Vector3d u = row.space.relativeVelocity(a, b);
        Eigen::Vector2d P_t = s.P_t - s.inverse_k_tt * Eigen::Vector2d(u.dot(s.t1), u.dot(s.t2));
        const double magnitude = P_t.norm();
        s.sliding = magnitude > s.mu * P_n || !row.slip_direction.isZero(0.0);
        if (!row.slip_direction.isZero(0.0)) {  // friction fixed against an existing slip
          P_t = -row.dynamic_friction * P_n *
                Eigen::Vector2d(row.slip_direction.dot(s.t1), row.slip_direction.dot(s.t2));
        } else if (s.sliding) {
          const double limit = s.mu * P_n;
          P_t = magnitude > 0.0 ? Eigen::Vector2d(P_t * (limit / magnitude))
                                : Eigen::Vector2d::Zero();
        }
        const Eigen::Vector2d dP_t = P_t - s.P_t;
        s.P_t = P_t;
        row.space.applyImpulse(a, b, dP_t.x() * s.t1 + dP_t.y() * s.t2);
        change = std::max(change, dP_t.norm());
      }
      largest_change = std::max(largest_change, change);
      largest_impulse = std::max(largest_impulse, std::hypot(s.P_n, s.P_t.norm()));
    }
    if (!std::isfinite(largest_impulse) || !std::isfinite(largest_change)) {
      // Diverged (no solution: e.g. a squeeze that cannot bounce, or sliding friction that makes a
      // row's effective mass negative, Painleve's case): apply nothing, report not converged.
      // (Friction only: the fixed normal impulses were applied before, and stay.)
      for (const auto& [index, body] : initial) bodies[index] = body;
      for (std::size_t i = 0; i < state.size(); ++i) {
        state[i].P_n = friction_only ? (*fixed_normal_impulses)[i] : 0.0;
        state[i].P_t.setZero();
        state[i].sliding = false;
      }
      stats.converged = false;
      break;
    }
    stats.residual = largest_impulse > 0.0 ? largest_change / largest_impulse : largest_change;
    if (stats.residual <= options.tolerance) {
      // Converged on the current cones. Contacts that slide on their static cone move to the
      // dynamic one and the sweeps go on from here; done when none does (as in the exact solver).
      bool moved = false;
      for (std::size_t i = 0; i < island.size(); ++i) {
        const ContactRow& row = rows[island[i]];
        if (state[i].sliding && state[i].mu != row.dynamic_friction) {
          state[i].mu = row.dynamic_friction;
          moved = true;
        }
      }
      if (!moved) {
        stats.converged = true;
        break;
      }
    }
  }
  stats.iterations = std::min(stats.iterations, options.max_iterations);

  for (std::size_t i = 0; i < island.size(); ++i) {
    const ContactRow& row = rows[island[i]];
    const RowState& s = state[i];
    ContactImpulse& impulse = impulses[island[i]];
    impulse.normal_impulse = s.P_n;
    impulse.friction_impulse = s.P_t.x() * s.t1 + s.P_t.y() * s.t2;
    impulse.sticking = !row.frictionless() && s.P_n > 0.0 && !s.sliding;
  }
  return stats;
}

}  // namespace collision_response::core
