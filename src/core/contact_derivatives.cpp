#include "collision_response/core/contact_derivatives.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <string>

#include "collision_response/core/constants.h"
#include "collision_response/core/contact_space.h"
#include "collision_response/core/exact_solver.h"
#include "collision_response/core/island_solver.h"

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
constexpr int kRestitution = kRestitutionColumn, kDynamic = kDynamicColumn;

}  // namespace

void flagSwitch(ContactDerivativeMode& mode, const std::string& detail) {
  mode.at_switch = true;
  if (!mode.switch_detail.empty()) mode.switch_detail += "; ";
  mode.switch_detail += detail;
}

AnalyticIsland analyticIslandOf(const SolveReport& island, ImpactLaw law) {
  const bool one = island.contacts.size() == 1;
  if (law == ImpactLaw::kNewton) {
    if (island.method == SolvedBy::kClosedForm && one) return AnalyticIsland::kNewtonClosedForm;
    if (island.method == SolvedBy::kExact) return AnalyticIsland::kNewtonExact;
    return AnalyticIsland::kNone;
  }
  const bool integrated = (island.method == SolvedBy::kImpulseSpace ||
                           island.method == SolvedBy::kSimultaneousImpulseSpace) &&
                          island.converged &&
                          !(island.impulse_space && island.impulse_space->fallback);
  if ((law != ImpactLaw::kPoisson && law != ImpactLaw::kStronge) || !integrated) {
    return AnalyticIsland::kNone;
  }
  if (one) return AnalyticIsland::kImpulseSpaceContact;
  return island.method == SolvedBy::kSimultaneousImpulseSpace &&
                 island.contacts.size() <= kSimultaneousMaxContacts
             ? AnalyticIsland::kImpulseSpaceIsland
             : AnalyticIsland::kNone;
}

bool markNoImpulseIsland(const SolveReport& island, const std::vector<ContactImpulse>& impulses,
                         std::vector<ContactDerivativeMode>& modes) {
  const bool impact = island.method != SolvedBy::kNone &&
                      island.method != SolvedBy::kRestingClosedForm &&
                      island.method != SolvedBy::kRestingIterative;
  if (impact) return false;
  double speed = 0.0;
  for (const int c : island.contacts) {
    speed = std::max(speed, std::abs(impulses[c].normal_velocity_before));
  }
  for (const int c : island.contacts) {
    modes[c].mode = ImpactMode::kNoImpulse;
    if (impulses[c].normal_velocity_before <= kSwitchTolerance * speed) {
      flagSwitch(modes[c], "u_n = 0: touching; no-impulse side (approaching starts an impact)");
    }
  }
  return true;
}

const MatrixXd& NewtonIsland::W() const {
  // Coefficient-wise product: the island's matrices are small (3m, L of a few dozen), where the
  // blocked product's set-up costs more than the product.
  if (W_.size() == 0) W_ = J.lazyProduct(MinvJt);
  return W_;
}

// ---- Newton, one contact in closed form (single_contact.h) ----------------------------------

bool differentiateNewtonContact(const Vector3d& n, const Matrix3d& K, const Vector3d& u,
                                const NewtonCoefficients& contact, Matrix3d& dP_du,
                                Matrix3d& dP_dtheta, ContactDerivativeMode& mode,
                                const std::vector<Matrix3d>& dK,
                                Eigen::Matrix<double, 3, Eigen::Dynamic>* dP_dK) {
  const double e = contact.restitution, mu_s = contact.static_friction,
               mu_d = contact.dynamic_friction;
  const double u_n = n.dot(u);
  dP_du.setZero();
  dP_dtheta.setZero();
  if (dP_dK != nullptr) dP_dK->setZero(3, static_cast<Index>(dK.size()));
  mode.method = DerivativeMethod::kAnalytic;
  if (!(u_n < 0.0)) {
    mode.mode = ImpactMode::kNoImpulse;
    return true;
  }
  if (-u_n <= kSwitchTolerance * u.norm()) {
    flagSwitch(mode,
               "u_n = 0: the contact barely approaches; approaching side (a larger u_n separates)");
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
    // dP = -(n^T dK n) / K_nn P.
    for (std::size_t k = 0; dP_dK != nullptr && k < dK.size(); ++k) {
      dP_dK->col(static_cast<Index>(k)) = (u_n * (1.0 + e) * n.dot(dK[k] * n) / (K_nn * K_nn)) * n;
    }
    flagSwitch(mode,
               "frictionless: the friction columns are one-sided, for increasing coefficients");
    return true;
  }
  // The sticking impulse's change with K: dq = -K^-1 dK q.
  const auto stickingByK = [&] {
    for (std::size_t k = 0; dP_dK != nullptr && k < dK.size(); ++k) {
      dP_dK->col(static_cast<Index>(k)) = -K_inv * (dK[k] * q);
    }
  };
  const double limit = mu_s * q_n;
  if (q_n >= 0.0 && q_t_norm <= limit) {
    mode.mode = ImpactMode::kSticking;
    dP_du = dq_du;
    dP_dtheta.col(kRestitution) = dq_de;
    stickingByK();
    if (q_t_norm >= (1.0 - kSwitchTolerance) * limit) {
      flagSwitch(mode, "stick/slide: |P_t| = mu_s P_n; sticking side");
    }
    if (q_n <= kSwitchTolerance * q.norm())
      flagSwitch(mode, "P_n = 0 while sticking; sticking side");
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
    stickingByK();
    flagSwitch(mode, "no sliding impulse exists (n^T K (n + mu_d d) <= 0): the sticking impulse");
    return true;
  }
  mode.mode = ImpactMode::kSliding;
  if (q_n >= 0.0 && q_t_norm <= (1.0 + kSwitchTolerance) * limit) {
    flagSwitch(mode, "stick/slide: |P_t| = mu_s P_n; sliding side");
  }
  if (denominator <= kSwitchTolerance * n.dot(K * n)) {
    flagSwitch(mode, "sliding impulse near n^T K (n + mu_d d) = 0");
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
  // Through K: the sticking impulse (dq = -K^-1 dK q, hence s) and the denominator.
  for (std::size_t k = 0; dP_dK != nullptr && k < dK.size(); ++k) {
    const Vector3d ds = ds_dq * (-K_inv * (dK[k] * q));
    const double dden = n.dot(dK[k] * direction) + mu_d * nK.dot(ds);
    dP_dK->col(static_cast<Index>(k)) =
        (-(alpha / denominator) * dden) * direction + alpha * mu_d * ds;
  }
  return true;
}

namespace {

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
  // The sector [d_k, d_k+1] a tangential vector t lies in: k in 0..D-1 by its angle from t1.
  int sector(const Vector3d& t) const {
    double angle = std::atan2(t.dot(t2), t.dot(t1));
    if (angle < 0.0) angle += 2.0 * kPi;
    return static_cast<int>(std::floor(angle * kD / (2.0 * kPi))) % kD;
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

}  // namespace

Vector3d pyramidFacetNormal(const Vector3d& n, const Vector3d& u, const Vector3d& friction) {
  const Pyramid p = pyramidOf(n, u);
  if (friction.dot(p.t1) == 0.0 && friction.dot(p.t2) == 0.0) return Vector3d::Zero();
  // The middle of the facet between d_k and d_k+1 (its outward normal).
  const double middle = 2.0 * kPi * (p.sector(friction) + 0.5) / kD;
  return std::cos(middle) * p.t1 + std::sin(middle) * p.t2;
}

namespace {

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

// G^-1 = L^-T L^-1 from G's Cholesky factor L (N x N, n its size): L^-1 by forward substitution
// with the diagonal's reciprocals taken once. The columns are then products with G^-1, which
// carry no division: solving column by column divides on every row of both triangles, a chain of
// divisions per column that took more time than the rest of the solve.
template <int N>
Eigen::Matrix<double, N, N> choleskyInverse(const Eigen::LLT<Eigen::Matrix<double, N, N>>& G) {
  using Square = Eigen::Matrix<double, N, N>;
  const auto& L = G.matrixLLT();  // lower triangle: L
  const Index n = L.rows();
  // (The n reciprocals are independent of each other: taken together, they overlap.)
  const Eigen::Matrix<double, N, 1> reciprocal = L.diagonal().cwiseInverse();
  Square Linv = Square::Zero(n, n);
  for (Index j = 0; j < n; ++j) {
    Linv(j, j) = reciprocal(j);
    for (Index i = j + 1; i < n; ++i) {
      double sum = 0.0;
      for (Index k = j; k < i; ++k) sum += L(i, k) * Linv(k, j);
      Linv(i, j) = -sum * reciprocal(i);
    }
  }
  return Linv.transpose() * Linv;
}

// The body-space least-norm solve, G of size N x N (N = 6L; fixed for one body, the common case,
// where Eigen's fixed-size kernels avoid the blocked ones' set-up).
template <int N>
bool solveStickingBodySpace(const NewtonIsland& s, const MatrixXd& rhs, MatrixXd& solution) {
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
  const Square G_inverse = choleskyInverse(G_llt);
  // x = G^-1 J^T rhs (the bodies' velocity change, up to sign), then J G^-1 M x.
  x = (G_inverse * x).eval();
  Tall& Mx = x;  // M x, in place (M block diagonal: mass, inertia per rigid body)
  for (Index l = 0; l < L / 6; ++l) {
    const auto b = static_cast<std::size_t>(l);
    Mx.template middleRows<3>(6 * l) *= s.rigid[b].mass;
    for (Index t = 0; t < columns; ++t) {
      const Eigen::Vector3d w = x.template block<3, 1>(6 * l + 3, t);
      Mx.template block<3, 1>(6 * l + 3, t).noalias() = s.rigid[b].inertia * w;
    }
  }
  if (!Mx.allFinite()) return false;  // a singular inertia: decomposed instead
  Mx = (G_inverse * Mx).eval();
  solution.resize(3 * m, columns);
  for (Index i = 0; i < m; ++i) {
    const auto J_i = s.J.template block<3, N>(3 * i, 0, 3, L);
    for (Index t = 0; t < columns; ++t) {
      solution.template block<3, 1>(3 * i, t).noalias() = J_i * Mx.col(t);
    }
  }
  return true;
}

bool solveSticking(const NewtonIsland& s, const MatrixXd& rhs, MatrixXd& solution) {
  const Index rows = s.J.rows(), L = s.J.cols();
  if (rows > L) {
    if (s.rigid.empty()) return false;  // not rigid bodies: W is decomposed
    return L == 6 ? solveStickingBodySpace<6>(s, rhs, solution)
                  : solveStickingBodySpace<Eigen::Dynamic>(s, rhs, solution);
  }
  const Eigen::LLT<MatrixXd> W(s.W());
  if (!regular(W)) return false;
  solution = W.solve(rhs);
  return true;
}

struct NewtonScratch {
  Eigen::Matrix<double, Eigen::Dynamic, 3> F_theta;
  MatrixXd rhs, solution;
};

[[gnu::noinline]] NewtonScratch& threadNewtonScratch() {
  thread_local NewtonScratch scratch;
  return scratch;
}

}  // namespace

bool differentiateNewtonIsland(const NewtonIsland& s, bool all_sticking,
                               const DerivativeColumns& columns, MatrixXd& dP_dv,
                               MatrixXd& dP_dtheta, std::vector<ContactDerivativeMode>& modes,
                               const ConfigurationChange* configuration, MatrixXd* dP_dq) {
  const Index m = static_cast<Index>(s.contacts.size());
  // F_u and F_theta are block diagonal (a contact's rows depend on its own u and coefficients):
  // their 3 x 3 diagonal blocks are stacked, rows 3i..3i+2 of each holding contact i's.
  // F_P is built on first use: an all-sticking island that solveSticking() solves does without it.
  MatrixXd F_P;
  auto FP = [&]() -> MatrixXd& {
    if (F_P.size() == 0) F_P.setZero(3 * m, 3 * m);
    return F_P;
  };
  using Blocks = Eigen::Matrix<double, Eigen::Dynamic, 3>;
  // F_u is read only for the velocity and configuration columns: without them it is neither
  // allocated nor filled. F_post, the part of F_u through u' = u + W P (at fixed P), only for the
  // configuration columns, whose W moves too.
  const Index Q = configuration != nullptr ? configuration->pre.cols() : 0;
  const bool velocities = columns.velocities || Q > 0;
  // F_theta, the right-hand sides and their solution in storage kept per thread (the function
  // does not call itself): one island after another, of the same size, allocates nothing for them.
  NewtonScratch& scratch = threadNewtonScratch();
  Blocks F_u = velocities ? Blocks::Zero(3 * m, 3) : Blocks();
  Blocks& F_theta = scratch.F_theta;
  F_theta.setZero(3 * m, 3);
  Blocks F_post = Q > 0 ? Blocks::Zero(3 * m, 3) : Blocks();
  double u_reference = 0.0, P_scale = 0.0;
  for (Index i = 0; i < m; ++i) {
    u_reference = std::max(u_reference, s.state[i].u.norm());
    P_scale = std::max(P_scale, s.state[i].P.norm());
  }
  const double facet = 1.0 + std::cos(2.0 * kPi / kD);
  bool frictional_sliding = false;  // F_P then depends on the inputs (pyramid, mu)
  bool every_row_sticking = true;   // F_P = W
  for (Index i = 0; i < m; ++i) {
    const NewtonContactState& state = s.state[i];
    const NewtonCoefficients& contact = state.coefficients;
    ContactDerivativeMode& mode = modes[s.contacts[i]];
    mode.method = DerivativeMethod::kAnalytic;
    const Vector3d& n = state.normal;
    const Vector3d& u = state.u;
    const Vector3d& u_after = state.u_after;
    const Vector3d& P = state.P;
    const double e = contact.restitution, mu_s = contact.static_friction,
                 mu_d = contact.dynamic_friction;
    const double u_n = n.dot(u), P_n = n.dot(P);
    const bool approaching = u_n < 0.0;
    const double target = approaching ? -e * u_n : 0.0;
    const Index r = 3 * i;
    if (std::abs(u_n) <= kSwitchTolerance * u_reference) {
      flagSwitch(mode, "u_n = 0: the target normal velocity switches between -e u_n and 0");
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
      if (velocities) F_u.block<1, 3>(r, 0) = (1.0 + (approaching ? e : 0.0)) * n.transpose();
      if (Q > 0) F_post.block<1, 3>(r, 0) = n.transpose();
      if (approaching) F_theta(r, kRestitution) = u_n;
    };
    if (!(P_n > kPyramidRoundOff * P_scale) && P_t.norm() <= kPyramidRoundOff * P_scale) {
      mode.mode = ImpactMode::kNoImpulse;
      every_row_sticking = false;
      FP().block<3, 3>(r, r).setIdentity();
      if (u_after.dot(n) - target <= kSwitchTolerance * u_reference) {
        flagSwitch(mode, "u'_n at its target with P_n = 0: separating/active; no-impulse side");
      }
      continue;
    }
    if (P_n <= kSwitchTolerance * P_scale) flagSwitch(mode, "P_n = 0 while active; active side");
    // Index of the edge the friction impulse (or, frictionless, the slip's opposite) is nearest.
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
      flagSwitch(mode,
                 "frictionless: the friction columns are one-sided, for increasing coefficients");
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
      f.k = pyramid().sector(P_t);
      f.k1 = (f.k + 1) % kD;
      const Pyramid& p = pyramid();
      f.d_k = p.direction(f.k);
      f.d_k1 = p.direction(f.k1);
      Eigen::Matrix2d B;
      B << f.d_k.dot(p.t1), f.d_k1.dot(p.t1), f.d_k.dot(p.t2), f.d_k1.dot(p.t2);
      f.beta = B.inverse() * Eigen::Vector2d(P_t.dot(p.t1), P_t.dot(p.t2));
      f.gauge = f.beta.sum();
      return f;
    };
    if (slip <= kSlipTolerance * u_reference) {
      mode.mode = ImpactMode::kSticking;
      // (F_P's rows: W's, filled if F_P is decomposed.)
      if (velocities)
        F_u.block<3, 3>(r, 0) = Matrix3d::Identity() + (approaching ? e : 0.0) * n * n.transpose();
      if (Q > 0) F_post.block<3, 3>(r, 0).setIdentity();
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
        flagSwitch(mode, all_sticking
                             ? "stick/slide: |P_t| = mu_s P_n; sticking side"
                             : "stick/slide: friction on its pyramid's boundary; sticking side");
      }
      continue;
    }
    mode.mode = ImpactMode::kSliding;
    frictional_sliding = true;
    every_row_sticking = false;
    if (slip <= 10.0 * kSlipTolerance * u_reference) {
      flagSwitch(mode, "stick/slide: the slip is at the solver's tolerance; sliding side");
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
      if (velocities) F_u.block<2, 3>(r + 1, 0) = -mu * P_n * E * pyramid().derivative(edge, n);
      F_theta.block<2, 1>(r + 1, kDynamic) = -P_n * E * d;
      const double opposing = d.dot(slip_after);
      for (const int j : {(edge + 1) % kD, (edge + kD - 1) % kD}) {
        if (pyramid().direction(j).dot(slip_after) - opposing <= kSwitchTolerance * slip) {
          flagSwitch(mode, "slip between two pyramid edges; sliding side of the reported edge");
        }
      }
      if (beta_min > 0.0 && beta_min > kSwitchTolerance * gauge) {
        flagSwitch(mode, "friction between a pyramid edge and a facet");
      }
    } else {
      // On the facet (d_k, d_k+1): (d_k - d_k+1).u' = 0 and c.P = mu P_n, c = (d_k + d_k+1) /
      // (1 + cos(2 pi / D)) (c.d_k = c.d_k+1 = 1).
      const Vector3d g = d_k - d_k1;
      const Vector3d c = (d_k + d_k1) / facet;
      const Matrix3d D_k = pyramid().derivative(k, n), D_k1 = pyramid().derivative(k1, n);
      FP().block(r + 1, 0, 1, 3 * m) = g.transpose() * s.W().middleRows<3>(r);
      if (velocities)
        F_u.block<1, 3>(r + 1, 0) = g.transpose() + u_after.transpose() * (D_k - D_k1);
      if (Q > 0) F_post.block<1, 3>(r + 1, 0) = g.transpose();
      FP().block<1, 3>(r + 2, r) = c.transpose() - mu * n.transpose();
      if (velocities) F_u.block<1, 3>(r + 2, 0) = P.transpose() * (D_k + D_k1) / facet;
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
  if (dP_dq != nullptr) dP_dq->setZero(3 * m, Q);
  // Island coefficient columns solved (on the stack for islands of up to 16 contacts).
  std::array<Index, 48> small_theta;
  std::vector<Index> large_theta;
  Index* theta_columns = small_theta.data();
  if (3 * m > static_cast<Index>(small_theta.size())) {
    large_theta.resize(static_cast<std::size_t>(3 * m));
    theta_columns = large_theta.data();
  }
  Index T = 0;
  for (Index k = 0; k < 3 * m; ++k) {
    if (columns.wantsCoefficient(3 * static_cast<Index>(s.contacts[k / 3]) + k % 3) &&
        !F_theta.block<3, 1>(k - k % 3, k % 3).isZero(0.0)) {
      theta_columns[T++] = k;
    }
  }
  if (V > 0) {
    dP_dv.setZero(3 * m, L);
  } else {
    dP_dv.resize(0, 0);  // not asked for: empty
  }
  dP_dtheta.setZero(3 * m, 3 * m);
  if (V + T + Q == 0) return true;
  MatrixXd& rhs = scratch.rhs;
  rhs.resize(3 * m, V + T + Q);
  if (V > 0) {
    for (Index i = 0; i < m; ++i) {
      rhs.block(3 * i, 0, 3, L).noalias() = F_u.block<3, 3>(3 * i, 0) * s.J.middleRows<3>(3 * i);
    }
  }
  for (Index t = 0; t < T; ++t) {
    // Column k of the block diagonal F_theta: contact k / 3's block, column k % 3.
    const Index k = theta_columns[t];
    rhs.col(V + t).setZero();
    rhs.block<3, 1>(k - k % 3, V + t) = F_theta.block<3, 1>(k - k % 3, k % 3);
  }
  // A configuration column: u moves by `pre`, and u' at fixed P by `pre` + `post`.
  for (Index i = 0; Q > 0 && i < m; ++i) {
    rhs.block(3 * i, V + T, 3, Q).noalias() =
        F_u.block<3, 3>(3 * i, 0) * configuration->pre.middleRows<3>(3 * i) +
        F_post.block<3, 3>(3 * i, 0) * configuration->post.middleRows<3>(3 * i);
  }
  MatrixXd& solution = scratch.solution;
  // Redundant contacts (F_P singular): the impulses' least-norm change is the derivative of the
  // least-norm impulses only where F_P does not move; under a configuration change it does.
  bool redundant = false;
  if (every_row_sticking && solveSticking(s, rhs, solution)) {
    redundant = 3 * m > L;  // more contact rows than unknowns: W singular
  } else {
    for (Index i = 0; i < m; ++i) {  // the sticking contacts' rows: W's
      if (modes[s.contacts[i]].mode == ImpactMode::kSticking) {
        FP().block(3 * i, 0, 3, 3 * m) = s.W().middleRows<3>(3 * i);
      }
    }
    const Eigen::CompleteOrthogonalDecomposition<MatrixXd> cod(FP());
    if (cod.rank() < 3 * m && frictional_sliding) {
      // Redundant contacts sliding with friction (a face sliding on 4 points): how the normal
      // impulse is shared is not fixed by the equations, and through friction neither are the
      // twists; the solver's choice depends on its own unknowns, and the least-norm change of
      // these equations (whose F_P moves with the pyramid and mu) is not its derivative.
      for (const int c : s.contacts) {
        flagSwitch(modes[c],
                   "redundant contacts sliding with friction: the impulses are not unique, the "
                   "solver's choice is differenced");
      }
      return false;
    }
    redundant = cod.rank() < 3 * m;
    solution = cod.solve(rhs);
  }
  if (V > 0) dP_dv = -solution.leftCols(L);
  for (Index t = 0; t < T; ++t) {
    dP_dtheta.col(theta_columns[t]) = -solution.col(V + t);
  }
  // Redundant: no configuration columns (empty dP_dq; the caller differences them).
  if (Q > 0 && dP_dq != nullptr) {
    if (redundant) {
      dP_dq->resize(0, 0);
    } else {
      *dP_dq = -solution.middleCols(V + T, Q);
    }
  }
  return true;
}

}  // namespace collision_response::core
