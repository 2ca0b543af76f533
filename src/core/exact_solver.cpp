// Exact multi-contact Newton restitution: the contact LCP of exact_solver.h, solved by lcp.h.
//
// Symbols: contact i has normal n_i, pyramid directions d_ik, pre-impact relative velocity u_i and
// target normal velocity -e_i u_n,i (approaching) or 0. For a movable body touched on side s (-1
// for a, +1 for b) at offset r, the contact's columns of J^T are s [dir; r x dir] for dir in
// (n_i, d_i1..d_iD), and W = diag(I3 / m, Iw^-1). The LCP unknowns of contact i are contiguous,
//   z = [..., P_n,i, beta_i1..beta_iD, lambda_i, ...]   (frictionless contacts: P_n,i only),
// and the LCP is
//   M = [ A         0 ]    A = J W J^T over the (P_n, beta) unknowns (summed body by body),
//       [           E ]    E_i = column of ones coupling beta_ik to lambda_i,
//       [ mu  -E^T  0 ]
//   q = [u_n,i + e_i u_n,i (or u_n,i);  d_ik . u_i;  0].
#include "collision_response/core/exact_solver.h"

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <algorithm>
#include <array>
#include <cmath>

#include "collision_response/core/lcp.h"

namespace collision_response::core {
namespace {

using Eigen::Index;

constexpr double kPi = 3.14159265358979323846;
constexpr int kD = kPyramidDirections;
static_assert(kD % 4 == 0, "t1, t2 and their opposites must be pyramid directions");

/// (cos, sin) of the pyramid's direction angles 2 pi k / D, computed once.
const std::array<Eigen::Vector2d, kD>& pyramidAngles() {
  static const std::array<Eigen::Vector2d, kD> table = [] {
    std::array<Eigen::Vector2d, kD> out;
    for (int k = 0; k < kD; ++k) {
      const double angle = 2.0 * kPi * k / kD;
      out[k] = Eigen::Vector2d(std::cos(angle), std::sin(angle));
    }
    return out;
  }();
  return table;
}
/// A contact slides if |u'_t| exceeds this fraction of the largest pre-impact |u| of the island.
constexpr double kSlipTolerance = 1e-9;
/// An answer whose worst complementarity violation exceeds this fraction of that |u| is refused.
/// Round-off reaches 1.5e-5 at a mass ratio of 1e12 (test_stress); the wrong answers this catches
/// miss by orders of magnitude (270x the speed in the property suite's find).
constexpr double kAcceptedResidual = 1e-3;

struct Contact {
  const ContactRow* row = nullptr;
  // n, then d_1..d_D: only n is set for a frictionless contact, whose other columns are unused.
  Eigen::Matrix<double, 3, kD + 1> directions;
  Index columns = 1;                            // unknowns with a column of J^T: 1 or 1 + D
  Index offset = 0;                             // first LCP unknown (P_n)
  int local[2] = {-1, -1};                      // island-local index of body a, b (-1: immovable)
  Eigen::Vector3d u = Eigen::Vector3d::Zero();  // pre-impact relative velocity [m/s]
  double target_u_n = 0.0;                      // [m/s]
  bool frictional = false;
  bool dynamic = false;  // mu_d in use (otherwise mu_s)
  // Solution [N s]: +P on b, -P on a, P = P_n n + P_t, P_t = sum_k beta_k d_k.
  double P_n = 0.0;
  Eigen::Matrix<double, kD, 1> beta = Eigen::Matrix<double, kD, 1>::Zero();
  Eigen::Vector3d P_t = Eigen::Vector3d::Zero();

  double mu() const { return dynamic ? row->dynamic_friction : row->static_friction; }
  Index lambda() const { return offset + columns; }
  Eigen::Vector3d impulse() const { return P_n * row->normal + P_t; }
  const Eigen::Vector3d& r(int side) const { return side == 0 ? row->space.r_a : row->space.r_b; }
};

/// Directions of the all-sticking unknowns: n, t1 = d_1 and t2 = d_(1 + D/4) of the pyramid.
Eigen::Matrix3d stickingDirections(const Contact& c) {
  Eigen::Matrix3d D;
  if (c.frictional) {
    D << c.directions.col(0), c.directions.col(1), c.directions.col(1 + kD / 4);
  } else {
    D << c.directions.col(0), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero();
  }
  return D;
}

/// An LDL^T whose smallest pivot is below this fraction of the largest is treated as singular.
constexpr double kRegularPivot = 1e-10;

// A movable body touched by a contact, and the contact's block of columns in J^T and W J^T.
struct Incidence {
  int body = 0;  // index into `bodies`
  int contact = 0;
  int side = 0;  // 0: body a, 1: body b
  Index column = 0;
};

// The LCP of one island and what is needed to read its solution.
class IslandLcp {
 public:
  IslandLcp(const std::vector<RigidBody>& bodies, const std::vector<ContactRow>& rows,
            const std::vector<int>& island);

  /// Largest pre-impact |u| [m/s].
  double speed() const { return u_reference_; }
  std::vector<Contact>& contacts() { return contacts_; }

  /// The all-sticking guess: the impulses that give every contact its target normal velocity
  /// (-e u_n approaching, 0 touching or separating) and no slip (the least-norm ones, the Delassus
  /// matrix being singular for redundant contacts) are compressive and inside the static Coulomb
  /// cones. Then they solve the problem (complementarity holds with every contact active and
  /// sticking) and are read; false otherwise (nothing changed). One linear solve instead of
  /// Lemke's pivots: a box landing flat, a row of touching bodies struck at one end.
  bool solveAllSticking();
  /// Solves the LCP with the current coefficients and reads the impulses; false if not solved.
  bool solve(std::size_t& pivots, const Deadline& deadline);
  /// Moves the contacts still on mu_s that slide after the current impulses to mu_d. True if any.
  bool switchSlidingToDynamic();
  /// Change of the relative velocity at contact c that the current impulses make [m/s].
  Eigen::Vector3d velocityChangeAt(const Contact& c) const;

 private:
  /// The all-sticking impulses from the Delassus matrix A = J W J^T (least-norm if singular).
  Eigen::VectorXd stickingByDelassus(const std::vector<Index>& first,
                                     const Eigen::VectorXd& rhs) const;
  void assemble();
  void velocityChanges();

  const std::vector<RigidBody>& bodies_;
  std::vector<Contact> contacts_;
  std::vector<Incidence> incidences_;  // sorted by body
  Eigen::Matrix<double, 6, Eigen::Dynamic> JT_, WJT_;
  Eigen::MatrixXd M_;
  Eigen::VectorXd q_;
  std::vector<Eigen::Vector3d> dv_, dw_;  // velocity changes of the island-local bodies
  std::vector<const RigidBody*> local_body_;
  double u_reference_ = 0.0;
  Index unknowns_ = 0;          // LCP size
  Index jacobian_columns_ = 0;  // columns of J^T
  bool assembled_ = false;
};

/// The least-norm all-sticking impulses P (A P = rhs, A = J W J^T) solved in body space: the
/// velocity changes D of the island's bodies that reach the targets, J D = rhs (least squares,
/// exact when consistent), then P = J y with J^T J y = M D, M = diag(m_b, I_b). Needs J of full
/// column rank, every body pinned by its contacts: false if one keeps a free direction. Each
/// body's moment columns are scaled by its largest lever arm L_b, for conditioning. `Columns`: 6
/// for one body (fixed-size), Eigen::Dynamic for several.
template <int Columns>
bool stickingInBodySpace(const std::vector<Contact>& contacts,
                         const std::vector<const RigidBody*>& bodies,
                         const std::vector<Index>& first, const Eigen::VectorXd& rhs,
                         Eigen::VectorXd& P) {
  using MatrixJ = Eigen::Matrix<double, Eigen::Dynamic, Columns>;
  using MatrixG = Eigen::Matrix<double, Columns, Columns>;
  using VectorG = Eigen::Matrix<double, Columns, 1>;
  const Index count = static_cast<Index>(bodies.size());
  std::vector<double> L(bodies.size(), 0.0);
  for (const Contact& c : contacts) {
    for (int side = 0; side < 2; ++side) {
      if (c.local[side] >= 0) L[c.local[side]] = std::max(L[c.local[side]], c.r(side).norm());
    }
  }
  for (const double l : L) {
    if (!(l > 0.0)) return false;  // touched only at its centre of mass: rotations are free
  }
  // Rows s [d^T, (r x d)^T / L_b] for each body b a contact touches (side s = -1 for a, +1 for b).
  MatrixJ J = MatrixJ::Zero(rhs.size(), 6 * count);
  for (std::size_t i = 0; i < contacts.size(); ++i) {
    const Contact& c = contacts[i];
    const Eigen::Matrix3d D = stickingDirections(c);
    for (int side = 0; side < 2; ++side) {
      const int b = c.local[side];
      if (b < 0) continue;
      for (Index j = 0; j < (c.frictional ? 3 : 1); ++j) {
        const Eigen::Vector3d d = (side == 0 ? -1.0 : 1.0) * D.col(j);
        J.template block<1, 3>(first[i] + j, 6 * b) += d.transpose();
        J.template block<1, 3>(first[i] + j, 6 * b + 3) += c.r(side).cross(d).transpose() / L[b];
      }
    }
  }
  MatrixG G;
  if constexpr (Columns == Eigen::Dynamic) {
    G.noalias() = J.transpose() * J;
  } else {
    G.noalias() = J.transpose().lazyProduct(J);  // small: no blocked product
  }
  const Eigen::LDLT<MatrixG> ldlt(G);
  if (ldlt.info() != Eigen::Success) return false;
  const VectorG d = ldlt.vectorD();
  if (!(d.minCoeff() > kRegularPivot * d.maxCoeff())) return false;
  const VectorG change = ldlt.solve(J.transpose() * rhs);  // [dv_b; L_b dw_b]
  VectorG momentum = VectorG::Zero(6 * count);             // S M S [dv_b; L_b dw_b]
  for (Index b = 0; b < count; ++b) {
    const RigidBody& body = *bodies[b];
    momentum.template segment<3>(6 * b) = change.template segment<3>(6 * b) / body.inverse_mass;
    momentum.template segment<3>(6 * b + 3) =
        body.inverse_inertia.llt().solve(change.template segment<3>(6 * b + 3)) / (L[b] * L[b]);
  }
  P = J * ldlt.solve(momentum);
  return true;
}

IslandLcp::IslandLcp(const std::vector<RigidBody>& bodies, const std::vector<ContactRow>& rows,
                     const std::vector<int>& island)
    : bodies_(bodies), contacts_(island.size()) {
  // Contacts: directions, targets, LCP layout, incidences.
  Index unknowns = 0;
  Index jacobian_columns = 0;
  incidences_.reserve(2 * island.size());
  for (std::size_t i = 0; i < island.size(); ++i) {
    Contact& c = contacts_[i];
    c.row = &rows[island[i]];
    const ContactRow& row = *c.row;
    c.u = row.space.relativeVelocity(bodies[row.body_a], bodies[row.body_b]);
    const double u_n = c.u.dot(row.normal);
    c.target_u_n = u_n < 0.0 ? -row.restitution * u_n : 0.0;
    u_reference_ = std::max(u_reference_, c.u.norm());
    c.frictional = !row.frictionless();
    c.directions.col(0) = row.normal;
    if (c.frictional) {  // t1 = d_1 and t2 = d_(1 + D/4) now, the rest of the pyramid for Lemke
      Eigen::Vector3d t1, t2;
      tangentBasis(row.normal, t1, t2);
      c.directions.col(1) = t1;
      c.directions.col(1 + kD / 4) = t2;
      c.columns = 1 + kD;
    }
    c.offset = unknowns;
    unknowns += c.frictional ? c.columns + 1 : 1;
    const int body_index[2] = {row.body_a, row.body_b};
    for (int side = 0; side < 2; ++side) {
      if (!bodies[body_index[side]].movable()) continue;
      incidences_.push_back({body_index[side], static_cast<int>(i), side, jacobian_columns});
      jacobian_columns += c.columns;
    }
  }

  // Island-local body indices, in body order.
  std::sort(incidences_.begin(), incidences_.end(), [](const Incidence& x, const Incidence& y) {
    return x.body < y.body || (x.body == y.body && x.contact < y.contact);
  });
  for (std::size_t g = 0; g < incidences_.size(); ++g) {
    if (g == 0 || incidences_[g].body != incidences_[g - 1].body) {
      local_body_.push_back(&bodies[incidences_[g].body]);
    }
    contacts_[incidences_[g].contact].local[incidences_[g].side] =
        static_cast<int>(local_body_.size()) - 1;
  }
  dv_.resize(local_body_.size());
  dw_.resize(local_body_.size());

  unknowns_ = unknowns;
  jacobian_columns_ = jacobian_columns;
}

void IslandLcp::assemble() {
  JT_.resize(6, jacobian_columns_);
  WJT_.resize(6, jacobian_columns_);
  M_.setZero(unknowns_, unknowns_);
  q_.setZero(unknowns_);
  // The friction pyramids: d_k = cos(2 pi k / D) t1 + sin(2 pi k / D) t2.
  const std::array<Eigen::Vector2d, kD>& angles = pyramidAngles();
  for (Contact& c : contacts_) {
    if (!c.frictional) continue;
    const Eigen::Vector3d t1 = c.directions.col(1), t2 = c.directions.col(1 + kD / 4);
    for (int k = 0; k < kD; ++k) {
      if (k % (kD / 4) != 0) c.directions.col(1 + k) = angles[k].x() * t1 + angles[k].y() * t2;
    }
    c.directions.col(1 + kD / 2) = -t1;
    c.directions.col(1 + 3 * kD / 4) = -t2;
  }
  // J^T and W J^T, one 6 x columns block per incidence.
  for (const Incidence& inc : incidences_) {
    const Contact& c = contacts_[inc.contact];
    const RigidBody& body = bodies_[inc.body];
    const double sign = inc.side == 0 ? -1.0 : 1.0;
    for (Index j = 0; j < c.columns; ++j) {
      const Eigen::Vector3d dir = sign * c.directions.col(j);
      const Eigen::Vector3d moment = c.r(inc.side).cross(dir);
      JT_.col(inc.column + j) << dir, moment;
      WJT_.col(inc.column + j) << body.inverse_mass * dir, body.inverse_inertia * moment;
    }
  }

  // A = J W J^T: contacts couple through each body they share (including a contact with itself).
  for (std::size_t begin = 0, end = 0; begin < incidences_.size(); begin = end) {
    end = begin + 1;
    while (end < incidences_.size() && incidences_[end].body == incidences_[begin].body) ++end;
    for (std::size_t x = begin; x < end; ++x) {
      const Contact& cx = contacts_[incidences_[x].contact];
      for (std::size_t y = begin; y < end; ++y) {
        const Contact& cy = contacts_[incidences_[y].contact];
        M_.block(cx.offset, cy.offset, cx.columns, cy.columns).noalias() +=
            JT_.middleCols(incidences_[x].column, cx.columns).transpose() *
            WJT_.middleCols(incidences_[y].column, cy.columns);
      }
    }
  }
  for (const Contact& c : contacts_) {
    q_.segment(c.offset, c.columns) = c.directions.leftCols(c.columns).transpose() * c.u;
    q_(c.offset) -= c.target_u_n;
    if (!c.frictional) continue;
    M_.block(c.offset + 1, c.lambda(), kD, 1).setOnes();
    M_.block(c.lambda(), c.offset + 1, 1, kD).setConstant(-1.0);
    M_(c.lambda(), c.offset) = c.mu();
  }
}

bool IslandLcp::solveAllSticking() {
  // Unknowns: P_n per contact, and (t1, t2) components for frictional ones.
  std::vector<Index> first(contacts_.size());
  Index unknowns = 0;
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    first[i] = unknowns;
    unknowns += contacts_[i].frictional ? 3 : 1;
  }
  Eigen::VectorXd rhs(unknowns);
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    const Contact& c = contacts_[i];
    const Eigen::Vector3d change = stickingDirections(c).transpose() * -c.u;  // to u' = 0 ...
    rhs.segment(first[i], c.frictional ? 3 : 1) = change.head(c.frictional ? 3 : 1);
    rhs(first[i]) += c.target_u_n;  // ... but u'_n = -e u_n
  }
  // More unknowns than the bodies' degrees of freedom (redundant contacts, as under a box): solved
  // in body space; otherwise, or if a body keeps a free direction, with the Delassus matrix.
  Eigen::VectorXd P;
  const bool in_body_space =
      unknowns > 6 * static_cast<Index>(local_body_.size()) &&
      (local_body_.size() == 1
           ? stickingInBodySpace<6>(contacts_, local_body_, first, rhs, P)
           : stickingInBodySpace<Eigen::Dynamic>(contacts_, local_body_, first, rhs, P));
  if (!in_body_space) P = stickingByDelassus(first, rhs);
  if (!P.allFinite()) return false;

  // Admissible: compressive and inside the static cones.
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    const Contact& c = contacts_[i];
    const double P_n = P(first[i]);
    if (!(P_n >= 0.0)) return false;
    if (c.frictional && P.segment<2>(first[i] + 1).norm() > c.row->static_friction * P_n)
      return false;
  }
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    Contact& c = contacts_[i];
    c.P_n = P(first[i]);
    c.beta.setZero();
    c.P_t = c.frictional
                ? Eigen::Vector3d(stickingDirections(c).rightCols<2>() * P.segment<2>(first[i] + 1))
                : Eigen::Vector3d::Zero();
  }
  velocityChanges();
  // Consistent: the velocity changes these impulses make reach every target (A P = rhs), to
  // round-off of the island's scale. Otherwise the targets are not reachable together.
  const double tolerance = 1e-10 * std::max(u_reference_, rhs.cwiseAbs().maxCoeff());
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    const Contact& c = contacts_[i];
    const Index k = c.frictional ? 3 : 1;
    const Eigen::Vector3d change = stickingDirections(c).transpose() * velocityChangeAt(c);
    if ((change.head(k) - rhs.segment(first[i], k)).cwiseAbs().maxCoeff() > tolerance) {
      for (Contact& reset : contacts_) reset.P_n = 0.0, reset.P_t.setZero();
      return false;
    }
  }
  return true;
}

Eigen::VectorXd IslandLcp::stickingByDelassus(const std::vector<Index>& first,
                                              const Eigen::VectorXd& rhs) const {
  // Columns [d; r x d] of J^T and of W J^T for each incidence, computed once.
  struct Columns {
    Eigen::Matrix<double, 6, 3> J, WJ;
    Index first, count;
  };
  std::vector<Columns> columns(incidences_.size());
  for (std::size_t g = 0; g < incidences_.size(); ++g) {
    const Incidence& inc = incidences_[g];
    const Contact& c = contacts_[inc.contact];
    const RigidBody& body = bodies_[inc.body];
    const Eigen::Matrix3d D = stickingDirections(c) * (inc.side == 0 ? -1.0 : 1.0);
    Columns& out = columns[g];
    out.first = first[inc.contact];
    out.count = c.frictional ? 3 : 1;
    for (Index j = 0; j < out.count; ++j) {
      const Eigen::Vector3d moment = c.r(inc.side).cross(D.col(j));
      out.J.col(j) << D.col(j), moment;
      out.WJ.col(j) << body.inverse_mass * D.col(j), body.inverse_inertia * moment;
    }
  }
  // A = J W J^T over the sticking unknowns: contacts couple through each body they share.
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(rhs.size(), rhs.size());
  for (std::size_t begin = 0, end = 0; begin < incidences_.size(); begin = end) {
    end = begin + 1;
    while (end < incidences_.size() && incidences_[end].body == incidences_[begin].body) ++end;
    for (std::size_t x = begin; x < end; ++x) {
      const Columns& cx = columns[x];
      for (std::size_t y = begin; y < end; ++y) {
        const Columns& cy = columns[y];
        if (cx.count == 3 && cy.count == 3) {
          A.block<3, 3>(cx.first, cy.first).noalias() += cx.WJ.transpose() * cy.J;
        } else {
          for (Index i = 0; i < cx.count; ++i) {
            for (Index j = 0; j < cy.count; ++j) {
              A(cx.first + i, cy.first + j) += cx.WJ.col(i).dot(cy.J.col(j));
            }
          }
        }
      }
    }
  }
  // Independent contacts: A is positive definite and LDL^T solves it. Redundant ones (a singular
  // A): the least-norm solution, by a complete orthogonal decomposition.
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(A);
  if (ldlt.info() == Eigen::Success && ldlt.isPositive()) {
    const Eigen::VectorXd d = ldlt.vectorD();
    if (d.minCoeff() > kRegularPivot * d.maxCoeff()) return ldlt.solve(rhs);
  }
  return A.completeOrthogonalDecomposition().solve(rhs);
}

Eigen::Vector3d IslandLcp::velocityChangeAt(const Contact& c) const {
  Eigen::Vector3d du = Eigen::Vector3d::Zero();  // change of v_b(p) - v_a(p)
  for (int side = 0; side < 2; ++side) {
    if (c.local[side] < 0) continue;
    const Eigen::Vector3d change = dv_[c.local[side]] + dw_[c.local[side]].cross(c.r(side));
    du += side == 0 ? Eigen::Vector3d(-change) : change;
  }
  return du;
}

bool IslandLcp::solve(std::size_t& pivots, const Deadline& deadline) {
  if (!assembled_) {  // only when the all-sticking guess did not answer
    assemble();
    assembled_ = true;
  }
  LcpOptions lcp_options;
  lcp_options.deadline = deadline;
  const LcpResult lcp = solveLcp(M_, q_, lcp_options);
  pivots += lcp.pivots;
  if (lcp.status != LcpStatus::kSolved) return false;
  for (Contact& c : contacts_) {
    c.P_n = lcp.z(c.offset);
    if (!c.frictional) continue;
    c.beta = lcp.z.segment<kD>(c.offset + 1);
    // sum beta <= mu P_n holds up to round-off; make it exact so P_t is inside the cone.
    const double limit = c.mu() * c.P_n;
    if (c.beta.sum() > limit) c.beta *= limit / c.beta.sum();
    c.P_t = c.directions.rightCols<kD>() * c.beta;
  }
  velocityChanges();
  return true;
}

void IslandLcp::velocityChanges() {
  std::fill(dv_.begin(), dv_.end(), Eigen::Vector3d::Zero());
  std::fill(dw_.begin(), dw_.end(), Eigen::Vector3d::Zero());
  for (const Contact& c : contacts_) {
    for (int side = 0; side < 2; ++side) {
      if (c.local[side] < 0) continue;
      const RigidBody& body = *local_body_[c.local[side]];
      const Eigen::Vector3d p = (side == 0 ? -1.0 : 1.0) * c.impulse();
      dv_[c.local[side]] += body.inverse_mass * p;
      dw_[c.local[side]] += body.inverse_inertia * c.r(side).cross(p);
    }
  }
}

bool IslandLcp::switchSlidingToDynamic() {
  bool changed = false;
  for (Contact& c : contacts_) {
    if (!c.frictional || c.dynamic || c.row->dynamic_friction == c.row->static_friction) continue;
    const Eigen::Vector3d u = c.u + velocityChangeAt(c);
    const Eigen::Vector3d u_t = u - u.dot(c.row->normal) * c.row->normal;
    if (u_t.norm() > kSlipTolerance * u_reference_) {
      c.dynamic = true;
      M_(c.lambda(), c.offset) = c.mu();
      changed = true;
    }
  }
  return changed;
}

}  // namespace

double pyramidFactor() {
  return std::cos(kPi / kD);
}

ExactStats solveExact(std::vector<RigidBody>& bodies, const std::vector<ContactRow>& rows,
                      const std::vector<int>& island, const SolverOptions& options,
                      std::vector<ContactImpulse>& impulses) {
  ExactStats stats;
  IslandLcp lcp(bodies, rows, island);
  const bool all_sticking = lcp.solveAllSticking();  // checked against its targets already
  bool solved = all_sticking;
  while (!solved && lcp.solve(stats.pivots, options.deadline)) {
    if (!lcp.switchSlidingToDynamic()) {
      solved = true;
      break;
    }
  }

  // Complementarity violation of contact c at post-impact relative velocity u [m/s]:
  // |min(velocity, k_nn impulse)| is 0 iff both are >= 0 and one of them is 0.
  const auto violation = [all_sticking](const Contact& c, const Eigen::Vector3d& u) {
    const ContactRow& row = *c.row;
    const double u_n = u.dot(row.normal);
    const double k_nn = row.normal.dot(row.space.K * row.normal);
    const auto pair = [k_nn](double velocity, double impulse) {
      return std::abs(std::min(velocity, k_nn * impulse));
    };
    double worst = pair(u_n - c.target_u_n, c.P_n);
    if (c.frictional && all_sticking) {
      // No pyramid (beta = 0): its terms are min(lambda, k_nn mu P_n) <= min(|u_t|, k_nn mu P_n).
      worst = std::max(worst, pair((u - u_n * row.normal).norm(), c.mu() * c.P_n));
    } else if (c.frictional) {
      const Eigen::Matrix<double, kD, 1> slip =
          c.directions.rightCols<kD>().transpose() * (u - u_n * row.normal);
      const double lambda = std::max(0.0, -slip.minCoeff());
      for (int k = 0; k < kD; ++k) worst = std::max(worst, pair(lambda + slip(k), c.beta(k)));
      worst = std::max(worst, pair(lambda, c.mu() * c.P_n - c.beta.sum()));
    }
    return worst;
  };
  const auto relative = [&lcp](double worst) {
    return lcp.speed() > 0.0 ? worst / lcp.speed() : worst;
  };

  // Trust the answer, not the pivots: an LCP solution accepted against the scale of huge,
  // cancelling impulses can still leave contacts approaching. It is refused here, from the
  // velocities it would give, and nothing is applied.
  std::vector<Contact>& contacts = lcp.contacts();
  if (solved && !all_sticking) {
    double worst = 0.0;
    for (const Contact& c : contacts) {
      worst = std::max(worst, violation(c, c.u + lcp.velocityChangeAt(c)));
    }
    solved = relative(worst) <= kAcceptedResidual;
  }

  // Apply (nothing if unsolved), report, and measure the residual from the final velocities.
  for (Contact& c : contacts) {
    if (!solved) c.P_n = 0.0, c.beta.setZero(), c.P_t.setZero();
    c.row->space.applyImpulse(bodies[c.row->body_a], bodies[c.row->body_b], c.impulse());
  }
  double worst = 0.0;
  for (std::size_t i = 0; i < contacts.size(); ++i) {
    const Contact& c = contacts[i];
    const ContactRow& row = *c.row;
    const Eigen::Vector3d u = row.space.relativeVelocity(bodies[row.body_a], bodies[row.body_b]);
    worst = std::max(worst, violation(c, u));
    const Eigen::Vector3d u_t = u - u.dot(row.normal) * row.normal;
    ContactImpulse& out = impulses[island[i]];
    out.normal_impulse = c.P_n;
    out.friction_impulse = c.P_t;
    out.sticking = c.frictional && c.P_n > 0.0 && u_t.norm() <= kSlipTolerance * lcp.speed();
  }
  stats.residual = relative(worst);
  stats.converged = solved;
  return stats;
}

}  // namespace collision_response::core
