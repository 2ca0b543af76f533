#include "collision_response/core/body_impact_derivatives.h"

#include <Eigen/QR>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <tuple>

#include "collision_response/core/errors.h"
#include "collision_response/core/impulse_space_derivatives.h"
#include "collision_response/core/validation.h"

namespace collision_response::core {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

// Central differences: the step relative to the input's scale (truncation ~ step^2, round-off
// ~ 1e-16 / step).
constexpr double kStep = 1e-6;

// (A null body, which computeBodyResponse() refuses when a contact names it, has no velocity.)
std::vector<VectorXd> velocities(const std::vector<BodyModel*>& bodies) {
  std::vector<VectorXd> out;
  out.reserve(bodies.size());
  for (const BodyModel* body : bodies) out.push_back(body ? body->velocity() : VectorXd());
  return out;
}

void setVelocities(const std::vector<BodyModel*>& bodies, const std::vector<VectorXd>& v) {
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    if (bodies[b] != nullptr && bodies[b]->velocityCount() > 0)
      bodies[b]->addVelocityChange(v[b] - bodies[b]->velocity());
  }
}

// The contacts as the solver sees them: a normal accepted within kUnitTolerance of unit length is
// normalised (computeBodyResponse() does the same), so that the analytic rows use the same n.
std::vector<ContactPoint> normalized(const std::vector<ContactPoint>& given) {
  std::vector<ContactPoint> contacts = given;
  for (ContactPoint& contact : contacts) {
    const double norm = contact.normal.norm();
    if (norm != 1.0 && std::abs(norm - 1.0) <= kUnitTolerance) contact.normal /= norm;
  }
  return contacts;
}

// The outputs (rows of the layout) of one solve from the velocities `before`.
// `end`: when the call's one time budget (options.time_budget, from the start of
// computeBodyImpactDerivatives()) runs out; each perturbed solve gets what is left of it.
VectorXd evaluate(const std::vector<BodyModel*>& bodies, const std::vector<ContactPoint>& contacts,
                  const SolverOptions& options, std::chrono::steady_clock::time_point end,
                  const std::vector<VectorXd>& before, const std::vector<int>& offset,
                  Index velocity_count) {
  SolverOptions remaining = options;
  remaining.time_budget =
      std::chrono::duration<double>(end - std::chrono::steady_clock::now()).count();
  if (!(remaining.time_budget > 0.0)) {
    throw SolverTimeout("the derivatives' finite differences exceeded the time budget of " +
                        std::to_string(options.time_budget) + " s");
  }
  setVelocities(bodies, before);
  const BodyResponse result = computeBodyResponse(bodies, contacts, remaining);
  VectorXd out(velocity_count + 4 * static_cast<Index>(contacts.size()));
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    if (offset[b] >= 0) out.segment(offset[b], bodies[b]->velocityCount()) = bodies[b]->velocity();
  }
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    const Index row = velocity_count + 4 * static_cast<Index>(c);
    out(row) = result.impulses[c].normal_impulse;
    out.segment<3>(row + 1) = result.impulses[c].friction_impulse;
  }
  return out;
}

ImpactMode modeOf(const ContactImpulse& impulse) {
  if (!(impulse.normal_impulse > 0.0)) return ImpactMode::kNoImpulse;
  return impulse.sticking ? ImpactMode::kSticking : ImpactMode::kSliding;
}

}  // namespace

BodyImpactDerivatives computeBodyImpactDerivatives(const std::vector<BodyModel*>& bodies,
                                                   const std::vector<ContactPoint>& given,
                                                   const SolverOptions& options) {
  const std::vector<ContactPoint> contacts = normalized(given);
  BodyImpactDerivatives out;
  out.velocity_offset.assign(bodies.size(), -1);
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    if (bodies[b] != nullptr && bodies[b]->velocityCount() > 0) {
      out.velocity_offset[b] = static_cast<int>(out.velocity_count);
      out.velocity_count += bodies[b]->velocityCount();
    }
  }
  // One time budget for the whole call: the prediction and every perturbed solve.
  const auto end = std::chrono::steady_clock::now() +
                   std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                       std::chrono::duration<double>(options.time_budget));
  const std::vector<VectorXd> before = velocities(bodies);
  out.result = computeBodyResponse(bodies, contacts, options);  // validates
  const std::vector<VectorXd> after = velocities(bodies);
  const Index N = out.velocity_count, C = static_cast<Index>(contacts.size());
  out.contact_count = contacts.size();
  out.jacobian.setZero(N + 4 * C, N + 3 * C);
  out.jacobian.topLeftCorner(N, N).setIdentity();
  out.contacts.resize(contacts.size());
  for (std::size_t c = 0; c < contacts.size(); ++c)
    out.contacts[c].mode = modeOf(out.result.impulses[c]);

  const bool frictionless = std::all_of(contacts.begin(), contacts.end(),
                                        [](const ContactPoint& c) { return c.frictionless(); });
  // The active-set formula holds where the answer is exact: every island solved in closed form or
  // by the exact solver (not by the iterative one, which kAuto takes beyond
  // kExactSolverMaxContacts, and not as resting contacts, whose answer is forces).
  const bool exact_islands =
      std::all_of(out.result.islands.begin(), out.result.islands.end(), [](const SolveReport& r) {
        return r.method == SolvedBy::kNone || r.method == SolvedBy::kClosedForm ||
               r.method == SolvedBy::kExact;
      });
  // One contact under an impulse-space law, integrated to its end: its impulse is a function of
  // its 3x3 W = J M^-1 J^T and u = J v (+ the part of bodies without unknowns), so
  // dv'/dv = I + M^-1 J^T (dP/du) J and dv'/dtheta = M^-1 J^T dP/dtheta, dP from the sensitivity
  // of the integration (impulse_space_derivatives.h).
  bool single_impulse_space = false;
  if ((options.law == ImpactLaw::kPoisson || options.law == ImpactLaw::kStronge) && C == 1 &&
      out.result.islands.size() == 1) {
    const SolveReport& report = out.result.islands[0];
    const bool integrated = (report.method == SolvedBy::kImpulseSpace ||
                             report.method == SolvedBy::kSimultaneousImpulseSpace) &&
                            report.converged &&
                            !(report.impulse_space && report.impulse_space->fallback);
    if (integrated) {
      const ContactPoint& contact = contacts[0];
      Eigen::Matrix<double, 3, Eigen::Dynamic> J = Eigen::MatrixXd::Zero(3, N);
      Eigen::Matrix<double, Eigen::Dynamic, 3> MinvJt = Eigen::MatrixXd::Zero(N, 3);
      Eigen::Vector3d u = Eigen::Vector3d::Zero();
      for (const auto& [body, part, sign] : {std::tuple{contact.body_a, contact.part_a, -1.0},
                                             std::tuple{contact.body_b, contact.part_b, 1.0}}) {
        const int offset = out.velocity_offset[body];
        if (offset < 0) {
          u += sign * bodies[body]->partPointVelocity(part, contact.point);
          continue;
        }
        const int n = bodies[body]->velocityCount();
        const Eigen::Matrix<double, 3, Eigen::Dynamic> Jb =
            bodies[body]->partPointJacobian(part, contact.point);
        J.middleCols(offset, n) += sign * Jb;
        u += sign * (Jb * before[body]);
        MinvJt.middleRows(offset, n) +=
            sign * bodies[body]->partInverseMassJacobianTranspose(part, contact.point);
      }
      const Eigen::Matrix3d W = J * MinvJt;
      Eigen::Matrix3d dP_du, dP_dtheta;
      ContactDerivativeMode mode;
      if (differentiateImpulseSpace(contact.normal, W, u, contact.restitution,
                                    contact.static_friction, contact.dynamic_friction, options.law,
                                    options.integration_tolerance, dP_du, dP_dtheta, mode)) {
        Eigen::Matrix<double, 4, 3> impulse_of_P;  // (normal_impulse, friction_impulse) of P
        impulse_of_P.row(0) = contact.normal.transpose();
        impulse_of_P.bottomRows<3>() =
            Eigen::Matrix3d::Identity() - contact.normal * contact.normal.transpose();
        const MatrixXd dP_dv = dP_du * J;
        out.jacobian.topLeftCorner(N, N) += MinvJt * dP_dv;
        out.jacobian.block(0, N, N, 3) = MinvJt * dP_dtheta;
        out.jacobian.block(N, 0, 4, N) = impulse_of_P * dP_dv;
        out.jacobian.block<4, 3>(N, N) = impulse_of_P * dP_dtheta;
        out.contacts[0] = mode;
        single_impulse_space = true;
      }
    }
  }
  const bool analytic = options.law == ImpactLaw::kNewton && frictionless && exact_islands;
  std::vector<Index> fd_columns;  // columns taken by central differences
  if (analytic) {
    // Along the normals: j_i = n_i^T (J_b - J_a) (1 x N), MinvJ column i = M^-1 j_i^T.
    std::vector<Index> active;
    for (Index c = 0; c < C; ++c)
      if (out.result.impulses[c].normal_impulse > 0.0) active.push_back(c);
    const Index m = static_cast<Index>(active.size());
    MatrixXd J = MatrixXd::Zero(m, N), MinvJt = MatrixXd::Zero(N, m);
    VectorXd u(m), e(m);
    for (Index i = 0; i < m; ++i) {
      const ContactPoint& contact = contacts[active[i]];
      for (const auto& [body, part, sign] : {std::tuple{contact.body_a, contact.part_a, -1.0},
                                             std::tuple{contact.body_b, contact.part_b, 1.0}}) {
        const int offset = out.velocity_offset[body];
        if (offset < 0) continue;
        const int n = bodies[body]->velocityCount();
        J.block(i, offset, 1, n) += sign * contact.normal.transpose() *
                                    bodies[body]->partPointJacobian(part, contact.point);
        MinvJt.block(offset, i, n, 1) +=
            sign * bodies[body]->partInverseMassJacobianTranspose(part, contact.point) *
            contact.normal;
      }
      // Newton's target -e u_n for an approaching contact, 0 for one that is pushed without
      // approaching (physics.md, "Several contacts"): then e plays no part.
      u(i) = out.result.impulses[active[i]].normal_velocity_before;
      e(i) = u(i) < 0.0 ? contact.restitution : 0.0;
    }
    if (m > 0) {
      const MatrixXd W = J * MinvJt;
      const Eigen::CompleteOrthogonalDecomposition<MatrixXd> cod(W);
      // dP/dv = -W^+ diag(1 + e) J;  dP/de_i = -W^+ 1_i u_i.
      const MatrixXd dP_dv = -cod.solve((VectorXd::Ones(m) + e).asDiagonal() * J);
      VectorXd u_approaching = u;
      for (Index i = 0; i < m; ++i)
        if (!(u(i) < 0.0)) u_approaching(i) = 0.0;
      const MatrixXd dP_de = -cod.solve(MatrixXd(u_approaching.asDiagonal()));
      out.jacobian.topLeftCorner(N, N) += MinvJt * dP_dv;
      for (Index i = 0; i < m; ++i) {
        const Index col = N + 3 * active[i];
        out.jacobian.block(0, col, N, 1) = MinvJt * dP_de.col(i);
        for (Index k = 0; k < m; ++k) {
          const Index row = N + 4 * active[k];
          out.jacobian.block(row, 0, 1, N) = dP_dv.row(k);
          out.jacobian(row, col) = dP_de(k, i);
        }
      }
    }
    for (Index c = 0; c < C; ++c) {
      out.contacts[c].method = DerivativeMethod::kAnalytic;
      if (out.result.impulses[c].normal_impulse > 0.0) {
        // Friction raised from 0: one-sided differences of the solver.
        fd_columns.push_back(N + 3 * c + 1);
        fd_columns.push_back(N + 3 * c + 2);
        out.contacts[c].at_switch = true;
        out.contacts[c].switch_detail =
            "frictionless: the friction columns are one-sided (friction raised from 0), "
            "differenced";
      }
    }
  } else if (!single_impulse_space) {
    out.method = DerivativeMethod::kFiniteDifference;
    for (Index k = 0; k < N + 3 * C; ++k) fd_columns.push_back(k);
    for (ContactDerivativeMode& mode : out.contacts)
      mode.method = DerivativeMethod::kFiniteDifference;
  }

  // Differences of the solver itself, column by column.
  const auto solve = [&](const std::vector<VectorXd>& v, const std::vector<ContactPoint>& cs) {
    return evaluate(bodies, cs, options, end, v, out.velocity_offset, N);
  };
  for (const Index column : fd_columns) {
    std::vector<VectorXd> v_plus = before, v_minus = before;
    std::vector<ContactPoint> c_plus = contacts, c_minus = contacts;
    double h = 0.0;
    bool central = true;
    if (column < N) {
      std::size_t b = 0;
      while (!(out.velocity_offset[b] >= 0 && column >= out.velocity_offset[b] &&
               column < out.velocity_offset[b] + bodies[b]->velocityCount()))
        ++b;
      const Index k = column - out.velocity_offset[b];
      h = kStep * std::max(1.0, before[b].cwiseAbs().maxCoeff());
      v_plus[b](k) += h;
      v_minus[b](k) -= h;
    } else {
      const Index c = (column - N) / 3, which = (column - N) % 3;
      ContactPoint& p = c_plus[c];
      ContactPoint& q = c_minus[c];
      h = kStep;
      if (which == 0) {  // e in [0, 1]
        central = p.restitution - h >= 0.0 && p.restitution + h <= 1.0;
        if (p.restitution + h > 1.0) h = -h;
        p.restitution += h;
        q.restitution -= h;
      } else if (which == 1) {  // mu_s >= mu_d
        central = p.static_friction - h >= p.dynamic_friction;
        p.static_friction += h;
        q.static_friction -= h;
      } else {  // 0 <= mu_d <= mu_s; at mu_d = mu_s, mu_s rises with it (one-sided)
        central = p.dynamic_friction - h >= 0.0 && p.dynamic_friction + h <= p.static_friction;
        p.dynamic_friction += h;
        p.static_friction = std::max(p.static_friction, p.dynamic_friction);
        q.dynamic_friction -= h;
      }
    }
    const VectorXd plus = solve(v_plus, c_plus);
    if (central) {
      out.jacobian.col(column) = (plus - solve(v_minus, c_minus)) / (2.0 * h);
    } else {
      out.jacobian.col(column) = (plus - solve(before, contacts)) / h;
      if (column >= N) {
        ContactDerivativeMode& mode = out.contacts[(column - N) / 3];
        mode.at_switch = true;
        if (mode.switch_detail.find("bound") == std::string::npos) {
          if (!mode.switch_detail.empty()) mode.switch_detail += "; ";
          mode.switch_detail += "a coefficient at its bound: its column is one-sided";
        }
      }
    }
  }
  setVelocities(bodies, after);  // the prediction's velocities, as computeBodyResponse() leaves
  return out;
}

}  // namespace collision_response::core
