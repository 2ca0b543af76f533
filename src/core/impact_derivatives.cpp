#include "collision_response/core/impact_derivatives.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <string_view>

#include "collision_response/core/constants.h"
#include "collision_response/core/contact_space.h"
#include "collision_response/core/exact_solver.h"
#include "collision_response/core/impulse_space_derivatives.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/validation.h"

namespace collision_response::core {
namespace {

using Eigen::Index;
using Eigen::Matrix3d;
using Eigen::MatrixXd;
using Eigen::Vector3d;

constexpr int kD = kPyramidDirections;
// The exact solver's own thresholds (exact_solver.cpp): a contact whose slip exceeds kAlignedSlip
// of its |u| gets its pyramid turned to the slip; one whose |u'_t| exceeds kSlipTolerance of the
// island's largest pre-impact |u| slides.
constexpr double kAlignedSlip = 1e-6;
constexpr double kSlipTolerance = 1e-9;
// Relative round-off below which a pyramid coefficient beta_k counts as 0 (an edge, not a facet).
constexpr double kPyramidRoundOff = 1e-8;
// Finite differences: step relative to the input's scale (central: truncation ~ step^2, round-off
// ~ 2e-16 / step). Small, because the integrations' outputs jump where their step count changes
// (by their discretisation error: 1e-7 of the outputs about every 1e-5 of an input for the
// simultaneous integration, which has no error control); a difference across such a jump is
// replaced by a one-sided one.
constexpr double kStep = 1e-7;
// Central differences with one and two steps that differ by more than this (relative to the
// column) reveal a kink or jump inside the steps.
constexpr double kSmoothness = 1e-4;
// Column offsets of a contact's coefficients.
constexpr int kRestitution = 0, kStatic = 1, kDynamic = 2;

// The island's movable bodies and the Jacobians J_i (3 x 6L, rows of contact i) of its contacts.
struct IslandSystem {
  std::vector<int> contacts;  // scene indices
  std::vector<int> bodies;    // scene indices of the movable bodies, local order
  MatrixXd J;                 // 3m x 6L: u = J v (+ the immovable bodies' part)
  MatrixXd MinvJt;            // 6L x 3m: M^-1 J^T
  // 3m x 3m: J M^-1 J^T, built on first use (the all-sticking solve of a face's redundant
  // contacts does without it).
  const MatrixXd& W() const {
    // Coefficient-wise product: the island's matrices are small (3m, 6L of a few dozen), where
    // the blocked product's set-up costs more than the product.
    if (W_.size() == 0) W_ = J.lazyProduct(MinvJt);
    return W_;
  }
  mutable MatrixXd W_;
  std::vector<Vector3d> normal, u, u_after, P;
  std::vector<double> mass;       // per movable body, local order [kg]
  std::vector<Matrix3d> inertia;  // world [kg m^2] (the inverse of RigidBody::inverse_inertia)
};

Eigen::Matrix<double, 3, 6> pointJacobian(const Vector3d& r) {
  Eigen::Matrix<double, 3, 6> J;
  J << Matrix3d::Identity(), -skew(r);
  return J;
}

IslandSystem buildSystem(const std::vector<int>& contacts, const Scene& scene,
                         const std::vector<std::pair<int, int>>& contact_bodies,
                         const std::vector<RigidBody>& before, const CollisionResult& result,
                         std::vector<int>& local_of) {
  IslandSystem s;
  s.contacts = contacts;
  for (auto* list : {&s.normal, &s.u, &s.u_after, &s.P}) list->reserve(contacts.size());
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
    s.normal.push_back(n);
    s.u.push_back(u);
    s.u_after.push_back(u_after);
    const ContactImpulse& impulse = result.impulses[c];
    s.P.push_back(impulse.normal_impulse * n + impulse.friction_impulse);
  }
  s.mass.reserve(static_cast<std::size_t>(L));
  s.inertia.reserve(static_cast<std::size_t>(L));
  for (Index l = 0; l < L; ++l) {
    const RigidBody& body = before[s.bodies[l]];
    s.mass.push_back(1.0 / body.inverse_mass);
    s.inertia.push_back(body.inverse_inertia.inverse());
    const auto Jt = s.J.middleCols<6>(6 * l).transpose();
    s.MinvJt.middleRows<3>(6 * l) = body.inverse_mass * Jt.topRows<3>();
    s.MinvJt.middleRows<3>(6 * l + 3) = body.inverse_inertia * Jt.bottomRows<3>();
  }
  for (const int b : s.bodies) local_of[b] = -1;
  return s;
}

void flag(ContactDerivativeMode& mode, const std::string& detail) {
  mode.at_switch = true;
  if (!mode.switch_detail.empty()) mode.switch_detail += "; ";
  mode.switch_detail += detail;
}

// Writes an island's derivatives into the full Jacobian from dP/dv (3m x 6L, v the island's
// movable bodies' twists) and dP/dtheta (3m x 3m, per contact e, mu_s, mu_d).
// `velocities`: whether dP/dv was computed (else its columns are left alone).
void scatter(const IslandSystem& s, const MatrixXd& dP_dv, const MatrixXd& dP_dtheta,
             bool velocities, const std::vector<Index>& body_column, Index velocity_count,
             MatrixXd& jacobian) {
  const Index m = static_cast<Index>(s.contacts.size()), L = static_cast<Index>(s.bodies.size());
  // (normal_impulse, friction_impulse) of contact i = impulseOfP(i) * P_i: normal_impulse = n.P,
  // friction_impulse = (I - n n^T) P.
  auto impulseOfP = [&s](Index i) {
    const Vector3d& n = s.normal[static_cast<std::size_t>(i)];
    Eigen::Matrix<double, 4, 3> out;
    out.row(0) = n.transpose();
    out.bottomRows<3>() = Matrix3d::Identity() - n * n.transpose();
    return out;
  };
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
    if (dP.isZero(0.0)) continue;
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

// ---- Newton, one contact in closed form (single_contact.h) ----------------------------------

// dP/du and dP/d(e, mu_s, mu_d) of solveSingleContact() under Newton's law for a regular K. False
// if K is singular (the caller then differentiates numerically).
bool closedFormNewton(const Contact& contact, const Vector3d& n, const Matrix3d& K,
                      const Vector3d& u, Matrix3d& dP_du, Matrix3d& dP_dtheta,
                      ContactDerivativeMode& mode) {
  const double e = contact.restitution, mu_s = contact.static_friction,
               mu_d = contact.dynamic_friction;
  const double u_n = n.dot(u);
  dP_du.setZero();
  dP_dtheta.setZero();
  mode.method = DerivativeMethod::kAnalytic;
  if (!(u_n < 0.0)) {
    mode.mode = ImpactMode::kNoImpulse;
    return true;
  }
  if (-u_n <= kSwitchTolerance * u.norm()) {
    flag(mode, "u_n = 0: the contact barely approaches; approaching side (a larger u_n separates)");
  }
  const double trace = K.trace();
  if (!(K.determinant() > 1e-12 * trace * trace * trace)) return false;
  const Matrix3d K_inv = K.inverse();
  const Matrix3d nnT = n * n.transpose();
  const Matrix3d tangential = Matrix3d::Identity() - nnT;
  // Sticking impulse q = K^-1 (-u - e u_n n) and its derivatives.
  const Vector3d q = K_inv * (-u - e * u_n * n);
  const Matrix3d dq_du = -K_inv * (Matrix3d::Identity() + e * nnT);
  const Vector3d dq_de = -u_n * (K_inv * n);
  const bool frictionless = contact.frictionless();
  const double q_n = q.dot(n);
  const Vector3d q_t = q - q_n * n;
  const double q_t_norm = q_t.norm();
  if (frictionless) {
    // P = -(1 + e) u_n / K_nn n.
    const double K_nn = n.dot(K * n);
    mode.mode = ImpactMode::kSliding;
    dP_du = (-(1.0 + e) / K_nn) * nnT;
    dP_dtheta.col(kRestitution) = (-u_n / K_nn) * n;
    // mu_s alone (mu_d = 0) keeps the frictionless impulse (the contact slides with mu_d = 0);
    // mu_d (with mu_s) slides along the sticking impulse's tangential direction: one-sided.
    if (q_t_norm > 0.0) {
      const Vector3d s = q_t / q_t_norm;
      const double alpha = -(1.0 + e) * u_n / K_nn;
      const double dalpha = -alpha * n.dot(K * s) / K_nn;
      dP_dtheta.col(kDynamic) = dalpha * n + alpha * s;
    }
    flag(mode, "frictionless: the friction columns are one-sided, for increasing coefficients");
    return true;
  }
  const double limit = mu_s * q_n;
  if (q_n >= 0.0 && q_t_norm <= limit) {
    mode.mode = ImpactMode::kSticking;
    dP_du = dq_du;
    dP_dtheta.col(kRestitution) = dq_de;
    if (q_t_norm >= (1.0 - kSwitchTolerance) * limit) {
      flag(mode, "stick/slide: |P_t| = mu_s P_n; sticking side");
    }
    if (q_n <= kSwitchTolerance * q.norm()) flag(mode, "P_n = 0 while sticking; sticking side");
    return true;
  }
  if (q_t_norm == 0.0) return false;  // sliding without a direction: numerically
  const Vector3d s = q_t / q_t_norm;
  const Vector3d direction = n + mu_d * s;
  const double denominator = n.dot(K * direction);
  if (!(denominator > 0.0)) {
    // Painleve-like: the sticking impulse is returned.
    mode.mode = ImpactMode::kSticking;
    dP_du = dq_du;
    dP_dtheta.col(kRestitution) = dq_de;
    flag(mode, "no sliding impulse exists (n^T K (n + mu_d d) <= 0): the sticking impulse");
    return true;
  }
  mode.mode = ImpactMode::kSliding;
  if (q_n >= 0.0 && q_t_norm <= (1.0 + kSwitchTolerance) * limit) {
    flag(mode, "stick/slide: |P_t| = mu_s P_n; sliding side");
  }
  if (denominator <= kSwitchTolerance * n.dot(K * n)) {
    flag(mode, "sliding impulse near n^T K (n + mu_d d) = 0");
  }
  // P = alpha (n + mu_d s), alpha = -(1 + e) u_n / (n^T K (n + mu_d s)), s = q_t / |q_t|.
  const double alpha = -(1.0 + e) * u_n / denominator;
  const Matrix3d ds_dq = (Matrix3d::Identity() - s * s.transpose()) * tangential / q_t_norm;
  const Vector3d nK = K * n;  // K symmetric: n^T K x = nK . x
  // Through s (u, e), and directly through u_n (u), e and mu_d.
  const Matrix3d ds_du = ds_dq * dq_du;
  const Vector3d ds_de = ds_dq * dq_de;
  const Eigen::RowVector3d dden_du = mu_d * nK.transpose() * ds_du;
  const double dden_de = mu_d * nK.dot(ds_de);
  const double dden_dmu = nK.dot(s);
  const Eigen::RowVector3d dalpha_du =
      (-(1.0 + e) / denominator) * n.transpose() - (alpha / denominator) * dden_du;
  const double dalpha_de = -u_n / denominator - (alpha / denominator) * dden_de;
  const double dalpha_dmu = -(alpha / denominator) * dden_dmu;
  dP_du = direction * dalpha_du + alpha * mu_d * ds_du;
  dP_dtheta.col(kRestitution) = dalpha_de * direction + alpha * mu_d * ds_de;
  dP_dtheta.col(kDynamic) = dalpha_dmu * direction + alpha * s;
  return true;
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
    if (!closedFormNewton(contact, n, K, u, dP_du, dP_dtheta, out.contacts[c])) return false;
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

// ---- Newton, exact solver: the final active set, implicit differentiation -------------------

// The pyramid of a contact as the exact solver builds it: d_k = cos(2 pi k / D) t1 +
// sin(2 pi k / D) t2, t1 along the pre-impact slip when it slides (then dt1/du = T1), otherwise
// tangentBasis(n) (T1 = 0).
struct Pyramid {
  Vector3d t1, t2;
  double slip_norm = 0.0;  // |pre-impact slip| when t1 follows it, else 0 (T1 = 0)
  Vector3d direction(int k) const {
    const double angle = 2.0 * kPi * k / kD;
    return std::cos(angle) * t1 + std::sin(angle) * t2;
  }
  // d t1 / du = (I - t1 t1^T)(I - n n^T) / |slip| (built where it is read: only a sliding
  // contact's rows need it).
  Matrix3d T1(const Vector3d& n) const {
    if (slip_norm == 0.0) return Matrix3d::Zero();
    return (Matrix3d::Identity() - t1 * t1.transpose()) *
           (Matrix3d::Identity() - n * n.transpose()) / slip_norm;
  }
  // d d_k / du: (cos I + sin [n]x) T1, t2 = n x t1.
  Matrix3d derivative(int k, const Vector3d& n) const {
    const double angle = 2.0 * kPi * k / kD;
    return (std::cos(angle) * Matrix3d::Identity() + std::sin(angle) * skew(n)) * T1(n);
  }
};

Pyramid pyramidOf(const Vector3d& n, const Vector3d& u) {
  Pyramid p;
  const Vector3d slip = u - u.dot(n) * n;
  const double slip_norm = slip.norm();
  if (slip_norm > kAlignedSlip * u.norm()) {
    p.t1 = slip / slip_norm;
    p.t2 = n.cross(p.t1);
    p.slip_norm = slip_norm;
  } else {
    tangentBasis(n, p.t1, p.t2);
  }
  return p;
}

// Implicit differentiation of the exact solver's answer on island `s`: F(P, u, theta) = 0, one
// row triple per contact for its mode, F_P dP = -(F_u du + F_theta dtheta).
bool wantedCoefficient(const DerivativeColumns& columns, Index column) {
  return columns.coefficients.empty() || columns.coefficients[static_cast<std::size_t>(column)];
}

// The all-sticking system F_P dP = -rhs with F_P = W = J M^-1 J^T (every contact's rows those of
// a sticking contact), in the least-norm sense of the general path below without decomposing the
// 3m x 3m W: with J of full column rank (more contact rows than body unknowns, a face on its
// corners), W^+ = J G^-1 M G^-1 J^T, G = J^T J (6L x 6L); with W regular (3m <= 6L), W^-1. False
// when the rank condition does not hold clearly (the caller then decomposes F_P).
// Relative size of the smallest pivot of a Cholesky factor (squared) for the rank to count as
// full: well above round-off, well below any physical mass ratio's effect on G or W.
constexpr double kRegular = 1e-10;

template <typename Llt>
bool regular(const Llt& llt) {
  if (llt.info() != Eigen::Success) return false;
  const auto pivots = llt.matrixLLT().diagonal().cwiseAbs2().eval();
  return pivots.minCoeff() > kRegular * pivots.maxCoeff();
}

// G^-1 b for every column b of `columns`, in place: column by column for a fixed size (inlined
// kernels), at once otherwise.
template <int N>
void solveColumns(const Eigen::LLT<Eigen::Matrix<double, N, N>>& G,
                  Eigen::Matrix<double, N, Eigen::Dynamic>& columns) {
  if constexpr (N == Eigen::Dynamic) {
    columns = G.solve(columns).eval();
  } else {
    for (Index k = 0; k < columns.cols(); ++k) {
      const Eigen::Matrix<double, N, 1> b = columns.col(k);
      columns.col(k) = G.solve(b);
    }
  }
}

// The body-space least-norm solve, G of size N x N (N = 6L; fixed for one body, the common case,
// where Eigen's fixed-size kernels avoid the blocked ones' set-up).
template <int N>
bool solveStickingBodySpace(const IslandSystem& s, const MatrixXd& rhs, MatrixXd& solution) {
  using Square = Eigen::Matrix<double, N, N>;
  using Tall = Eigen::Matrix<double, N, Eigen::Dynamic>;
  const Index L = s.J.cols(), m = s.J.rows() / 3, columns = rhs.cols();
  // G = J^T J and x = J^T rhs, contact by contact (3-row blocks: fixed-size kernels for one body).
  Square G = Square::Zero(L, L);
  Tall x = Tall::Zero(L, columns);
  for (Index i = 0; i < m; ++i) {
    const auto J_i = s.J.template block<3, N>(3 * i, 0, 3, L);
    G.noalias() += J_i.transpose() * J_i;
    for (Index t = 0; t < columns; ++t) {
      const Eigen::Vector3d b = rhs.template block<3, 1>(3 * i, t);
      if (!b.isZero(0.0)) x.col(t).noalias() += J_i.transpose() * b;
    }
  }
  const Eigen::LLT<Square> G_llt(G);
  if (!regular(G_llt)) return false;
  // x = G^-1 J^T rhs (the bodies' velocity change, up to sign), then J G^-1 M x.
  solveColumns(G_llt, x);
  Tall& Mx = x;  // M x, in place (M block diagonal: mass, inertia per body)
  for (Index l = 0; l < L / 6; ++l) {
    const auto b = static_cast<std::size_t>(l);
    Mx.template middleRows<3>(6 * l) *= s.mass[b];
    for (Index t = 0; t < columns; ++t) {
      const Eigen::Vector3d w = x.template block<3, 1>(6 * l + 3, t);
      Mx.template block<3, 1>(6 * l + 3, t).noalias() = s.inertia[b] * w;
    }
  }
  if (!Mx.allFinite()) return false;  // a singular inertia: decomposed instead
  solveColumns(G_llt, Mx);
  solution.resize(3 * m, columns);
  for (Index i = 0; i < m; ++i) {
    const auto J_i = s.J.template block<3, N>(3 * i, 0, 3, L);
    for (Index t = 0; t < columns; ++t) {
      solution.template block<3, 1>(3 * i, t).noalias() = J_i * Mx.col(t);
    }
  }
  return true;
}

bool solveSticking(const IslandSystem& s, const MatrixXd& rhs, MatrixXd& solution) {
  const Index rows = s.J.rows(), L = s.J.cols();
  if (rows > L) {
    return L == 6 ? solveStickingBodySpace<6>(s, rhs, solution)
                  : solveStickingBodySpace<Eigen::Dynamic>(s, rhs, solution);
  }
  const Eigen::LLT<MatrixXd> W(s.W());
  if (!regular(W)) return false;
  solution = W.solve(rhs);
  return true;
}

bool exactNewton(const IslandSystem& s, const Scene& scene, bool all_sticking,
                 const DerivativeColumns& columns, MatrixXd& dP_dv, MatrixXd& dP_dtheta,
                 std::vector<ContactDerivativeMode>& modes) {
  const Index m = static_cast<Index>(s.contacts.size());
  // F_u and F_theta are block diagonal (a contact's rows depend on its own u and coefficients):
  // their 3 x 3 diagonal blocks are stacked, rows 3i..3i+2 of each holding contact i's.
  // F_P is built on first use: an all-sticking island solved in body space does without it.
  MatrixXd F_P;
  auto FP = [&]() -> MatrixXd& {
    if (F_P.size() == 0) F_P.setZero(3 * m, 3 * m);
    return F_P;
  };
  Eigen::Matrix<double, Eigen::Dynamic, 3> F_u = Eigen::Matrix<double, Eigen::Dynamic, 3>::Zero(
                                               3 * m, 3),
                                           F_theta = Eigen::Matrix<double, Eigen::Dynamic, 3>::Zero(
                                               3 * m, 3);
  double u_reference = 0.0, P_scale = 0.0;
  for (Index i = 0; i < m; ++i) {
    u_reference = std::max(u_reference, s.u[i].norm());
    P_scale = std::max(P_scale, s.P[i].norm());
  }
  const double facet = 1.0 + std::cos(2.0 * kPi / kD);
  bool frictional_sliding = false;  // F_P then depends on the inputs (pyramid, mu)
  bool every_row_sticking = true;   // F_P = W
  for (Index i = 0; i < m; ++i) {
    const Contact& contact = scene.contacts[s.contacts[i]];
    ContactDerivativeMode& mode = modes[s.contacts[i]];
    mode.method = DerivativeMethod::kAnalytic;
    const Vector3d& n = s.normal[i];
    const Vector3d& u = s.u[i];
    const Vector3d& u_after = s.u_after[i];
    const Vector3d& P = s.P[i];
    const double e = contact.restitution, mu_s = contact.static_friction,
                 mu_d = contact.dynamic_friction;
    const double u_n = n.dot(u), P_n = n.dot(P);
    const bool approaching = u_n < 0.0;
    const double target = approaching ? -e * u_n : 0.0;
    const Index r = 3 * i;
    if (std::abs(u_n) <= kSwitchTolerance * u_reference) {
      flag(mode, "u_n = 0: the target normal velocity switches between -e u_n and 0");
    }
    const Vector3d P_t = P - P_n * n;
    const Vector3d slip_after = u_after - u_after.dot(n) * n;
    const double slip = slip_after.norm();
    // (Built where it is read: the contacts of an all-sticking answer do without it.)
    std::optional<Pyramid> built_pyramid;
    auto pyramid = [&]() -> const Pyramid& {
      if (!built_pyramid) built_pyramid = pyramidOf(n, u);
      return *built_pyramid;
    };
    // The fixed tangents (rows), for the rows of a sliding or frictionless contact.
    auto tangents = [&n] {
      Vector3d E1, E2;
      tangentBasis(n, E1, E2);
      Eigen::Matrix<double, 2, 3> E;
      E.row(0) = E1.transpose();
      E.row(1) = E2.transpose();
      return E;
    };
    // The normal row of an active contact: n^T u' - target = 0.
    auto normalRow = [&]() {
      FP().block(r, 0, 1, 3 * m) = n.transpose() * s.W().middleRows<3>(r);
      F_u.block<1, 3>(r, 0) = (1.0 + (approaching ? e : 0.0)) * n.transpose();
      if (approaching) F_theta(r, kRestitution) = u_n;
    };
    if (!(P_n > kPyramidRoundOff * P_scale) && P_t.norm() <= kPyramidRoundOff * P_scale) {
      mode.mode = ImpactMode::kNoImpulse;
      every_row_sticking = false;
      FP().block<3, 3>(r, r).setIdentity();
      if (u_after.dot(n) - target <= kSwitchTolerance * u_reference) {
        flag(mode, "u'_n at its target with P_n = 0: separating/active; no-impulse side");
      }
      continue;
    }
    if (P_n <= kSwitchTolerance * P_scale) flag(mode, "P_n = 0 while active; active side");
    // Index of the edge the friction impulse (or, frictionless, the slip's opposite) is nearest.
    auto sector = [&](const Vector3d& t) {
      double angle = std::atan2(t.dot(pyramid().t2), t.dot(pyramid().t1));
      if (angle < 0.0) angle += 2.0 * kPi;
      return static_cast<int>(std::floor(angle * kD / (2.0 * kPi))) % kD;
    };
    if (contact.frictionless()) {
      mode.mode = ImpactMode::kSliding;
      every_row_sticking = false;
      normalRow();
      const Eigen::Matrix<double, 2, 3> E = tangents();
      FP().block<2, 3>(r + 1, r) = E;  // P_t = 0
      // Friction from mu = 0 up: along the pyramid edge most opposed to the slip.
      if (slip > kSlipTolerance * u_reference) {
        int best = 0;
        for (int k = 1; k < kD; ++k) {
          if (pyramid().direction(k).dot(slip_after) < pyramid().direction(best).dot(slip_after)) {
            best = k;
          }
        }
        F_theta.block<2, 1>(r + 1, kDynamic) = -P_n * E * pyramid().direction(best);
      }
      flag(mode, "frictionless: the friction columns are one-sided, for increasing coefficients");
      continue;
    }
    // The friction impulse in the pyramid's sector (d_k, d_k+1): P_t = b_k d_k + b_k+1 d_k+1.
    // (Computed where it is read: the all-sticking answer's contacts do without it.)
    struct FrictionSector {
      int k, k1;
      Vector3d d_k, d_k1;
      Eigen::Vector2d beta;
      double gauge;
    };
    auto frictionSector = [&]() {
      FrictionSector f;
      f.k = sector(P_t);
      f.k1 = (f.k + 1) % kD;
      f.d_k = pyramid().direction(f.k);
      f.d_k1 = pyramid().direction(f.k1);
      Eigen::Matrix2d B;
      B << f.d_k.dot(pyramid().t1), f.d_k1.dot(pyramid().t1), f.d_k.dot(pyramid().t2),
          f.d_k1.dot(pyramid().t2);
      f.beta = B.inverse() * Eigen::Vector2d(P_t.dot(pyramid().t1), P_t.dot(pyramid().t2));
      f.gauge = f.beta.sum();
      return f;
    };
    if (slip <= kSlipTolerance * u_reference) {
      mode.mode = ImpactMode::kSticking;
      // (F_P's rows: W's, filled if F_P is decomposed.)
      F_u.block<3, 3>(r, 0) = Matrix3d::Identity() + (approaching ? e : 0.0) * n * n.transpose();
      if (approaching) F_theta.block<3, 1>(r, kRestitution) = u_n * n;
      // The all-sticking answer (no pivot) is bounded by the static cone, Lemke's and the modes'
      // by the pyramid (static, or dynamic for a contact that slid in an earlier round).
      auto on_pyramid_boundary = [&] {
        const double gauge = frictionSector().gauge;
        return gauge >= (1.0 - kSwitchTolerance) * mu_s * P_n ||
               (mu_d < mu_s && std::abs(gauge - mu_d * P_n) <= kSwitchTolerance * mu_s * P_n);
      };
      if (all_sticking ? P_t.norm() >= (1.0 - kSwitchTolerance) * mu_s * P_n
                       : on_pyramid_boundary()) {
        flag(mode, all_sticking ? "stick/slide: |P_t| = mu_s P_n; sticking side"
                                : "stick/slide: friction on its pyramid's boundary; sticking side");
      }
      continue;
    }
    mode.mode = ImpactMode::kSliding;
    frictional_sliding = true;
    every_row_sticking = false;
    if (slip <= 10.0 * kSlipTolerance * u_reference) {
      flag(mode, "stick/slide: the slip is at the solver's tolerance; sliding side");
    }
    normalRow();
    const FrictionSector f = frictionSector();
    const int k = f.k, k1 = f.k1;
    const Vector3d &d_k = f.d_k, &d_k1 = f.d_k1;
    const Eigen::Vector2d& beta = f.beta;
    const double gauge = f.gauge;
    const double mu = mu_d;  // a contact that slides ends on the dynamic pyramid
    const double beta_min = std::min(beta(0), beta(1));
    if (beta_min <= kPyramidRoundOff * gauge) {
      // Along one edge: P_t = mu P_n d, expressed in the fixed tangents E.
      const int edge = beta(0) >= beta(1) ? k : k1;
      const Vector3d d = pyramid().direction(edge);
      const Eigen::Matrix<double, 2, 3> E = tangents();
      FP().block<2, 3>(r + 1, r) = E * (Matrix3d::Identity() - (n + mu * d) * n.transpose());
      F_u.block<2, 3>(r + 1, 0) = -mu * P_n * E * pyramid().derivative(edge, n);
      F_theta.block<2, 1>(r + 1, kDynamic) = -P_n * E * d;
      const double opposing = d.dot(slip_after);
      for (const int j : {(edge + 1) % kD, (edge + kD - 1) % kD}) {
        if (pyramid().direction(j).dot(slip_after) - opposing <= kSwitchTolerance * slip) {
          flag(mode, "slip between two pyramid edges; sliding side of the reported edge");
        }
      }
      if (beta_min > 0.0 && beta_min > kSwitchTolerance * gauge) {
        flag(mode, "friction between a pyramid edge and a facet");
      }
    } else {
      // On the facet (d_k, d_k+1): (d_k - d_k+1).u' = 0 and c.P = mu P_n, c = (d_k + d_k+1) /
      // (1 + cos(2 pi / D)) (c.d_k = c.d_k+1 = 1).
      const Vector3d g = d_k - d_k1;
      const Vector3d c = (d_k + d_k1) / facet;
      const Matrix3d D_k = pyramid().derivative(k, n), D_k1 = pyramid().derivative(k1, n);
      FP().block(r + 1, 0, 1, 3 * m) = g.transpose() * s.W().middleRows<3>(r);
      F_u.block<1, 3>(r + 1, 0) = g.transpose() + u_after.transpose() * (D_k - D_k1);
      FP().block<1, 3>(r + 2, r) = c.transpose() - mu * n.transpose();
      F_u.block<1, 3>(r + 2, 0) = P.transpose() * (D_k + D_k1) / facet;
      F_theta(r + 2, kDynamic) = -P_n;
    }
  }
  // One decomposition for both right-hand sides, F_u J (F_u is block diagonal) and F_theta, of
  // the columns asked for; a coefficient column whose F_theta column is 0 has a 0 derivative (a
  // sticking contact's friction coefficients) and is not solved. Where redundant contacts make
  // F_P singular (a face on 4 points), the least-norm change, as the solver's least-norm impulses
  // (the velocities' derivatives are the same for every solution).
  const Index L = s.J.cols();
  const Index V = columns.velocities ? L : 0;
  std::vector<Index> theta_columns;  // island coefficient columns solved
  theta_columns.reserve(static_cast<std::size_t>(3 * m));
  for (Index k = 0; k < 3 * m; ++k) {
    if (wantedCoefficient(columns, 3 * static_cast<Index>(s.contacts[k / 3]) + k % 3) &&
        !F_theta.block<3, 1>(k - k % 3, k % 3).isZero(0.0)) {
      theta_columns.push_back(k);
    }
  }
  const Index T = static_cast<Index>(theta_columns.size());
  if (V > 0) dP_dv.setZero(3 * m, L);  // (not read by scatter() without the velocity columns)
  dP_dtheta.setZero(3 * m, 3 * m);
  if (V + T == 0) return true;
  MatrixXd rhs(3 * m, V + T);
  if (V > 0) {
    for (Index i = 0; i < m; ++i) {
      rhs.block(3 * i, 0, 3, L).noalias() = F_u.block<3, 3>(3 * i, 0) * s.J.middleRows<3>(3 * i);
    }
  }
  for (Index t = 0; t < T; ++t) {
    // Column k of the block diagonal F_theta: contact k / 3's block, column k % 3.
    const Index k = theta_columns[static_cast<std::size_t>(t)];
    rhs.col(V + t).setZero();
    rhs.block<3, 1>(k - k % 3, V + t) = F_theta.block<3, 1>(k - k % 3, k % 3);
  }
  MatrixXd solution;
  if (!every_row_sticking || !solveSticking(s, rhs, solution)) {
    for (Index i = 0; i < m; ++i) {  // the sticking contacts' rows: W's
      const ContactDerivativeMode& mode = modes[s.contacts[i]];
      if (mode.mode == ImpactMode::kSticking)
        FP().block(3 * i, 0, 3, 3 * m) = s.W().middleRows<3>(3 * i);
    }
    const Eigen::CompleteOrthogonalDecomposition<MatrixXd> cod(FP());
    if (cod.rank() < 3 * m && frictional_sliding) {
      // Redundant contacts sliding with friction (a face sliding on 4 points): how the normal
      // impulse is shared is not fixed by the equations, and through friction neither are the
      // twists; the solver's choice depends on its own unknowns, and the least-norm change of
      // these equations (whose F_P moves with the pyramid and mu) is not its derivative.
      for (const int c : s.contacts) {
        flag(modes[c],
             "redundant contacts sliding with friction: the impulses are not unique, the "
             "solver's choice is differenced");
      }
      return false;
    }
    solution = cod.solve(rhs);
  }
  if (V > 0) dP_dv = -solution.leftCols(L);
  for (Index t = 0; t < T; ++t) {
    dP_dtheta.col(theta_columns[static_cast<std::size_t>(t)]) = -solution.col(V + t);
  }
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
      auto same = [&](const Evaluation& e) {
        if (e.modes.empty()) return false;
        for (const int c : report.contacts) {
          if (e.modes[c] != base.modes[c]) return false;
        }
        return e.island_mark[island] == base.island_mark[island];
      };
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
              flag(out.contacts[c], "the solve is not smooth within two steps of " + label +
                                        " (an event inside it): derivative uncertain");
            }
          }
        }
      } else {
        const bool forward = plus_same;
        const double sign = forward ? 1.0 : -1.0;
        const Evaluation& near = forward ? plus : minus;
        const Evaluation far = at(x0 + 2.0 * sign * h, valid);
        if ((plus_same || minus_same) && valid && same(far)) {
          derivative = sign * (-3.0 * base.outputs + 4.0 * near.outputs - far.outputs) / (2.0 * h);
        } else if (plus_same || minus_same) {
          derivative = sign * (near.outputs - base.outputs) / h;
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
            flag(out.contacts[c],
                 std::string("mode or integration steps change within the step of ") + label +
                     ": " +
                     (plus_same    ? "increasing side"
                      : minus_same ? "decreasing side"
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
      if (wantedCoefficient(columns, first + kRestitution)) {
        column(col + kRestitution, contact.restitution, 0.0, 1.0, 1.0, name + "restitution");
      }
      // Each coefficient on its own, mu_d <= mu_s aside: the solvers read them separately (the
      // static one for the stick test, the dynamic one for slip), so the map extends across it.
      if (wantedCoefficient(columns, first + kStatic)) {
        column(col + kStatic, contact.static_friction, 0.0, INFINITY, 1.0,
               name + "static_friction");
      }
      if (wantedCoefficient(columns, first + kDynamic)) {
        column(col + kDynamic, contact.dynamic_friction, 0.0, INFINITY, 1.0,
               name + "dynamic_friction");
      }
    }
  }
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
  if (!columns.coefficients.empty() && columns.coefficients.size() != 3 * scene.contacts.size()) {
    throw std::invalid_argument(
        "computeValidatedImpactDerivatives: one coefficient column flag per coefficient");
  }
  // One time budget for the whole call: the prediction and every perturbed solve.
  const auto end = std::chrono::steady_clock::now() +
                   std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                       std::chrono::duration<double>(options.time_budget));
  ImpactDerivatives out;
  out.result = computeValidatedResponse(scene, contact_bodies, options);
  out.contact_count = scene.contacts.size();
  out.contacts.resize(scene.contacts.size());

  std::vector<RigidBody> before;
  makeRigidBodies(scene.bodies, before);
  std::vector<Index> body_column(scene.bodies.size(), -1);
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
    out.jacobian.rightCols(out.coefficientCount()).setZero();
  }

  std::vector<int> local_of(scene.bodies.size(), -1);
  std::vector<std::size_t> numerical;
  for (std::size_t k = 0; k < out.result.islands.size(); ++k) {
    const SolveReport& report = out.result.islands[k];
    if (!report.converged) {
      for (const int c : report.contacts) {
        flag(out.contacts[c],
             "the island's solve did not converge (see result.islands): the "
             "derivative is that of the answer given, not of a solution");
      }
    }
    const bool impact = report.method != SolvedBy::kNone &&
                        report.method != SolvedBy::kRestingClosedForm &&
                        report.method != SolvedBy::kRestingIterative;
    if (!impact) {
      // No impulse; a contact touching at u_n = 0 would start an impact if made to approach.
      double speed = 0.0;
      for (const int c : report.contacts) {
        speed = std::max(speed, std::abs(out.result.impulses[c].normal_velocity_before));
      }
      for (const int c : report.contacts) {
        out.contacts[c].mode = ImpactMode::kNoImpulse;
        if (out.result.impulses[c].normal_velocity_before <= kSwitchTolerance * speed) {
          flag(out.contacts[c],
               "u_n = 0: touching; no-impulse side (approaching starts an impact)");
        }
      }
      continue;
    }
    const bool newton = options.law == ImpactLaw::kNewton;
    // One contact integrated in impulse space (Poisson, Stronge), to the end (no fallback).
    const bool impulse_space =
        (options.law == ImpactLaw::kPoisson || options.law == ImpactLaw::kStronge) &&
        report.contacts.size() == 1 &&
        (report.method == SolvedBy::kImpulseSpace ||
         report.method == SolvedBy::kSimultaneousImpulseSpace) &&
        report.converged && !(report.impulse_space && report.impulse_space->fallback);
    if ((newton && report.method == SolvedBy::kClosedForm && report.contacts.size() == 1) ||
        impulse_space) {
      const int c = report.contacts[0];
      if (singleContact(scene, c, contact_bodies[c], before, body_column, velocity_count, options,
                        out)) {
        continue;
      }
      out.contacts[c] = ContactDerivativeMode{};
    } else if (newton && report.method == SolvedBy::kExact) {
      const IslandSystem s =
          buildSystem(report.contacts, scene, contact_bodies, before, out.result, local_of);
      MatrixXd dP_dv, dP_dtheta;
      // The exact solver's answer came without a pivot (iterations 0) when every contact was
      // active and sticking inside its static cone (exact_solver.h).
      if (exactNewton(s, scene, report.iterations == 0, columns, dP_dv, dP_dtheta, out.contacts)) {
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
  return out;
}

}  // namespace collision_response::core
