#include "collision_response/core/impact_derivatives.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string_view>

#include "collision_response/core/constants.h"
#include "collision_response/core/contact_derivatives.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/contact_space.h"
#include "collision_response/core/exact_solver.h"
#include "collision_response/core/impulse_space_derivatives.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/simultaneous_impact.h"
#include "collision_response/core/validation.h"

namespace collision_response::core {
namespace {

using Eigen::Index;
using Eigen::Matrix3d;
using Eigen::MatrixXd;
using Eigen::Vector3d;

// Finite differences: step relative to the input's scale (central: truncation ~ step^2, round-off
// ~ 2e-16 / step). Small, because the integrations' outputs jump where their step count changes
// (by their discretisation error: 1e-7 of the outputs about every 1e-5 of an input for the
// simultaneous integration, which has no error control); a difference across such a jump is
// replaced by a one-sided one.
constexpr double kStep = 1e-7;
// Central differences with one and two steps that differ by more than this (relative to the
// column) reveal a kink or jump inside the steps.
constexpr double kSmoothness = 1e-4;
// Column offsets of a contact's coefficients (contact_derivatives.h).
constexpr int kRestitution = kRestitutionColumn, kStatic = kStaticColumn, kDynamic = kDynamicColumn;

// The island's contacts in contact space (contact_derivatives.h: J 3m x 6L over the island's
// movable bodies' twists, M^-1 J^T, the rigid bodies' masses and inertias) and those bodies.
struct IslandSystem : NewtonIsland {
  std::vector<int> bodies;  // scene indices of the movable bodies, local order
};

Eigen::Matrix<double, 3, 6> pointJacobian(const Vector3d& r) {
  Eigen::Matrix<double, 3, 6> J;
  J << Matrix3d::Identity(), -skew(r);
  return J;
}

// Fills `s` (its storage reused: the caller's per-thread system, one island after another).
void buildSystem(const std::vector<int>& contacts, const Scene& scene,
                 const std::vector<std::pair<int, int>>& contact_bodies,
                 const std::vector<RigidBody>& before, const CollisionResult& result,
                 std::vector<int>& local_of, IslandSystem& s) {
  s.contacts = contacts;
  s.state.clear();
  s.rigid.clear();
  s.bodies.clear();
  s.clearW();
  s.state.reserve(contacts.size());
  for (const int c : contacts) {
    for (const int b : {contact_bodies[c].first, contact_bodies[c].second}) {
      if (before[b].movable() && local_of[b] < 0) {
        local_of[b] = static_cast<int>(s.bodies.size());
        s.bodies.push_back(b);
      }
    }
  }
  const Index m = static_cast<Index>(contacts.size()), L = static_cast<Index>(s.bodies.size());
  s.J.setZero(3 * m, 6 * L);
  s.MinvJt.resize(6 * L, 3 * m);
  for (Index i = 0; i < m; ++i) {
    const int c = contacts[i];
    const Contact& contact = scene.contacts[c];
    const auto [a, b] = contact_bodies[c];
    const Vector3d n = contact.normal.normalized();
    Vector3d u = Vector3d::Zero(), u_after = Vector3d::Zero();
    for (const int side : {a, b}) {
      const double sign = side == b ? 1.0 : -1.0;
      const Vector3d r = contact.point - before[side].com;
      u += sign * before[side].pointVelocity(r);
      u_after += sign * (result.bodies[side].linear_velocity +
                         result.bodies[side].angular_velocity.cross(r));
      if (local_of[side] >= 0)
        s.J.block<3, 6>(3 * i, 6 * local_of[side]) += sign * pointJacobian(r);
    }
    const ContactImpulse& impulse = result.impulses[c];
    s.state.push_back({n,
                       u,
                       u_after,
                       impulse.normal_impulse * n + impulse.friction_impulse,
                       {contact.restitution, contact.static_friction, contact.dynamic_friction}});
  }
  s.rigid.reserve(static_cast<std::size_t>(L));
  for (Index l = 0; l < L; ++l) {
    const RigidBody& body = before[s.bodies[l]];
    s.rigid.push_back({1.0 / body.inverse_mass, body.inverse_inertia.inverse()});
    const auto Jt = s.J.middleCols<6>(6 * l).transpose();
    s.MinvJt.middleRows<3>(6 * l) = body.inverse_mass * Jt.topRows<3>();
    s.MinvJt.middleRows<3>(6 * l + 3) = body.inverse_inertia * Jt.bottomRows<3>();
  }
  for (const int b : s.bodies) local_of[b] = -1;
}

// Writes an island's derivatives into the full Jacobian from dP/dv (3m x 6L, v the island's
// movable bodies' twists) and dP/dtheta (3m x 3m, per contact e, mu_s, mu_d).
// `velocities`: whether dP/dv was computed (else its columns are left alone).
void scatter(const IslandSystem& s, const MatrixXd& dP_dv, const MatrixXd& dP_dtheta,
             bool velocities, const std::vector<Index>& body_column, Index velocity_count,
             MatrixXd& jacobian) {
  const Index m = static_cast<Index>(s.contacts.size()), L = static_cast<Index>(s.bodies.size());
  // (normal_impulse, friction_impulse) of contact i = impulseOfP(i) * P_i: normal_impulse = n.P,
  // friction_impulse = (I - n n^T) P. Formed once per contact (on the stack for islands of up to
  // 16 contacts), read for every column.
  using ImpulseMap = Eigen::Matrix<double, 4, 3>;
  std::array<ImpulseMap, 16> small_maps;
  std::vector<ImpulseMap> large_maps;
  ImpulseMap* maps = small_maps.data();
  if (m > static_cast<Index>(small_maps.size())) {
    large_maps.resize(static_cast<std::size_t>(m));
    maps = large_maps.data();
  }
  for (Index i = 0; i < m; ++i) {
    const Vector3d& n = s.state[static_cast<std::size_t>(i)].normal;
    maps[i].row(0) = n.transpose();
    maps[i].bottomRows<3>() = Matrix3d::Identity() - n * n.transpose();
  }
  auto impulseOfP = [maps](Index i) -> const ImpulseMap& { return maps[i]; };
  const Index impulse_rows = velocity_count;
  const Index coefficient_columns = velocity_count;
  if (velocities) {
    const MatrixXd dv_dv = s.MinvJt.lazyProduct(dP_dv);
    for (Index l = 0; l < L; ++l) {
      const Index row = body_column[s.bodies[l]];
      for (Index k = 0; k < L; ++k) {
        jacobian.block<6, 6>(row, body_column[s.bodies[k]]) += dv_dv.block<6, 6>(6 * l, 6 * k);
      }
    }
    for (Index i = 0; i < m; ++i) {
      const Index row = impulse_rows + 4 * static_cast<Index>(s.contacts[i]);
      for (Index l = 0; l < L; ++l) {
        jacobian.block<4, 6>(row, body_column[s.bodies[l]]) =
            impulseOfP(i) * dP_dv.block<3, 6>(3 * i, 6 * l);
      }
    }
  }
  // Coefficient columns that are 0 (not computed, or no effect: a sticking contact's friction)
  // are left as they are: 0 (the caller's jacobian starts at 0). The others column by column, in
  // fixed-size blocks: dv_l = (M^-1 J^T)_l dP, impulses_i = impulseOfP(i) dP_i.
  for (Index k = 0; k < dP_dtheta.cols(); ++k) {
    const auto dP = dP_dtheta.col(k);
    if (std::all_of(dP.data(), dP.data() + dP.size(), [](double x) { return x == 0.0; })) continue;
    const Index column = coefficient_columns + 3 * static_cast<Index>(s.contacts[k / 3]) + k % 3;
    for (Index l = 0; l < L; ++l) {
      Eigen::Matrix<double, 6, 1> dv = Eigen::Matrix<double, 6, 1>::Zero();
      for (Index i = 0; i < m; ++i) {
        dv.noalias() += s.MinvJt.block<6, 3>(6 * l, 3 * i) * dP.segment<3>(3 * i);
      }
      jacobian.block<6, 1>(body_column[s.bodies[l]], column) = dv;
    }
    for (Index i = 0; i < m; ++i) {
      jacobian.block<4, 1>(impulse_rows + 4 * static_cast<Index>(s.contacts[i]), column).noalias() =
          impulseOfP(i) * dP.segment<3>(3 * i);
    }
  }
}

// One contact between free rigid bodies, alone in its island, in fixed-size blocks (the cheap
// path of a single-contact prediction): side s (a: -1, b: +1) of a movable body has
// J_s = [I3, -[r_s]x] and M_s^-1 J_s^T = [I3 / m_s; Iw_s^-1 [r_s]x], K = sum_s J_s M_s^-1 J_s^T,
// u = sum_s sign_s J_s v_s, dv_s' = sign_s M_s^-1 J_s^T dP; dP/du and dP/d(e, mu_s, mu_d) from
// Newton's closed form or the impulse-space sensitivity (impulse_space_derivatives.h), by
// options.law. False if K is singular (or the sensitivity cannot be had).
bool singleContact(const Scene& scene, int c, std::pair<int, int> sides,
                   const std::vector<RigidBody>& before, const std::vector<Index>& body_column,
                   Index velocity_count, const SolverOptions& options, ImpactDerivatives& out) {
  const Contact& contact = scene.contacts[c];
  const Vector3d n = contact.normal.normalized();
  struct Side {
    int body;
    double sign;
    Eigen::Matrix<double, 3, 6> J;
    Eigen::Matrix<double, 6, 3> MinvJt;
  };
  std::array<Side, 2> side;
  int count = 0;
  Matrix3d K = Matrix3d::Zero();
  Vector3d u = Vector3d::Zero();
  for (const int body : {sides.first, sides.second}) {
    const double sign = body == sides.second ? 1.0 : -1.0;
    const RigidBody& rigid = before[body];
    const Vector3d r = contact.point - rigid.com;
    u += sign * rigid.pointVelocity(r);
    if (!rigid.movable()) continue;
    Side& s = side[count++];
    s.body = body;
    s.sign = sign;
    s.J = pointJacobian(r);
    s.MinvJt.topRows<3>() = rigid.inverse_mass * Matrix3d::Identity();
    s.MinvJt.bottomRows<3>() = rigid.inverse_inertia * skew(r);
    K.noalias() += s.J * s.MinvJt;
  }
  Matrix3d dP_du, dP_dtheta;
  if (options.law == ImpactLaw::kNewton) {
    if (!differentiateNewtonContact(
            n, K, u, {contact.restitution, contact.static_friction, contact.dynamic_friction},
            dP_du, dP_dtheta, out.contacts[c])) {
      return false;
    }
  } else if (!differentiateImpulseSpace(
                 n, K, u, contact.restitution, contact.static_friction, contact.dynamic_friction,
                 options.law, options.integration_tolerance, dP_du, dP_dtheta, out.contacts[c])) {
    return false;
  }
  Eigen::Matrix<double, 4, 3> impulse_of_P;  // (normal_impulse, friction_impulse) = this * P
  impulse_of_P.row(0) = n.transpose();
  impulse_of_P.bottomRows<3>() = Matrix3d::Identity() - n * n.transpose();
  const Index impulse_row = velocity_count + 4 * static_cast<Index>(c);
  const Index coefficient_column = velocity_count + 3 * static_cast<Index>(c);
  for (int k = 0; k < count; ++k) {
    const Eigen::Matrix<double, 3, 6> dP_dv = side[k].sign * dP_du * side[k].J;
    const Index column = body_column[side[k].body];
    for (int l = 0; l < count; ++l) {
      out.jacobian.block<6, 6>(body_column[side[l].body], column).noalias() +=
          side[l].sign * side[l].MinvJt * dP_dv;
    }
    out.jacobian.block<4, 6>(impulse_row, column).noalias() = impulse_of_P * dP_dv;
    out.jacobian.block<6, 3>(body_column[side[k].body], coefficient_column).noalias() =
        side[k].sign * side[k].MinvJt * dP_dtheta;
  }
  out.jacobian.block<4, 3>(impulse_row, coefficient_column).noalias() = impulse_of_P * dP_dtheta;
  return true;
}

// ---- Finite differences of the solver ------------------------------------------------------

// The outputs (layout of ImpactDerivatives) and each contact's mode.
struct Evaluation {
  Eigen::VectorXd outputs;
  std::vector<int> modes;                // per contact: 0 none, 1 sticking, 2 sliding
  std::vector<std::size_t> island_mark;  // per island: SolveReport::iterations
};

int modeOf(const ContactImpulse& impulse) {
  if (impulse.normal_impulse == 0.0 && impulse.friction_impulse.isZero(0.0)) return 0;
  return impulse.sticking ? 1 : 2;
}

Evaluation evaluate(const CollisionResult& result, const std::vector<Index>& body_column,
                    Index velocity_count) {
  Evaluation out;
  out.outputs.setZero(velocity_count + 4 * static_cast<Index>(result.impulses.size()));
  for (std::size_t b = 0; b < result.bodies.size(); ++b) {
    if (body_column[b] < 0) continue;
    out.outputs.segment<3>(body_column[b]) = result.bodies[b].linear_velocity;
    out.outputs.segment<3>(body_column[b] + 3) = result.bodies[b].angular_velocity;
  }
  for (std::size_t c = 0; c < result.impulses.size(); ++c) {
    const Index row = velocity_count + 4 * static_cast<Index>(c);
    out.outputs(row) = result.impulses[c].normal_impulse;
    out.outputs.segment<3>(row + 1) = result.impulses[c].friction_impulse;
    out.modes.push_back(modeOf(result.impulses[c]));
  }
  for (const SolveReport& island : result.islands) {
    // Steps and segments (impulse space), sweeps (iterative): the discretisation of the solve.
    out.island_mark.push_back(island.iterations);
  }
  return out;
}

// Finite differences for the islands listed (indices into result.islands): the columns of their
// bodies and contacts, the rows of the same.
// `end`: when the call's time budget (options.time_budget, from the start of
// computeImpactDerivatives()) runs out; each perturbed solve gets what is left of it.
void finiteDifferences(const Scene& scene, const std::vector<std::pair<int, int>>& contact_bodies,
                       const SolverOptions& options, std::chrono::steady_clock::time_point end,
                       const CollisionResult& base_result, const std::vector<std::size_t>& islands,
                       const std::vector<Index>& body_column, Index velocity_count,
                       const DerivativeColumns& columns, ImpactDerivatives& out) {
  const Evaluation base = evaluate(base_result, body_column, velocity_count);
  for (const std::size_t island : islands) {
    const SolveReport& report = base_result.islands[island];
    std::vector<int> bodies;
    for (const int c : report.contacts) {
      for (const int b : {contact_bodies[c].first, contact_bodies[c].second}) {
        if (body_column[b] >= 0 && std::find(bodies.begin(), bodies.end(), b) == bodies.end()) {
          bodies.push_back(b);
        }
      }
      out.contacts[c].method = DerivativeMethod::kFiniteDifference;
      out.contacts[c].mode = std::array<ImpactMode, 3>{
          ImpactMode::kNoImpulse, ImpactMode::kSticking, ImpactMode::kSliding}[base.modes[c]];
    }
    std::vector<Index> rows;
    for (const int b : bodies) {
      for (int k = 0; k < 6; ++k) rows.push_back(body_column[b] + k);
    }
    for (const int c : report.contacts) {
      for (int k = 0; k < 4; ++k) rows.push_back(velocity_count + 4 * c + k);
    }
    double velocity_scale = 0.0;
    for (const int b : bodies) {
      velocity_scale =
          std::max({velocity_scale, scene.bodies[b].linear_velocity.cwiseAbs().maxCoeff(),
                    scene.bodies[b].angular_velocity.cwiseAbs().maxCoeff()});
    }
    if (!(velocity_scale > 0.0)) velocity_scale = 1.0;
    // One column: input `label`, read/written through `value`; [low, high] its valid range.
    Scene perturbed = scene;
    auto column = [&](Index col, double& value, double low, double high, double scale,
                      const std::string& label) {
      const double x0 = value;
      const double h = kStep * std::max(std::abs(x0), scale);
      auto at = [&](double x, bool& valid) {
        valid = x >= low && x <= high;
        if (!valid) return Evaluation{};
        value = x;
        SolverOptions remaining = options;
        remaining.time_budget =
            std::chrono::duration<double>(end - std::chrono::steady_clock::now()).count();
        if (!(remaining.time_budget > 0.0)) {
          value = x0;
          throw SolverTimeout("the derivatives' finite differences exceeded the time budget of " +
                              std::to_string(options.time_budget) + " s");
        }
        Evaluation e = evaluate(computeValidatedResponse(perturbed, contact_bodies, remaining),
                                body_column, velocity_count);
        value = x0;
        return e;
      };
      // Whether `e` lies on the same piece of the solve as `reference` (modes, integration steps).
      auto sameAs = [&](const Evaluation& e, const Evaluation& reference) {
        if (e.modes.empty() || reference.modes.empty()) return false;
        for (const int c : report.contacts) {
          if (e.modes[c] != reference.modes[c]) return false;
        }
        return e.island_mark[island] == reference.island_mark[island];
      };
      auto same = [&](const Evaluation& e) { return sameAs(e, base); };
      bool valid_plus = false, valid_minus = false, valid = false;
      const Evaluation plus = at(x0 + h, valid_plus), minus = at(x0 - h, valid_minus);
      Eigen::VectorXd derivative;
      const bool plus_same = valid_plus && same(plus), minus_same = valid_minus && same(minus);
      if (plus_same && minus_same) {
        derivative = (plus.outputs - minus.outputs) / (2.0 * h);
        // The same with twice the step: where they disagree, an event inside the solve (one the
        // report does not count) lies within the steps, and the difference is not a derivative.
        bool valid_far_plus = false, valid_far_minus = false;
        const Evaluation far_plus = at(x0 + 2.0 * h, valid_far_plus);
        const Evaluation far_minus = at(x0 - 2.0 * h, valid_far_minus);
        if (valid_far_plus && valid_far_minus && same(far_plus) && same(far_minus)) {
          const Eigen::VectorXd wide = (far_plus.outputs - far_minus.outputs) / (4.0 * h);
          double difference = 0.0, scale = 0.0;
          for (const Index row : rows) {
            difference = std::max(difference, std::abs(wide(row) - derivative(row)));
            scale = std::max(scale, std::abs(derivative(row)));
          }
          if (difference > kSmoothness * scale) {
            for (const int c : report.contacts) {
              flagSwitch(out.contacts[c], "the solve is not smooth within two steps of " + label +
                                              " (an event inside it): derivative uncertain");
            }
          }
        }
      } else {
        // The side differenced: the one on the base's piece. At a bound of the input's range
        // (e = 0, mu_d = mu_s) the one valid side can lie on a piece of its own (e > 0 adds a
        // restitution phase, and steps): the derivative of that side's piece, from two points on
        // it (not across the jump to the base).
        const bool bounded = valid_plus != valid_minus;
        const bool forward = plus_same || (!minus_same && bounded && valid_plus);
        const double sign = forward ? 1.0 : -1.0;
        const Evaluation& near = forward ? plus : minus;
        const Evaluation far = at(x0 + 2.0 * sign * h, valid);
        const bool own_piece = !plus_same && !minus_same && bounded && valid && sameAs(far, near);
        if ((plus_same || minus_same) && valid && same(far)) {
          derivative = sign * (-3.0 * base.outputs + 4.0 * near.outputs - far.outputs) / (2.0 * h);
        } else if (plus_same || minus_same) {
          derivative = sign * (near.outputs - base.outputs) / h;
        } else if (own_piece) {
          derivative = sign * (far.outputs - near.outputs) / h;
        } else if (valid_plus && valid_minus) {
          derivative = (plus.outputs - minus.outputs) / (2.0 * h);
        } else {
          derivative =
              valid_plus ? (plus.outputs - base.outputs) / h : (base.outputs - minus.outputs) / h;
        }
        // The contacts whose mode changes within the step: at a switch.
        for (const int c : report.contacts) {
          const bool changes = (valid_plus && plus.modes[c] != base.modes[c]) ||
                               (valid_minus && minus.modes[c] != base.modes[c]) ||
                               (!plus_same && !minus_same);
          if (changes) {
            flagSwitch(out.contacts[c],
                       std::string("mode or integration steps change within the step of ") + label +
                           ": " +
                           (plus_same    ? "increasing side"
                            : minus_same ? "decreasing side"
                            : own_piece  ? (forward ? "the increasing side's own piece (at a bound)"
                                                    : "the decreasing side's own piece (at a bound)")
                                         : "both sides change"));
          }
        }
      }
      for (const Index row : rows) out.jacobian(row, col) = derivative(row);
    };
    for (const int b : columns.velocities ? bodies : std::vector<int>{}) {
      BodyState& state = perturbed.bodies[b];
      const std::string name = "bodies[" + std::to_string(b) + "].twist.";
      const char* axes[] = {"x", "y", "z"};
      for (int k = 0; k < 3; ++k) {
        column(body_column[b] + k, state.linear_velocity[k], -INFINITY, INFINITY, velocity_scale,
               name + "linear." + axes[k]);
        column(body_column[b] + 3 + k, state.angular_velocity[k], -INFINITY, INFINITY,
               velocity_scale, name + "angular." + axes[k]);
      }
    }
    for (const int c : report.contacts) {
      Contact& contact = perturbed.contacts[c];
      const Index col = velocity_count + 3 * c;
      const std::string name = "contacts[" + std::to_string(c) + "].";
      const Index first = 3 * static_cast<Index>(c);
      if (columns.wantsCoefficient(first + kRestitution)) {
        column(col + kRestitution, contact.restitution, 0.0, 1.0, 1.0, name + "restitution");
      }
      // Each coefficient on its own, mu_d <= mu_s aside: the solvers read them separately (the
      // static one for the stick test, the dynamic one for slip), so the map extends across it.
      if (columns.wantsCoefficient(first + kStatic)) {
        column(col + kStatic, contact.static_friction, 0.0, INFINITY, 1.0,
               name + "static_friction");
      }
      if (columns.wantsCoefficient(first + kDynamic)) {
        column(col + kDynamic, contact.dynamic_friction, 0.0, INFINITY, 1.0,
               name + "dynamic_friction");
      }
    }
  }
}

// computeValidatedImpactDerivatives()'s per-body lists, in storage reused per thread (the linear
// uncertainty differentiates once per request, where fresh vectors' allocations are a visible part
// of the cost). The function does not call itself, so one set per thread suffices.
struct DerivativeScratch {
  std::vector<RigidBody> before;   // the bodies before the impact
  std::vector<Index> body_column;  // per body: its first velocity column, -1 if immovable
  std::vector<int> local_of;       // per body: its index in the island buildSystem() builds
  IslandSystem system;             // the island being differentiated (exact solver's, dual run's)
  MatrixXd dP_dv, dP_dtheta;       // its impulses' derivatives (differentiateNewtonIsland())
};

[[gnu::noinline]] DerivativeScratch& threadDerivativeScratch() {
  thread_local DerivativeScratch scratch;
  return scratch;
}

// Several contacts under Poisson or Stronge integrated together (solveSimultaneousImpulseSpace()):
// the integration run again on dual numbers on the island's problem as the solve built it
// (differentiateSimultaneousImpulseSpace()), dP/dv = dP/du J. False (the caller differences) if it
// refuses or its impulses are not the solve's (a branch taken otherwise).
bool simultaneousIsland(const Scene& scene, const std::vector<std::pair<int, int>>& contact_bodies,
                        const SolveReport& report, const SolverOptions& options,
                        const Deadline& deadline, const DerivativeColumns& columns,
                        const std::vector<RigidBody>& before, const std::vector<Index>& body_column,
                        Index velocity_count, std::vector<int>& local_of, ImpactDerivatives& out) {
  std::vector<ContactPoint> points;
  makeContactPoints(scene, contact_bodies, points);
  ContactProblem problem;
  problem.buildImpact(before, points, report.contacts);
  const std::size_t m = report.contacts.size();
  std::vector<bool> coefficients(3 * m, true);
  for (std::size_t i = 0; i < m; ++i) {
    for (int k = 0; k < 3; ++k) {
      coefficients[3 * i + static_cast<std::size_t>(k)] =
          columns.wantsCoefficient(3 * static_cast<Index>(report.contacts[i]) + k);
    }
  }
  // The call's time budget: a dual run out of time refuses, and the differences then throw.
  SolverOptions timed = options;
  timed.deadline = deadline;
  SimultaneousImpulseDerivatives d;
  if (!differentiateSimultaneousImpulseSpace(problem, timed, columns.velocities, coefficients, d)) {
    return false;
  }
  IslandSystem& s = threadDerivativeScratch().system;
  buildSystem(report.contacts, scene, contact_bodies, before, out.result, local_of, s);
  double scale = 0.0, error = 0.0;
  for (std::size_t i = 0; i < m; ++i) {
    const Vector3d& P = s.state[i].P;
    scale = std::max(scale, P.norm());
    error = std::max(error, (d.impulses.segment<3>(3 * static_cast<Index>(i)) - P).norm());
  }
  if (!(error <= 1e-9 * scale)) return false;
  // The island's scales: its fastest normal approach or separation, its largest normal impulse.
  double speed = 0.0, normal_scale = 0.0;
  for (const int c : report.contacts) {
    speed = std::max(speed, std::abs(out.result.impulses[c].normal_velocity_before));
    normal_scale = std::max(normal_scale, out.result.impulses[c].normal_impulse);
  }
  for (std::size_t i = 0; i < m; ++i) {
    const int c = report.contacts[i];
    const ContactImpulse& impulse = out.result.impulses[c];
    ContactDerivativeMode& mode = out.contacts[c];
    mode = ContactDerivativeMode{};
    mode.mode = impulse.normal_impulse <= 0.0 ? ImpactMode::kNoImpulse
                : impulse.sticking            ? ImpactMode::kSticking
                                              : ImpactMode::kSliding;
    if (!d.switches[i].empty()) flagSwitch(mode, d.switches[i]);
    // The integration's own end states near a branch (as the Newton island flags them): a contact
    // touching before (an approach starts its compression, a separation leaves it idle), one left
    // touching without an impulse, one active with a vanishing impulse.
    if (std::abs(impulse.normal_velocity_before) <= kSwitchTolerance * speed) {
      flagSwitch(mode, "u_n = 0: touching before the impact; compressing or idle");
    }
    if (mode.mode == ImpactMode::kNoImpulse &&
        std::abs(impulse.normal_velocity_after) <= kSwitchTolerance * speed) {
      flagSwitch(mode, "u'_n = 0 with P_n = 0: separating/active; no-impulse side");
    }
    if (mode.mode != ImpactMode::kNoImpulse &&
        impulse.normal_impulse <= kSwitchTolerance * normal_scale) {
      flagSwitch(mode, "P_n = 0 while active; active side");
    }
  }
  const MatrixXd dP_dv = columns.velocities ? MatrixXd(d.dP_du * s.J) : MatrixXd();
  scatter(s, dP_dv, d.dP_dtheta, columns.velocities, body_column, velocity_count, out.jacobian);
  return true;
}

}  // namespace

const char* toString(DerivativeMethod method) {
  return method == DerivativeMethod::kAnalytic ? "analytic" : "finite_difference";
}

const char* toString(ImpactMode mode) {
  switch (mode) {
    case ImpactMode::kNoImpulse:
      return "no_impulse";
    case ImpactMode::kSticking:
      return "sticking";
    case ImpactMode::kSliding:
      return "sliding";
  }
  return "unknown";
}

namespace {
// Labels "prefix[index].part" built in a buffer, each allocated once with its exact length: the
// labels are built per call of the linear uncertainty, where their allocations are a visible part
// of the cost.
class LabelWriter {
 public:
  // Starts the labels of "prefix[index].".
  void start(std::string_view prefix, std::size_t index) {
    std::memcpy(buffer_, prefix.data(), prefix.size());
    char* at = buffer_ + prefix.size();
    *at++ = '[';
    at = std::to_chars(at, buffer_ + kIndexEnd, index).ptr;
    *at++ = ']';
    *at++ = '.';
    stem_ = static_cast<std::size_t>(at - buffer_);
  }
  // Appends "prefix[index]." + part to `labels`.
  void add(std::string_view part, std::vector<std::string>& labels) {
    std::memcpy(buffer_ + stem_, part.data(), part.size());
    labels.emplace_back(buffer_, stem_ + part.size());
  }

 private:
  static constexpr std::size_t kIndexEnd = 40;  // prefixes are short: room for 20 digits
  char buffer_[kIndexEnd + 2 + 32];             // "]." and the longest part
  std::size_t stem_ = 0;
};
}  // namespace

std::vector<std::string> ImpactDerivatives::rowLabels() const {
  static constexpr std::array<std::string_view, 6> kTwist = {"twist.linear.x",  "twist.linear.y",
                                                             "twist.linear.z",  "twist.angular.x",
                                                             "twist.angular.y", "twist.angular.z"};
  static constexpr std::array<std::string_view, 4> kImpulse = {
      "normal_impulse", "friction_impulse.x", "friction_impulse.y", "friction_impulse.z"};
  std::vector<std::string> labels;
  labels.reserve(static_cast<std::size_t>(jacobian.rows()));
  LabelWriter writer;
  for (const int b : movable_bodies) {
    writer.start("bodies", static_cast<std::size_t>(b));
    for (const std::string_view part : kTwist) writer.add(part, labels);
  }
  for (std::size_t c = 0; c < contact_count; ++c) {
    writer.start("impulses", c);
    for (const std::string_view part : kImpulse) writer.add(part, labels);
  }
  return labels;
}

std::vector<std::string> ImpactDerivatives::columnLabels() const {
  std::vector<std::string> labels;
  labels.reserve(static_cast<std::size_t>(jacobian.cols()));
  for (const int b : movable_bodies) {
    const std::string name = "bodies[" + std::to_string(b) + "].twist.";
    for (const char* part : {"linear.", "angular."}) {
      for (const char* axis : {"x", "y", "z"}) labels.push_back(name + part + axis);
    }
  }
  for (std::size_t c = 0; c < contact_count; ++c) {
    const std::string name = "contacts[" + std::to_string(c) + "].";
    for (const char* field : {"restitution", "static_friction", "dynamic_friction"}) {
      labels.push_back(name + field);
    }
  }
  return labels;
}

ImpactDerivatives computeImpactDerivatives(const Scene& scene, const SolverOptions& options,
                                           const RequestLimits& limits) {
  return computeValidatedImpactDerivatives(scene, validate(scene, options, limits), options, {});
}

ImpactDerivatives computeValidatedImpactDerivatives(
    const Scene& scene, const std::vector<std::pair<int, int>>& contact_bodies,
    const SolverOptions& options, const DerivativeColumns& columns) {
  ImpactDerivatives out;
  computeValidatedImpactDerivatives(scene, contact_bodies, options, columns, out);
  return out;
}

void computeValidatedImpactDerivatives(const Scene& scene,
                                       const std::vector<std::pair<int, int>>& contact_bodies,
                                       const SolverOptions& options,
                                       const DerivativeColumns& columns, ImpactDerivatives& out) {
  if (!columns.coefficients.empty() && columns.coefficients.size() != 3 * scene.contacts.size()) {
    throw std::invalid_argument(
        "computeValidatedImpactDerivatives: one coefficient column flag per coefficient");
  }
  // One time budget for the whole call: the prediction and every perturbed solve.
  const Deadline deadline = Deadline::in(options.time_budget);
  const std::chrono::steady_clock::time_point end = deadline.end();
  out.result = computeValidatedResponse(scene, contact_bodies, options);
  out.contact_count = scene.contacts.size();
  out.contacts.assign(scene.contacts.size(), ContactDerivativeMode{});
  out.movable_bodies.clear();
  out.method = DerivativeMethod::kAnalytic;

  DerivativeScratch& scratch = threadDerivativeScratch();
  std::vector<RigidBody>& before = scratch.before;
  makeRigidBodies(scene.bodies, before);
  std::vector<Index>& body_column = scratch.body_column;
  body_column.assign(scene.bodies.size(), -1);
  for (std::size_t b = 0; b < scene.bodies.size(); ++b) {
    if (before[b].movable()) {
      body_column[b] = out.velocityCount();
      out.movable_bodies.push_back(static_cast<int>(b));
    }
  }
  const Index velocity_count = out.velocityCount();
  if (columns.velocities) {
    out.jacobian.setZero(velocity_count + out.impulseCount(),
                         velocity_count + out.coefficientCount());
    // Bodies the impacts leave alone (and every body before its island is differentiated): v' = v.
    out.jacobian.topLeftCorner(velocity_count, velocity_count).setIdentity();
  } else {
    // The velocity columns are set to 0 at the end (the closed forms write them).
    out.jacobian.resize(velocity_count + out.impulseCount(),
                        velocity_count + out.coefficientCount());
    // Column by column: short fills (one block of a few KB is a byte-wise `rep stosb` in glibc's
    // memset, each byte an instruction to callgrind's count of the linear uncertainty's cost).
    for (Index k = velocity_count; k < out.jacobian.cols(); ++k) out.jacobian.col(k).setZero();
  }

  std::vector<int>& local_of = scratch.local_of;
  local_of.assign(scene.bodies.size(), -1);
  std::vector<std::size_t> numerical;
  for (std::size_t k = 0; k < out.result.islands.size(); ++k) {
    const SolveReport& report = out.result.islands[k];
    if (!report.converged) {
      for (const int c : report.contacts) {
        flagSwitch(out.contacts[c],
                   "the island's solve did not converge (see result.islands): the "
                   "derivative is that of the answer given, not of a solution");
      }
    }
    // No impulse; a contact touching at u_n = 0 would start an impact if made to approach.
    if (markNoImpulseIsland(report, out.result.impulses, out.contacts)) continue;
    const AnalyticIsland kind = analyticIslandOf(report, options.law);
    if (kind == AnalyticIsland::kNewtonClosedForm || kind == AnalyticIsland::kImpulseSpaceContact) {
      const int c = report.contacts[0];
      if (singleContact(scene, c, contact_bodies[c], before, body_column, velocity_count, options,
                        out)) {
        continue;
      }
      out.contacts[c] = ContactDerivativeMode{};
    } else if (kind == AnalyticIsland::kImpulseSpaceIsland) {
      if (simultaneousIsland(scene, contact_bodies, report, options, deadline, columns, before,
                             body_column, velocity_count, local_of, out)) {
        continue;
      }
      for (const int c : report.contacts) out.contacts[c] = ContactDerivativeMode{};
    } else if (kind == AnalyticIsland::kNewtonExact) {
      IslandSystem& s = scratch.system;
      buildSystem(report.contacts, scene, contact_bodies, before, out.result, local_of, s);
      MatrixXd &dP_dv = scratch.dP_dv, &dP_dtheta = scratch.dP_dtheta;
      // The exact solver's answer came without a pivot (iterations 0) when every contact was
      // active and sticking inside its static cone (exact_solver.h).
      if (differentiateNewtonIsland(s, report.iterations == 0, columns, dP_dv, dP_dtheta,
                                    out.contacts)) {
        scatter(s, dP_dv, dP_dtheta, columns.velocities, body_column, velocity_count, out.jacobian);
        continue;
      }
    }
    numerical.push_back(k);
  }
  if (!numerical.empty()) {
    out.method = DerivativeMethod::kFiniteDifference;
    finiteDifferences(scene, contact_bodies, options, end, out.result, numerical, body_column,
                      velocity_count, columns, out);
  }
  // The closed forms fill every column: those not asked for are 0, as documented.
  if (!columns.velocities) out.jacobian.leftCols(velocity_count).setZero();
  for (std::size_t k = 0; k < columns.coefficients.size(); ++k) {
    if (!columns.coefficients[k])
      out.jacobian.col(velocity_count + static_cast<Index>(k)).setZero();
  }
}

}  // namespace collision_response::core
