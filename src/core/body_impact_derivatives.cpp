#include "collision_response/core/body_impact_derivatives.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <tuple>
#include <utility>

#include "collision_response/core/approach_warnings.h"
#include "collision_response/core/contact_derivatives.h"
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

// The bodies' velocity unknowns stacked as the layout has them (body b's from offset[b]; -1: a
// body without unknowns, or null, which computeBodyResponse() refuses when a contact names it).
VectorXd velocities(const std::vector<BodyModel*>& bodies, const std::vector<int>& offset,
                    Index count) {
  VectorXd v(count);
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    if (offset[b] >= 0) v.segment(offset[b], bodies[b]->velocityCount()) = bodies[b]->velocity();
  }
  return v;
}

void setVelocities(const std::vector<BodyModel*>& bodies, const std::vector<int>& offset,
                   const VectorXd& v) {
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    if (offset[b] >= 0) {
      bodies[b]->addVelocityChange(v.segment(offset[b], bodies[b]->velocityCount()) -
                                   bodies[b]->velocity());
    }
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

ImpactMode modeOf(const ContactImpulse& impulse) {
  if (!(impulse.normal_impulse > 0.0)) return ImpactMode::kNoImpulse;
  return impulse.sticking ? ImpactMode::kSticking : ImpactMode::kSliding;
}

// The outputs (rows of the layout) of one solve from the velocities `before`.
// `end`: when the call's one time budget (options.time_budget, from the start of
// computeBodyImpactDerivatives()) runs out; each perturbed solve gets what is left of it.
// `modes` (if given) receives each contact's mode in that solve.
VectorXd evaluate(const std::vector<BodyModel*>& bodies, const std::vector<ContactPoint>& contacts,
                  const SolverOptions& options, std::chrono::steady_clock::time_point end,
                  const VectorXd& before, const std::vector<int>& offset, Index velocity_count,
                  std::vector<ImpactMode>* modes = nullptr) {
  SolverOptions remaining = options;
  remaining.time_budget =
      std::chrono::duration<double>(end - std::chrono::steady_clock::now()).count();
  if (!(remaining.time_budget > 0.0)) {
    throw SolverTimeout("the derivatives' finite differences exceeded the time budget of " +
                        std::to_string(options.time_budget) + " s");
  }
  setVelocities(bodies, offset, before);
  const BodyResponse result = computeBodyResponse(bodies, contacts, remaining);
  VectorXd out(velocity_count + 4 * static_cast<Index>(contacts.size()));
  out.head(velocity_count) = velocities(bodies, offset, velocity_count);
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    const Index row = velocity_count + 4 * static_cast<Index>(c);
    out(row) = result.impulses[c].normal_impulse;
    out.segment<3>(row + 1) = result.impulses[c].friction_impulse;
  }
  if (modes != nullptr) {
    modes->clear();
    for (const ContactImpulse& impulse : result.impulses) modes->push_back(modeOf(impulse));
  }
  return out;
}

// The contacts of one island in contact space over all the bodies' unknowns (N columns, the
// layout's): rows 3i..3i+2 of J = J_b - J_a at contact i's point (J(p) of each side with
// unknowns), M^-1 J^T, u = J v + the velocity of a side without unknowns and the part of a side's
// point velocity its unknowns do not give (a robot's locked joints), before (`before`) and
// after (`after`, the prediction's) the impact, the impulse and the coefficients.
NewtonIsland contactSpace(const std::vector<BodyModel*>& bodies,
                          const std::vector<ContactPoint>& contacts, const std::vector<int>& island,
                          const std::vector<int>& offset, Index N, const VectorXd& before,
                          const VectorXd& after, const BodyResponse& result) {
  NewtonIsland s;
  s.contacts = island;
  const Index m = static_cast<Index>(island.size());
  s.J.setZero(3 * m, N);
  s.MinvJt.setZero(N, 3 * m);
  s.state.resize(island.size());
  for (Index i = 0; i < m; ++i) {
    const int c = island[i];
    const ContactPoint& contact = contacts[c];
    Eigen::Vector3d prescribed = Eigen::Vector3d::Zero();
    for (const auto& [body, part, sign] : {std::tuple{contact.body_a, contact.part_a, -1.0},
                                           std::tuple{contact.body_b, contact.part_b, 1.0}}) {
      if (offset[body] < 0) {
        prescribed += sign * bodies[body]->partPointVelocity(part, contact.point);
        continue;
      }
      const int n = bodies[body]->velocityCount();
      const Eigen::Matrix<double, 3, Eigen::Dynamic> J =
          bodies[body]->partPointJacobian(part, contact.point);
      s.J.block(3 * i, offset[body], 3, n) += sign * J;
      // What the unknowns do not give: a robot's locked joints moving at their kept velocities
      // (a free rigid body's point velocity is J v exactly).
      if (bodies[body]->asRigidBody() == nullptr) {
        prescribed += sign * (bodies[body]->partPointVelocity(part, contact.point) -
                              J * bodies[body]->velocity());
      }
      s.MinvJt.block(offset[body], 3 * i, n, 3) +=
          sign * bodies[body]->partInverseMassJacobianTranspose(part, contact.point);
    }
    NewtonContactState& state = s.state[static_cast<std::size_t>(i)];
    state.normal = contact.normal;
    state.u = s.J.middleRows<3>(3 * i) * before + prescribed;
    state.u_after = s.J.middleRows<3>(3 * i) * after + prescribed;
    const ContactImpulse& impulse = result.impulses[c];
    state.P = impulse.normal_impulse * contact.normal + impulse.friction_impulse;
    state.coefficients = {contact.restitution, contact.static_friction, contact.dynamic_friction};
  }
  return s;
}

// Writes an island's derivatives into the layout's Jacobian from dP/dv (3m x N) and dP/dtheta
// (3m x 3m, per contact e, mu_s, mu_d): dv'/dv += M^-1 J^T dP/dv, dv'/dtheta = M^-1 J^T dP/dtheta,
// and the impulse rows (normal_impulse = n.P, friction_impulse = (I - n n^T) P).
void scatter(const NewtonIsland& s, const MatrixXd& dP_dv, const MatrixXd& dP_dtheta, Index N,
             MatrixXd& jacobian) {
  const Index m = static_cast<Index>(s.contacts.size());
  // Contact by contact, as coefficient-wise products with an inner size of 3 fixed at compile
  // time: the matrices are small (N of a few dozen), where the blocked product's set-up costs
  // more than the product.
  for (Index j = 0; j < m; ++j) {
    const auto MinvJt_j = s.MinvJt.middleCols<3>(3 * j);
    jacobian.topLeftCorner(N, N).noalias() += MinvJt_j.lazyProduct(dP_dv.middleRows<3>(3 * j));
    for (Index k = 0; k < m; ++k) {
      const Index column = N + 3 * static_cast<Index>(s.contacts[k]);
      jacobian.block(0, column, N, 3).noalias() +=
          MinvJt_j.lazyProduct(dP_dtheta.block<3, 3>(3 * j, 3 * k));
    }
  }
  for (Index i = 0; i < m; ++i) {
    const Eigen::Vector3d& n = s.state[static_cast<std::size_t>(i)].normal;
    Eigen::Matrix<double, 4, 3> impulse_of_P;
    impulse_of_P.row(0) = n.transpose();
    impulse_of_P.bottomRows<3>() = Eigen::Matrix3d::Identity() - n * n.transpose();
    const Index row = N + 4 * static_cast<Index>(s.contacts[i]);
    jacobian.block(row, 0, 4, N).noalias() = impulse_of_P.lazyProduct(dP_dv.middleRows<3>(3 * i));
    for (Index j = 0; j < m; ++j) {
      jacobian.block<4, 3>(row, N + 3 * static_cast<Index>(s.contacts[j])).noalias() =
          impulse_of_P * dP_dtheta.block<3, 3>(3 * i, 3 * j);
    }
  }
}

// The sensitivity of a lone contact under Poisson or Stronge, taken before the prediction
// (predictLoneContact()): its contact space (J, M^-1 J^T taken once) and derivatives.
struct LoneContact {
  bool valid = false;
  NewtonIsland s;
  Eigen::Matrix3d dP_du, dP_dtheta;
  ContactDerivativeMode mode;
};

// A call with one contact under Poisson or Stronge that the automatic solver integrates alone
// (solveIsland(): one contact, contact by contact) and that approaches: its sensitivity
// (differentiateImpulseSpace()) carries the impulse itself, so the solver need not integrate the
// contact first. Where the sensitivity took no Dormand-Prince step (closed-form segments and the
// stick-approach series, the same closed forms as integrateSingleContact() at the same tolerance,
// in [1e-12, 1e-10], hence the prediction's answer to round-off), the prediction is written from it
// as solveIslands() writes it (impulses, effective mass, island report, warnings; the bodies'
// velocities) and true is returned. Otherwise (an integrated slip or one ended at the sensitivity's
// own threshold: the prediction's path differs; a contact that does not qualify) false: the caller
// predicts with computeBodyResponse(), and `lone` keeps the derivatives if they were taken.
bool predictLoneContact(const std::vector<BodyModel*>& bodies,
                        const std::vector<ContactPoint>& contacts, const SolverOptions& options,
                        const VectorXd& before, BodyImpactDerivatives& out, LoneContact& lone) {
  if (contacts.size() != 1 || options.method != SolverMethod::kAuto ||
      (options.law != ImpactLaw::kPoisson && options.law != ImpactLaw::kStronge)) {
    return false;
  }
  validateContactPoints(bodies, contacts);
  const ContactPoint& contact = contacts[0];
  if (out.velocity_offset[contact.body_a] < 0 && out.velocity_offset[contact.body_b] < 0) {
    return false;  // nothing moves: computeBodyResponse() reports it
  }
  const Index N = out.velocity_count;
  BodyResponse none;
  none.impulses.resize(1);
  lone.s = contactSpace(bodies, contacts, {0}, out.velocity_offset, N, before, before, none);
  NewtonIsland& s = lone.s;
  const Eigen::Vector3d u = s.state[0].u;
  const double u_n = contact.normal.dot(u);
  // Approaching beyond round-off (a touching contact goes to the resting solver).
  if (!(u_n < -1e-12 * u.norm())) return false;
  const Eigen::Matrix3d W = s.J.lazyProduct(s.MinvJt);
  Eigen::Vector3d P;
  ImpulseSpaceSensitivityDetail detail;
  if (!differentiateImpulseSpace(contact.normal, W, u, contact.restitution, contact.static_friction,
                                 contact.dynamic_friction, options.law,
                                 options.integration_tolerance, lone.dP_du, lone.dP_dtheta,
                                 lone.mode, &P, &detail) ||
      lone.mode.mode == ImpactMode::kNoImpulse) {
    return false;
  }
  lone.valid = true;
  const double tolerance = options.integration_tolerance;
  // Tolerances below 1e-12 bring the series' acceptance tests (the stop cancelling the slip to
  // tol |u_n|) within a few hundred ulps, where the two implementations' round-off can decide
  // them differently (the same answer to the tolerance, reached by different steps).
  if (detail.steps > 0 || detail.threshold_stop || !(tolerance >= 1e-12 && tolerance <= 1e-10)) {
    return false;
  }

  // The prediction, as solveIslands() and integrateSingleContact() write it.
  BodyResponse& result = out.result;
  result.impulses.assign(1, ContactImpulse{});
  ContactImpulse& impulse = result.impulses[0];
  impulse.normal_velocity_before = u_n;
  impulse.normal_impulse = P.dot(contact.normal);
  impulse.friction_impulse = P - impulse.normal_impulse * contact.normal;
  impulse.sticking = lone.mode.mode == ImpactMode::kSticking;
  const VectorXd after = before + s.MinvJt * P;
  setVelocities(bodies, out.velocity_offset, after);
  s.state[0].u_after = u + s.J * (after - before);
  s.state[0].P = P;
  impulse.normal_velocity_after = contact.normal.dot(s.state[0].u_after);
  const double w = contact.normal.dot(W * contact.normal);
  result.effective_masses.assign(1, w > 0.0 ? 1.0 / w : std::numeric_limits<double>::infinity());
  SolveReport report;
  report.method = SolvedBy::kImpulseSpace;
  report.contacts = {0};
  report.iterations = detail.steps + detail.segments;
  ImpulseSpaceDetail how;
  how.segments = detail.segments;
  how.compression_impulse = detail.compression_impulse;
  how.compression_work = detail.compression_work;
  how.series_order = static_cast<std::size_t>(detail.series_order);
  report.impulse_space = how;
  result.islands.assign(1, std::move(report));
  warnApproachingContacts(result.impulses, result.effective_masses, result.islands, options,
                          result.warnings);
  return true;
}

// The call's configuration coordinates, when every one names a body of the call that can
// differentiate by it (ConfigurationCoordinate::body, index): per coordinate that body's index in
// `bodies` and the coordinate's index among the body's own. `done` stays true while every island
// so far wrote its columns in closed form (analyticIsland()); otherwise the columns are
// differenced.
struct AnalyticCoordinates {
  std::vector<int> body, index;
  bool done = true;
};

std::optional<AnalyticCoordinates> analyticCoordinatesOf(
    const std::vector<BodyModel*>& bodies,
    const std::vector<ConfigurationCoordinate>& coordinates) {
  if (coordinates.empty()) return std::nullopt;
  AnalyticCoordinates out;
  for (const ConfigurationCoordinate& coordinate : coordinates) {
    const auto found = std::find(bodies.begin(), bodies.end(), coordinate.body);
    if (coordinate.body == nullptr || found == bodies.end() || coordinate.index < 0 ||
        coordinate.index >= coordinate.body->configurationCount()) {
      return std::nullopt;
    }
    out.body.push_back(static_cast<int>(found - bodies.begin()));
    out.index.push_back(coordinate.index);
  }
  return out;
}

// The call's columns of body b's coordinates: (the column, the body's own index).
std::vector<std::pair<Index, int>> ownColumns(const AnalyticCoordinates& coordinates, int b) {
  std::vector<std::pair<Index, int>> columns;
  for (std::size_t k = 0; k < coordinates.body.size(); ++k) {
    if (coordinates.body[k] == b) columns.emplace_back(static_cast<Index>(k), coordinates.index[k]);
  }
  return columns;
}

// An island's contact space moved by the configuration coordinates (docs/physics.md,
// "Derivatives with respect to a robot's joint positions"), at fixed impulses: `change.pre` the
// change of u, `change.post` that of u' = u + W P beyond it, and `moved` (N x Q) the change of the
// bodies' velocities after the impact, M^-1 (dJ^T P - dM (v' - v)). The bodies are at their
// velocities `after`, as the prediction leaves them.
void configurationChange(const std::vector<BodyModel*>& bodies,
                         const std::vector<ContactPoint>& contacts, const NewtonIsland& s,
                         const std::vector<int>& offset, const VectorXd& before,
                         const VectorXd& after, const AnalyticCoordinates& coordinates,
                         ConfigurationChange& change, MatrixXd& moved) {
  const Index m = static_cast<Index>(s.contacts.size()), N = s.J.cols();
  const Index Q = static_cast<Index>(coordinates.body.size());
  change.pre.setZero(3 * m, Q);
  change.post.setZero(3 * m, Q);
  moved.setZero(N, Q);
  for (std::size_t b = 0; b < bodies.size(); ++b) {
    const std::vector<std::pair<Index, int>> columns = ownColumns(coordinates, static_cast<int>(b));
    if (columns.empty()) continue;
    const BodyModel& body = *bodies[b];
    const int n = offset[b] >= 0 ? body.velocityCount() : 0;
    const VectorXd change_v = n > 0 ? VectorXd((after - before).segment(offset[b], n)) : VectorXd();
    MatrixXd g;  // dJ^T P - dM (v' - v), the body's own columns
    bool touched = false;
    for (Index i = 0; i < m; ++i) {
      const ContactPoint& contact = contacts[s.contacts[i]];
      const Eigen::Vector3d& P = s.state[static_cast<std::size_t>(i)].P;
      for (const auto& [side, part, sign] : {std::tuple{contact.body_a, contact.part_a, -1.0},
                                             std::tuple{contact.body_b, contact.part_b, 1.0}}) {
        if (side != static_cast<int>(b)) continue;
        if (!touched) {
          touched = true;
          if (n > 0) g = -body.massMatrixProductByConfiguration(change_v);
        }
        Eigen::Matrix<double, 3, Eigen::Dynamic> pre =
            body.partPointVelocityByConfiguration(part, contact.point);
        Eigen::Matrix<double, 3, Eigen::Dynamic> post;
        if (n > 0) {
          post = body.partJacobianProductByConfiguration(part, contact.point, change_v);
          pre -= post;  // the body's motion is read at `after`: before it, dJ (v' - v) less
          g += sign * body.partJacobianTransposeProductByConfiguration(part, contact.point, P);
        }
        for (const auto& [k, own] : columns) {
          change.pre.block<3, 1>(3 * i, k) += sign * pre.col(own);
          if (n > 0) change.post.block<3, 1>(3 * i, k) += sign * post.col(own);
        }
      }
    }
    if (!touched || n == 0) continue;
    const MatrixXd dv = body.inverseMassTimes(g);
    for (const auto& [k, own] : columns) moved.block(offset[b], k, n, 1) = dv.col(own);
  }
  change.post.noalias() += s.J * moved;
}

// dK = d(J M^-1 J^T) of a lone contact along each configuration coordinate (3 x 3 each):
// dJ M^-1 J^T + J M^-1 dJ^T - J M^-1 dM M^-1 J^T, body by body (the coordinates' bodies).
std::vector<Eigen::Matrix3d> contactMassChange(const std::vector<BodyModel*>& bodies,
                                               const ContactPoint& contact, const NewtonIsland& s,
                                               const std::vector<int>& offset,
                                               const AnalyticCoordinates& coordinates) {
  const Index Q = static_cast<Index>(coordinates.body.size());
  std::vector<Eigen::Matrix3d> dK(static_cast<std::size_t>(Q), Eigen::Matrix3d::Zero());
  // Each body once (a robot's two links touching each other: both sides, one body).
  const int sides = contact.body_a == contact.body_b ? 1 : 2;
  for (int side_index = 0; side_index < sides; ++side_index) {
    const int b = side_index == 0 ? contact.body_a : contact.body_b;
    const BodyModel& body = *bodies[b];
    const int n = offset[b] >= 0 ? body.velocityCount() : 0;
    if (n == 0) continue;  // no unknowns: K does not depend on it
    const std::vector<std::pair<Index, int>> columns = ownColumns(coordinates, b);
    if (columns.empty()) continue;
    const MatrixXd X = s.MinvJt.block(offset[b], 0, n, 3);  // this body's M^-1 J^T
    const MatrixXd J = s.J.block(0, offset[b], 3, n);
    for (int j = 0; j < 3; ++j) {
      MatrixXd h = -body.massMatrixProductByConfiguration(X.col(j));  // n x the body's own
      Eigen::Matrix<double, 3, Eigen::Dynamic> dJX =
          Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, h.cols());
      for (const auto& [side, part, sign] : {std::tuple{contact.body_a, contact.part_a, -1.0},
                                             std::tuple{contact.body_b, contact.part_b, 1.0}}) {
        if (side != b) continue;
        dJX += sign * body.partJacobianProductByConfiguration(part, contact.point, X.col(j));
        h += sign * body.partJacobianTransposeProductByConfiguration(part, contact.point,
                                                                     Eigen::Vector3d::Unit(j));
      }
      const Eigen::Matrix<double, 3, Eigen::Dynamic> column = dJX + J * body.inverseMassTimes(h);
      for (const auto& [k, own] : columns)
        dK[static_cast<std::size_t>(k)].col(j) += column.col(own);
    }
  }
  return dK;
}

// Writes an island's configuration columns (the last Q of out.jacobian): the velocities after,
// `moved` + M^-1 J^T dP/dq, and the island's impulse rows.
void scatterCoordinates(const NewtonIsland& s, const MatrixXd& moved, const MatrixXd& dP_dq,
                        Index N, Index C, MatrixXd& jacobian) {
  const Index Q = moved.cols(), first = N + 3 * C;
  jacobian.block(0, first, N, Q) += moved + s.MinvJt * dP_dq;
  for (std::size_t i = 0; i < s.contacts.size(); ++i) {
    const Eigen::Vector3d& n = s.state[i].normal;
    const Index row = N + 4 * static_cast<Index>(s.contacts[i]);
    const auto dP = dP_dq.middleRows<3>(3 * static_cast<Index>(i));
    jacobian.block(row, first, 1, Q) = n.transpose() * dP;
    jacobian.block(row + 1, first, 3, Q) = (Eigen::Matrix3d::Identity() - n * n.transpose()) * dP;
  }
}

// The configuration columns of one contact integrated in impulse space (Poisson, Stronge): the
// sensitivity with K's entries too (differentiateImpulseSpaceByK()), dP = dP/du du + dP/dK dK,
// written like the Newton islands'. False if the sensitivity refuses (the caller differences).
bool impulseSpaceCoordinates(const std::vector<BodyModel*>& bodies,
                             const std::vector<ContactPoint>& contacts, const SolveReport& report,
                             const SolverOptions& options, const VectorXd& before,
                             const VectorXd& after, BodyImpactDerivatives& out,
                             const AnalyticCoordinates& coordinates) {
  const Index N = out.velocity_count;
  const NewtonIsland s = contactSpace(bodies, contacts, report.contacts, out.velocity_offset, N,
                                      before, after, out.result);
  ConfigurationChange change;
  MatrixXd moved;
  configurationChange(bodies, contacts, s, out.velocity_offset, before, after, coordinates, change,
                      moved);
  const ContactPoint& contact = contacts[report.contacts[0]];
  const std::vector<Eigen::Matrix3d> dK =
      contactMassChange(bodies, contact, s, out.velocity_offset, coordinates);
  Eigen::Matrix<double, 3, Eigen::Dynamic> dP_dK;
  Eigen::Matrix3d dP_du;
  ContactDerivativeMode mode;
  if (!differentiateImpulseSpaceByK(contact.normal, s.J.lazyProduct(s.MinvJt), s.state[0].u,
                                    contact.restitution, contact.static_friction,
                                    contact.dynamic_friction, options.law,
                                    options.integration_tolerance, dK, dP_dK, dP_du, mode) ||
      mode.mode != modeOf(out.result.impulses[report.contacts[0]])) {
    return false;  // (a mode other than the prediction's: the two runs disagree at a switch)
  }
  scatterCoordinates(s, moved, dP_du * change.pre + dP_dK, N, static_cast<Index>(contacts.size()),
                     out.jacobian);
  return true;
}

// The analytic derivative of one island (docs/physics.md, "General bodies (robots)"), written
// into out.jacobian and out.contacts: Newton's closed form (one contact) or the exact solver's
// final mode, or one contact integrated in impulse space (Poisson, Stronge). False where the
// island is differenced instead (another solver, a singular K, redundant contacts sliding with
// friction, an integration that fell back).
// `coordinates` (if given): the configuration columns too, in closed form for Newton's law
// (coordinates->done set false where they cannot be: the impulse-space laws, redundant contacts).
bool analyticIsland(const std::vector<BodyModel*>& bodies,
                    const std::vector<ContactPoint>& contacts, const SolveReport& report,
                    const SolverOptions& options, const VectorXd& before, const VectorXd& after,
                    const LoneContact& lone, BodyImpactDerivatives& out,
                    AnalyticCoordinates* coordinates) {
  const Index N = out.velocity_count;
  const Index C = static_cast<Index>(contacts.size());
  const AnalyticIsland kind = analyticIslandOf(report, options.law);
  // Several contacts integrated together: differenced for general bodies (the rigid path
  // differentiates the integration, impact_derivatives.cpp).
  if (kind == AnalyticIsland::kNone || kind == AnalyticIsland::kImpulseSpaceIsland) return false;
  if (kind == AnalyticIsland::kImpulseSpaceContact && coordinates != nullptr && coordinates->done &&
      !impulseSpaceCoordinates(bodies, contacts, report, options, before, after, out,
                               *coordinates)) {
    coordinates->done = false;
  }
  if (kind == AnalyticIsland::kImpulseSpaceContact && lone.valid) {
    // Taken before the prediction (predictLoneContact()), on the same contact space.
    out.contacts[report.contacts[0]] = lone.mode;
    scatter(lone.s, lone.dP_du.lazyProduct(lone.s.J), lone.dP_dtheta, N, out.jacobian);
    return true;
  }
  const NewtonIsland s = contactSpace(bodies, contacts, report.contacts, out.velocity_offset, N,
                                      before, after, out.result);
  const bool configuration = coordinates != nullptr && coordinates->done &&
                             kind != AnalyticIsland::kImpulseSpaceContact;  // (written above)
  ConfigurationChange change;
  MatrixXd moved, dP_dq;
  if (configuration) {
    configurationChange(bodies, contacts, s, out.velocity_offset, before, after, *coordinates,
                        change, moved);
  }
  MatrixXd dP_dv, dP_dtheta;
  if (kind == AnalyticIsland::kNewtonExact) {
    // The exact solver's answer came without a pivot (iterations 0) when every contact was
    // active and sticking inside its static cone (exact_solver.h).
    if (!differentiateNewtonIsland(s, report.iterations == 0, DerivativeColumns{}, dP_dv, dP_dtheta,
                                   out.contacts, configuration ? &change : nullptr, &dP_dq)) {
      return false;
    }
    if (configuration && dP_dq.size() == 0 && change.pre.size() > 0) coordinates->done = false;
  } else {
    // One contact: its impulse is a function of its 3x3 W = J M^-1 J^T and u = J v (+ the part
    // of a body without unknowns), so dP/dv = dP/du J.
    const int c = report.contacts[0];
    const ContactPoint& contact = contacts[c];
    const Eigen::Matrix3d W = s.J.lazyProduct(s.MinvJt);
    Eigen::Matrix3d dP_du, dP_dtheta3;
    const bool closed_form = kind == AnalyticIsland::kNewtonClosedForm;
    const std::vector<Eigen::Matrix3d> dK =
        configuration && closed_form
            ? contactMassChange(bodies, contact, s, out.velocity_offset, *coordinates)
            : std::vector<Eigen::Matrix3d>{};
    Eigen::Matrix<double, 3, Eigen::Dynamic> dP_dK;
    const bool done =
        closed_form
            ? differentiateNewtonContact(contact.normal, W, s.state[0].u, s.state[0].coefficients,
                                         dP_du, dP_dtheta3, out.contacts[c], dK, &dP_dK)
            : differentiateImpulseSpace(contact.normal, W, s.state[0].u, contact.restitution,
                                        contact.static_friction, contact.dynamic_friction,
                                        options.law, options.integration_tolerance, dP_du,
                                        dP_dtheta3, out.contacts[c]);
    if (!done) return false;
    dP_dv = dP_du.lazyProduct(s.J);
    dP_dtheta = dP_dtheta3;
    if (configuration && closed_form) dP_dq = dP_du * change.pre + dP_dK;
  }
  scatter(s, dP_dv, dP_dtheta, N, out.jacobian);
  if (configuration && coordinates->done) scatterCoordinates(s, moved, dP_dq, N, C, out.jacobian);
  return true;
}

// The configuration coordinates' columns (the last K of out.jacobian): central differences of
// solve(contacts, modes) with each coordinate at value +- h, one-sided where one side changes a
// contact's mode (docs/robots.md, "Derivatives of robot impacts"), against the outputs at the
// coordinates' values (solved again, once, when a column needs them); every coordinate ends at its
// value. `solve` starts each solve from the velocities before the impact.
template <class Solve>
void differenceCoordinates(const std::vector<ConfigurationCoordinate>& coordinates,
                           const std::vector<ContactPoint>& contacts, const Solve& solve,
                           BodyImpactDerivatives& out) {
  if (coordinates.empty()) return;
  const Index N = out.velocity_count, C = static_cast<Index>(contacts.size());
  // The prediction's modes as modeOf() classifies the perturbed solves (the analytic pass may
  // report a mode by its own, finer rules: comparing with those would flag switches that are not).
  std::vector<ImpactMode> prediction_modes;
  for (const ContactImpulse& impulse : out.result.impulses)
    prediction_modes.push_back(modeOf(impulse));
  std::vector<ImpactMode> nominal_modes;
  VectorXd nominal;  // the outputs at the coordinates' values, solved once if a column needs them
  std::vector<ImpactMode> plus_modes, minus_modes;
  for (std::size_t k = 0; k < coordinates.size(); ++k) {
    const ConfigurationCoordinate& coordinate = coordinates[k];
    const double h = kStep * std::max(1.0, std::abs(coordinate.value));
    coordinate.set(coordinate.value + h);
    const VectorXd plus = solve(contacts, &plus_modes);
    coordinate.set(coordinate.value - h);
    const VectorXd minus = solve(contacts, &minus_modes);
    coordinate.set(coordinate.value);
    std::vector<std::size_t> switched;  // contacts whose mode changed on either side
    bool plus_same = true, minus_same = true;
    for (std::size_t c = 0; c < contacts.size(); ++c) {
      const bool p = plus_modes[c] == prediction_modes[c],
                 m = minus_modes[c] == prediction_modes[c];
      plus_same = plus_same && p;
      minus_same = minus_same && m;
      if (!p || !m) switched.push_back(c);
    }
    const Index column = N + 3 * C + static_cast<Index>(k);
    if (plus_same == minus_same) {
      out.jacobian.col(column) = (plus - minus) / (2.0 * h);
    } else {
      if (nominal.size() == 0) nominal = solve(contacts, &nominal_modes);
      out.jacobian.col(column) =
          plus_same ? VectorXd((plus - nominal) / h) : VectorXd((nominal - minus) / h);
    }
    for (const std::size_t c : switched) {
      ContactDerivativeMode& mode = out.contacts[c];
      mode.at_switch = true;
      const char* detail = plus_same == minus_same
                               ? "a configuration coordinate's column crosses a mode switch"
                               : "a configuration coordinate's column is one-sided (a mode switch)";
      if (mode.switch_detail.find(detail) == std::string::npos) {
        if (!mode.switch_detail.empty()) mode.switch_detail += "; ";
        mode.switch_detail += detail;
      }
    }
  }
}

}  // namespace

BodyImpactDerivatives computeBodyImpactDerivatives(
    const std::vector<BodyModel*>& bodies, const std::vector<ContactPoint>& given,
    const SolverOptions& options, const std::vector<ConfigurationCoordinate>& coordinates) {
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
  const Index N = out.velocity_count, C = static_cast<Index>(contacts.size());
  const VectorXd before = velocities(bodies, out.velocity_offset, N);
  LoneContact lone;
  if (!predictLoneContact(bodies, contacts, options, before, out, lone)) {
    out.result = computeBodyResponse(bodies, contacts, options);  // validates
  }
  const VectorXd after = velocities(bodies, out.velocity_offset, N);
  out.contact_count = contacts.size();
  out.coordinate_count = static_cast<Index>(coordinates.size());
  out.jacobian.setZero(N + 4 * C, N + 3 * C + out.coordinate_count);
  out.jacobian.topLeftCorner(N, N).setIdentity();
  out.contacts.resize(contacts.size());
  for (std::size_t c = 0; c < contacts.size(); ++c)
    out.contacts[c].mode = modeOf(out.result.impulses[c]);

  // Analytic island by island (islands are independent: each writes its own bodies' and
  // contacts' entries); if one cannot be, every column is differenced. The configuration
  // coordinates' columns too, where every coordinate's body differentiates by it and every island
  // can (an island without an impulse adds nothing to them).
  std::optional<AnalyticCoordinates> analytic_coordinates =
      analyticCoordinatesOf(bodies, coordinates);
  AnalyticCoordinates* by_coordinates = analytic_coordinates ? &*analytic_coordinates : nullptr;
  bool analytic = true;
  for (const SolveReport& report : out.result.islands) {
    if (markNoImpulseIsland(report, out.result.impulses, out.contacts)) continue;
    if (!analyticIsland(bodies, contacts, report, options, before, after, lone, out,
                        by_coordinates)) {
      analytic = false;
      break;
    }
  }
  std::vector<Index> fd_columns;  // columns taken by central differences
  if (!analytic) {
    // The switch flags found so far stay (they describe the answer); the modes are the answer's.
    out.method = DerivativeMethod::kFiniteDifference;
    out.jacobian.setZero();
    out.jacobian.topLeftCorner(N, N).setIdentity();
    for (Index k = 0; k < N + 3 * C; ++k) fd_columns.push_back(k);
    for (std::size_t c = 0; c < contacts.size(); ++c) {
      out.contacts[c].mode = modeOf(out.result.impulses[c]);
      out.contacts[c].method = DerivativeMethod::kFiniteDifference;
    }
  }

  // Differences of the solver itself, column by column.
  const auto solve = [&](const VectorXd& v, const std::vector<ContactPoint>& cs) {
    return evaluate(bodies, cs, options, end, v, out.velocity_offset, N);
  };
  for (const Index column : fd_columns) {
    VectorXd v_plus = before, v_minus = before;
    std::vector<ContactPoint> c_plus = contacts, c_minus = contacts;
    double h = 0.0;
    bool central = true;
    if (column < N) {
      std::size_t b = 0;
      while (!(out.velocity_offset[b] >= 0 && column >= out.velocity_offset[b] &&
               column < out.velocity_offset[b] + bodies[b]->velocityCount()))
        ++b;
      h = kStep * std::max(1.0, before.segment(out.velocity_offset[b], bodies[b]->velocityCount())
                                    .cwiseAbs()
                                    .maxCoeff());
      v_plus(column) += h;
      v_minus(column) -= h;
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
  const bool coordinates_done = analytic && by_coordinates != nullptr && by_coordinates->done;
  if (coordinates_done) out.coordinate_method = DerivativeMethod::kAnalytic;
  if (!coordinates_done && !coordinates.empty()) {
    out.jacobian.rightCols(out.coordinate_count).setZero();  // islands written before one failed
  }
  try {
    if (!coordinates_done)
      differenceCoordinates(
          coordinates, contacts,
          [&](const std::vector<ContactPoint>& cs, std::vector<ImpactMode>* modes) {
            return evaluate(bodies, cs, options, end, before, out.velocity_offset, N, modes);
          },
          out);
  } catch (...) {
    // A perturbed solve ran out of time or failed, or a coordinate could not be set (a robot's
    // M singular at q +- h): the bodies go back to their configuration and the prediction's
    // velocities before the error goes on.
    for (const ConfigurationCoordinate& coordinate : coordinates) coordinate.set(coordinate.value);
    setVelocities(bodies, out.velocity_offset, after);
    throw;
  }
  // The prediction's velocities, as computeBodyResponse() leaves them (the differences moved them).
  if (!fd_columns.empty() || !coordinates.empty())
    setVelocities(bodies, out.velocity_offset, after);
  return out;
}

}  // namespace collision_response::core
