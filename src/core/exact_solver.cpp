// Exact multi-contact Newton restitution: the contact LCP of exact_solver.h, solved by lcp.h.
//
// Everything is read from the contact problem (contact_problem.h). Symbols: contact i has normal
// n_i, pyramid directions d_ik, pre-impact relative velocity u_i and target normal velocity
// (ProblemContact::target_normal_velocity). With D_i = [n_i d_i1 .. d_iD] the contact's directions
// and W_ij the problem's Delassus blocks, A_ij = D_i^T W_ij D_j. The LCP unknowns of contact i are
// contiguous,
//   z = [..., P_n,i, beta_i1..beta_iD, lambda_i, ...]   (frictionless contacts: P_n,i only),
// and the LCP is
//   M = [ A         0 ]    A over the (P_n, beta) unknowns (blocks of W, diagonal and coupled),
//       [           E ]    E_i = column of ones coupling beta_ik to lambda_i,
//       [ mu  -E^T  0 ]
//   q = [u_n,i + e_i u_n,i (or u_n,i);  d_ik . u_i;  0].
#include "collision_response/core/exact_solver.h"
#include "collision_response/core/constants.h"

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <algorithm>
#include <array>
#include <cmath>

#include "collision_response/core/lcp.h"
#include "collision_response/core/mode_solver.h"

namespace collision_response::core {
namespace {

using Eigen::Index;

using collision_response::core::kPi;
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
/// A contact whose slip exceeds this fraction of its |u| gets its pyramid turned to the slip.
constexpr double kAlignedSlip = 1e-6;
/// A contact slides if |u'_t| exceeds this fraction of the largest pre-impact |u| of the island.
constexpr double kSlipTolerance = 1e-9;
/// An answer whose worst complementarity violation exceeds this fraction of that |u| is refused.
/// Round-off reaches 1.5e-5 at a mass ratio of 1e12 (test_stress); the wrong answers this catches
/// miss by orders of magnitude (270x the speed in the property suite's find).
constexpr double kAcceptedResidual = 1e-3;

// One contact of the problem as the LCP sees it (named so as not to shadow core::Contact).
struct LcpContact {
  const ProblemContact* entry = nullptr;
  int index = 0;  // in the problem
  // n, then d_1..d_D: only n is set for a frictionless contact, whose other columns are unused.
  Eigen::Matrix<double, 3, kD + 1> directions = Eigen::Matrix<double, 3, kD + 1>::Zero();
  Index columns = 1;                            // unknowns with a column of J^T: 1 or 1 + D
  Index offset = 0;                             // first LCP unknown (P_n)
  int local[2] = {-1, -1};                      // problem body of a, b (-1: no unknowns)
  Eigen::Vector3d u = Eigen::Vector3d::Zero();  // pre-impact relative velocity [m/s]
  double target_u_n = 0.0;                      // [m/s]
  bool frictional = false;
  bool dynamic = false;  // mu_d in use (otherwise mu_s)
  // Solution [N s]: +P on b, -P on a, P = P_n n + P_t, P_t = sum_k beta_k d_k.
  double P_n = 0.0;
  Eigen::Matrix<double, kD, 1> beta = Eigen::Matrix<double, kD, 1>::Zero();
  Eigen::Vector3d P_t = Eigen::Vector3d::Zero();

  double mu() const { return dynamic ? entry->dynamic_friction : entry->static_friction; }
  Index lambda() const { return offset + columns; }
  Eigen::Vector3d impulse() const { return P_n * entry->normal + P_t; }
  const Eigen::Vector3d& r(int side) const {
    return side == 0 ? entry->lever_arm_a : entry->lever_arm_b;
  }
};

/// Directions of the all-sticking unknowns: n, t1 = d_1 and t2 = d_(1 + D/4) of the pyramid.
Eigen::Matrix3d stickingDirections(const LcpContact& c) {
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

// Per-thread storage of the exact solver, whose capacity is kept from one solve to the next (no
// allocation per solve once it has seen islands of this size).
struct ExactWorkspace {
  std::vector<LcpContact> contacts;
  Eigen::VectorXd velocity_changes;  // of the problem's unknowns
  // The general all-sticking solve: each contact's first unknown, the targets, the impulses, and
  // a tridiagonal factor's D and L.
  std::vector<Index> first;
  Eigen::VectorXd rhs, P, d, l;
};

// The LCP of one island's contact problem and what is needed to read its solution.
class IslandLcp {
 public:
  /// Step 1 of the construction: directions, targets and the LCP layout of every contact, in
  /// `workspace` (per thread).
  IslandLcp(const ContactProblem& problem, ExactWorkspace& workspace);

  /// Largest pre-impact |u| [m/s].
  double speed() const { return u_reference_; }
  std::vector<LcpContact>& contacts() { return contacts_; }

  /// The all-sticking guess: the impulses that give every contact its target normal velocity
  /// (-e u_n approaching, 0 touching or separating) and no slip (the least-norm ones, the Delassus
  /// matrix being singular for redundant contacts or bodies with few freedoms) are compressive and
  /// inside the static Coulomb cones, and reach the targets. Then they solve the problem
  /// (complementarity holds with every contact active and sticking) and are read; false otherwise
  /// (nothing changed). One linear solve instead of Lemke's pivots: a box landing flat, a row of
  /// touching bodies struck at one end.
  bool solveAllSticking();
  /// Solves the LCP with the current coefficients and reads the impulses; false if not solved.
  /// Small islands (at most kModeSolverMaxUnknowns frame unknowns) first by their modes
  /// (mode_solver.h, warm-started from the all-sticking impulses and then from the previous
  /// answer), Lemke only if no mode fits. `work`: Lemke pivots plus modes checked.
  bool solve(std::size_t& work, const Deadline& deadline);
  /// Moves the contacts still on mu_s that slide after the current impulses to mu_d. True if any.
  bool switchSlidingToDynamic();
  /// Change of the relative velocity at contact c that the current impulses make [m/s].
  Eigen::Vector3d velocityChangeAt(const LcpContact& c) const {
    return problem_.motionChange(c.index, velocity_changes_);
  }

 private:
  /// The all-sticking answer P (frame unknowns, contact i's from first[i]) if it is admissible
  /// and consistent (solveAllSticking()): then read, and true.
  bool acceptSticking(const double* P, const Index* first, const double* rhs, double rhs_scale);
  /// The all-sticking impulses of a frictionless chain (A tridiagonal, nonsingular) by an O(n)
  /// LDL^T; false (P untouched) if the island is not one.
  bool stickingTridiagonal(const Eigen::VectorXd& rhs, Eigen::VectorXd& P);
  /// n_i^T W_ij n_j, from the shared bodies' masses and inertias when they are free rigid bodies
  /// (the problem's delassusBlock() otherwise).
  double normalCoupling(int i, int j) const;
  /// The all-sticking impulses from the Delassus matrix (least-norm if singular).
  Eigen::VectorXd stickingByDelassus(const std::vector<Index>& first,
                                     const Eigen::VectorXd& rhs) const;
  /// Small islands: the contacts' frame data (first unknown, u in the frame, target) into modes_.
  void assembleSmallFrames();
  /// Small islands: the frame Delassus matrix S^T W S into small_A_ (and the frame data if not
  /// yet there); once per solve.
  void assembleSmall();
  /// The LCP by modes (small islands); false if no mode fitted (nothing changed then).
  bool solveByModes(std::size_t& work);
  /// Step 2, only when Lemke runs: the rest of each friction pyramid.
  void completePyramids();
  /// Step 3: M's A part from the problem's Delassus blocks, A_ij = D_i^T W_ij D_j.
  void assembleDelassus();
  /// Step 4: q and the friction coupling rows (E, mu, -E^T).
  void assembleFrictionRows();
  /// The bodies' velocity changes from the current impulses.
  void velocityChanges();

  const ContactProblem& problem_;
  std::vector<LcpContact>& contacts_;
  ExactWorkspace& workspace_;
  // Small islands: the frame Delassus matrix and each contact's mode (warm start, answer).
  bool small_ = false;
  bool small_frames_ = false;
  bool small_assembled_ = false;
  bool modes_warm_ = false;    // modes_ hold a warm start
  bool inconsistent_ = false;  // the last all-sticking impulses missed the targets in body space
  // Small islands whose targets no rigid motion reaches together (redundant contacts with
  // different restitutions: the 4 corners of a face, whose normal velocities after lie on one
  // plane): the least-squares miss u'_n - target of each contact (stickingInBodySpace()), read by
  // the first solveByModes(), which then starts with one of the contacts carried away faster than
  // its target separating.
  bool missed_targets_ = false;
  std::array<double, kModeSolverMaxUnknowns> normal_miss_{};
  Index frame_unknowns_ = 0;
  ModeMatrix small_A_;
  std::array<ModeContact, kModeSolverMaxUnknowns> modes_;
  Eigen::MatrixXd M_;
  Eigen::VectorXd q_;
  Eigen::VectorXd& velocity_changes_;  // of the problem's unknowns (in the workspace)
  double u_reference_ = 0.0;
  Index unknowns_ = 0;  // LCP size
  bool assembled_ = false;
  bool pyramids_complete_ = false;  // every d_k of the frictional contacts set
};

/// The least-norm all-sticking impulses P (A P = rhs) solved in body space, for free rigid bodies:
/// the velocity changes D of the island's bodies that reach the targets, J D = rhs (least
/// squares, exact when consistent), then P = J y with J^T J y = M D, M = diag(m_b, I_b). Needs J
/// of full column rank, every body pinned by its contacts: false if one keeps a free direction,
/// or if a body is not a free rigid body. Each body's moment columns are scaled by its largest
/// lever arm L_b, for conditioning. `Columns`: 6 for one body (fixed-size), Eigen::Dynamic for
/// several. `MaxRows`: a bound on the frame unknowns (kModeSolverMaxUnknowns for small islands:
/// then J lives on the stack) or Eigen::Dynamic; `first[i]`: contact i's first frame unknown.
/// `normal_miss` (if given, one entry per contact): the least-squares velocity changes' normal
/// velocity minus the target, u'_n - target [m/s]: zero when the targets are reachable together;
/// otherwise the least-squares residual (J D - rhs, orthogonal to the range of J whatever the
/// column scaling), positive at the contacts the rigid motion carries away faster than their
/// targets.
template <int Columns, int MaxRows, class Rhs, class Out>
bool stickingInBodySpace(const std::vector<LcpContact>& contacts,
                         const std::vector<ProblemBody>& bodies, const Index* first, const Rhs& rhs,
                         Out& P, double* normal_miss = nullptr) {
  using MatrixJ = Eigen::Matrix<double, Eigen::Dynamic, Columns, Eigen::ColMajor, MaxRows, Columns>;
  using MatrixG = Eigen::Matrix<double, Columns, Columns>;
  using VectorG = Eigen::Matrix<double, Columns, 1>;
  // L_b per body: one entry for a single body (Columns == 6), on the stack.
  using VectorL = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor,
                                Columns == Eigen::Dynamic ? Eigen::Dynamic : Columns / 6, 1>;
  const Index count = static_cast<Index>(bodies.size());
  if (Columns != Eigen::Dynamic && 6 * count != Columns) return false;
  for (const ProblemBody& body : bodies) {
    if (!body.rigid()) return false;
  }
  VectorL L = VectorL::Zero(count);
  for (const LcpContact& c : contacts) {
    for (int side = 0; side < 2; ++side) {
      if (c.local[side] >= 0) L(c.local[side]) = std::max(L(c.local[side]), c.r(side).norm());
    }
  }
  for (Index b = 0; b < count; ++b) {
    if (!(L(b) > 0.0)) return false;  // touched only at its centre of mass: rotations are free
  }
  // Rows s [d^T, (r x d)^T / L_b] for each body b a contact touches (side s = -1 for a, +1 for b).
  MatrixJ J = MatrixJ::Zero(rhs.size(), 6 * count);
  for (std::size_t i = 0; i < contacts.size(); ++i) {
    const LcpContact& c = contacts[i];
    const Eigen::Matrix3d D = stickingDirections(c);
    for (int side = 0; side < 2; ++side) {
      const int b = c.local[side];
      if (b < 0) continue;
      for (Index j = 0; j < (c.frictional ? 3 : 1); ++j) {
        const Eigen::Vector3d d = (side == 0 ? -1.0 : 1.0) * D.col(j);
        J.template block<1, 3>(first[i] + j, 6 * b) += d.transpose();
        J.template block<1, 3>(first[i] + j, 6 * b + 3) += c.r(side).cross(d).transpose() / L(b);
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
  VectorG Jt_rhs;
  if constexpr (Columns == Eigen::Dynamic) {
    Jt_rhs.noalias() = J.transpose() * rhs;
  } else {
    Jt_rhs.noalias() = J.transpose().lazyProduct(rhs);
  }
  const VectorG change = ldlt.solve(Jt_rhs);  // [dv_b; L_b dw_b]
  if (normal_miss != nullptr) {
    for (std::size_t i = 0; i < contacts.size(); ++i) {
      normal_miss[i] = J.row(first[i]).dot(change) - rhs(first[i]);
    }
  }
  VectorG momentum = VectorG::Zero(6 * count);  // S M S [dv_b; L_b dw_b]
  for (Index b = 0; b < count; ++b) {
    const ProblemBody& body = bodies[b];
    momentum.template segment<3>(6 * b) = change.template segment<3>(6 * b) / body.inverse_mass;
    momentum.template segment<3>(6 * b + 3) =
        body.inverse_inertia.llt().solve(change.template segment<3>(6 * b + 3)) / (L(b) * L(b));
  }
  const VectorG y = ldlt.solve(momentum);
  if constexpr (Columns == Eigen::Dynamic) {
    P.noalias() = J * y;
  } else {
    P.noalias() = J.lazyProduct(y);
  }
  return true;
}

IslandLcp::IslandLcp(const ContactProblem& problem, ExactWorkspace& workspace)
    : problem_(problem),
      contacts_(workspace.contacts),
      workspace_(workspace),
      velocity_changes_(workspace.velocity_changes) {
  contacts_.resize(problem.size());
  Index unknowns = 0;
  for (std::size_t i = 0; i < problem.size(); ++i) {
    LcpContact& c = contacts_[i];  // reused storage: every field read later is set here
    const ProblemContact& entry = problem.contact(i);
    c.columns = 1;
    c.dynamic = false;
    c.P_n = 0.0;
    c.beta.setZero();
    c.P_t.setZero();
    c.entry = &entry;
    c.index = static_cast<int>(i);
    c.local[0] = entry.local_a;
    c.local[1] = entry.local_b;
    c.u = problem.relativeMotion(i);
    c.target_u_n = problem.targetNormal(i);
    u_reference_ = std::max(u_reference_, c.u.norm());
    c.frictional = !entry.frictionless();
    c.directions.col(0) = entry.normal;
    if (c.frictional) {  // t1 = d_1 and t2 = d_(1 + D/4) now, the rest of the pyramid for Lemke
      // The pyramid is turned so that d_1 lies along the contact's slip when it slides: friction
      // against a slip whose direction the impact keeps (a body sliding flat or along an edge)
      // is then Coulomb's exactly, not the nearest facet's.
      Eigen::Vector3d slip = c.u - c.u.dot(entry.normal) * entry.normal;
      if (slip.norm() > kAlignedSlip * c.u.norm()) {
        slip -= slip.dot(entry.normal) * entry.normal;  // tangential to round-off once normalized
        c.directions.col(1) = slip.normalized();
        c.directions.col(1 + kD / 4) = entry.normal.cross(c.directions.col(1));
      } else {
        c.directions.col(1) = entry.tangent1;
        c.directions.col(1 + kD / 4) = entry.tangent2;
      }
      c.columns = 1 + kD;
    }
    c.offset = unknowns;
    unknowns += c.frictional ? c.columns + 1 : 1;
    frame_unknowns_ += c.frictional ? 3 : 1;
  }
  unknowns_ = unknowns;
  small_ = frame_unknowns_ <= kModeSolverMaxUnknowns;
  velocity_changes_.setZero(problem.unknowns());
}

void IslandLcp::assembleSmallFrames() {
  Index first = 0;
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    const LcpContact& c = contacts_[i];
    const Index k = c.frictional ? 3 : 1;
    ModeContact& m = modes_[i];
    m.frictional = c.frictional;
    m.first = static_cast<int>(first);
    if (c.frictional) {
      m.u = stickingDirections(c).transpose() * c.u;
    } else {
      m.u = Eigen::Vector3d(c.directions.col(0).dot(c.u), 0.0, 0.0);
    }
    m.target = c.target_u_n;
    first += k;
  }
  small_frames_ = true;
}

void IslandLcp::assembleSmall() {
  if (small_assembled_) return;
  if (!small_frames_) assembleSmallFrames();
  small_A_.setZero(frame_unknowns_, frame_unknowns_);
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    const LcpContact& c = contacts_[i];
    const Index k = c.frictional ? 3 : 1;
    const Eigen::Matrix3d S = stickingDirections(c);
    small_A_.block(modes_[i].first, modes_[i].first, k, k) =
        (S.transpose() * c.entry->delassus * S).topLeftCorner(k, k);
  }
  for (const auto& [i, j] : problem_.couplings()) {
    const LcpContact& ci = contacts_[i];
    const LcpContact& cj = contacts_[j];
    const Index ki = ci.frictional ? 3 : 1, kj = cj.frictional ? 3 : 1;
    const Eigen::Matrix3d block =
        stickingDirections(ci).transpose() * problem_.delassusBlock(i, j) * stickingDirections(cj);
    small_A_.block(modes_[i].first, modes_[j].first, ki, kj) = block.topLeftCorner(ki, kj);
    small_A_.block(modes_[j].first, modes_[i].first, kj, ki) =
        block.topLeftCorner(ki, kj).transpose();
  }
  small_assembled_ = true;
}

bool IslandLcp::solveByModes(std::size_t& work) {
  if (!small_assembled_) assembleSmall();
  const int count = static_cast<int>(contacts_.size());
  double speed = u_reference_;
  for (int i = 0; i < count; ++i) {
    ModeContact& m = modes_[i];
    m.mu = contacts_[i].mu();
    speed = std::max(speed, std::abs(m.target));
    if (modes_warm_) continue;
    // No all-sticking impulses to start from: active if approaching or touching, sticking.
    m.mode = m.u.x() > m.target ? ContactMode::kSeparating : ContactMode::kSticking;
  }
  const int max_modes = 2 * count + 4;
  int tried = 0;
  if (missed_targets_) {
    // No mode with every contact active fits (Newton's targets miss each other): start instead
    // from the warm start with one contact separating, those the least-squares motion carries away
    // fastest first (a diagonal pair for a face's 4 corners); each search is checked in full, so
    // the order only decides the cost.
    missed_targets_ = false;
    std::array<ModeContact, kModeSolverMaxUnknowns> start;
    std::array<int, kModeSolverMaxUnknowns> order;
    int candidates = 0;
    const double tolerance = 1e-10 * speed;
    for (int i = 0; i < count; ++i) {
      start[i] = modes_[i];
      if (normal_miss_[i] > tolerance && modes_[i].mode != ContactMode::kSeparating)
        order[candidates++] = i;
    }
    std::sort(order.begin(), order.begin() + candidates,
              [this](int a, int b) { return normal_miss_[a] > normal_miss_[b]; });
    for (int c = 0; c < candidates && tried <= 0; ++c) {
      for (int i = 0; i < count; ++i) modes_[i] = start[i];
      modes_[order[c]].mode = ContactMode::kSeparating;
      tried = core::solveByModes(small_A_, modes_.data(), count, speed, max_modes);
      work += static_cast<std::size_t>(std::abs(tried));
    }
    if (tried <= 0) {
      for (int i = 0; i < count; ++i) modes_[i] = start[i];
    }
  }
  if (tried <= 0) {
    tried = core::solveByModes(small_A_, modes_.data(), count, speed, max_modes);
    work += static_cast<std::size_t>(std::abs(tried));
  }
  if (tried <= 0) return false;
  modes_warm_ = true;  // the next round (mu_d for contacts found sliding) starts here
  completePyramids();  // the pyramid's directions, for the residual check
  for (int i = 0; i < count; ++i) {
    LcpContact& c = contacts_[i];
    const ModeContact& m = modes_[i];
    c.P_n = m.P.x();
    c.beta.setZero();
    c.P_t.setZero();
    if (!c.frictional) continue;
    if (m.mode == ContactMode::kSliding) {
      c.beta(m.direction) = c.mu() * c.P_n;
    } else if (m.mode == ContactMode::kSlidingFacet) {
      // The facet's two parts, >= 0 and summing to mu P_n exactly (round-off aside).
      double beta_k, beta_next;
      facetParts(m.P.tail<2>(), m.direction, beta_k, beta_next);
      beta_k = std::clamp(beta_k, 0.0, c.mu() * c.P_n);
      c.beta(m.direction) = beta_k;
      c.beta((m.direction + 1) % kD) = c.mu() * c.P_n - beta_k;
    } else if (m.mode == ContactMode::kSticking) {
      int k;
      Eigen::Vector2d beta;
      pyramidGauge(m.P.tail<2>(), k, beta);
      c.beta(k) = std::max(beta(0), 0.0);
      c.beta((k + 1) % kD) = std::max(beta(1), 0.0);
    }
    c.P_t = c.directions.rightCols<kD>() * c.beta;
  }
  velocityChanges();
  // The frame matrix's answer, checked in body space: every active contact at its target, no
  // contact approaching beyond it (an ill-conditioned island may lose digits in the frame solve;
  // Lemke decides then).
  const double tolerance = 1e-10 * speed;
  for (int i = 0; i < count; ++i) {
    const LcpContact& c = contacts_[i];
    const double u_n = c.u.dot(c.entry->normal) + velocityChangeAt(c).dot(c.entry->normal);
    const bool active = modes_[i].mode != ContactMode::kSeparating;
    if (u_n < c.target_u_n - tolerance || (active && u_n > c.target_u_n + tolerance)) {
      for (LcpContact& reset : contacts_)
        reset.P_n = 0.0, reset.beta.setZero(), reset.P_t.setZero();
      return false;
    }
  }
  return true;
}

void IslandLcp::completePyramids() {
  if (pyramids_complete_) return;
  pyramids_complete_ = true;
  // d_k = cos(2 pi k / D) t1 + sin(2 pi k / D) t2.
  const std::array<Eigen::Vector2d, kD>& angles = pyramidAngles();
  for (LcpContact& c : contacts_) {
    if (!c.frictional) continue;
    const Eigen::Vector3d t1 = c.directions.col(1), t2 = c.directions.col(1 + kD / 4);
    for (int k = 0; k < kD; ++k) {
      if (k % (kD / 4) != 0) c.directions.col(1 + k) = angles[k].x() * t1 + angles[k].y() * t2;
    }
    c.directions.col(1 + kD / 2) = -t1;
    c.directions.col(1 + 3 * kD / 4) = -t2;
  }
}

void IslandLcp::assembleDelassus() {
  M_.setZero(unknowns_, unknowns_);
  // D_i^T W_ij D_j: of fixed size (n and the pyramid's directions) for frictional contacts, so
  // that the products are unrolled instead of general matrix products with their packing.
  using Directions = Eigen::Matrix<double, 3, kD + 1>;
  const auto block = [this](const LcpContact& ci, const LcpContact& cj,
                            const Eigen::Matrix3d& W_ij) {
    if (ci.columns == kD + 1 && cj.columns == kD + 1) {
      const Directions WD = W_ij * cj.directions;
      M_.block<kD + 1, kD + 1>(ci.offset, cj.offset).noalias() = ci.directions.transpose() * WD;
    } else {
      const auto Di = ci.directions.leftCols(ci.columns);
      const auto Dj = cj.directions.leftCols(cj.columns);
      M_.block(ci.offset, cj.offset, ci.columns, cj.columns).noalias() = Di.transpose() * W_ij * Dj;
    }
  };
  for (const LcpContact& c : contacts_) block(c, c, c.entry->delassus);
  for (const auto& [i, j] : problem_.couplings()) {
    const LcpContact& ci = contacts_[i];
    const LcpContact& cj = contacts_[j];
    block(ci, cj, problem_.delassusBlock(i, j));
    M_.block(cj.offset, ci.offset, cj.columns, ci.columns) =
        M_.block(ci.offset, cj.offset, ci.columns, cj.columns).transpose();
  }
}

void IslandLcp::assembleFrictionRows() {
  q_.setZero(unknowns_);
  for (const LcpContact& c : contacts_) {
    q_.segment(c.offset, c.columns) = c.directions.leftCols(c.columns).transpose() * c.u;
    q_(c.offset) -= c.target_u_n;
    if (!c.frictional) continue;
    M_.block(c.offset + 1, c.lambda(), kD, 1).setOnes();
    M_.block(c.lambda(), c.offset + 1, 1, kD).setConstant(-1.0);
    M_(c.lambda(), c.offset) = c.mu();
  }
}

bool IslandLcp::solveAllSticking() {
  if (small_) {
    // Small islands: the frame Delassus matrix (needed by the modes anyway), solved on the stack
    // (least-norm if singular: the same impulses as the body-space solve or the complete
    // orthogonal decomposition below).
    assembleSmallFrames();
    const Index n = frame_unknowns_;
    Index first[kModeSolverMaxUnknowns];
    ModeVector rhs(n), P;
    for (std::size_t i = 0; i < contacts_.size(); ++i) {
      const ModeContact& m = modes_[i];
      first[i] = m.first;
      const Index k = m.frictional ? 3 : 1;
      rhs.segment(m.first, k) = -m.u.head(k);  // to u' = 0 ...
      rhs(m.first) += m.target;                // ... but u'_n = -e u_n
    }
    // More unknowns than the bodies' freedoms (redundant contacts, as under a box): the 6 x 6
    // body-space solve is cheaper than the frame matrix's (which is then assembled only if the
    // modes need it); otherwise the frame matrix.
    const bool in_body_space =
        n > problem_.unknowns() && problem_.bodies().size() == 1 &&
        stickingInBodySpace<6, kModeSolverMaxUnknowns>(contacts_, problem_.bodies(), first, rhs, P,
                                                       normal_miss_.data());
    if (!in_body_space) {
      assembleSmall();
      ModeMatrix K = small_A_;
      ModeVector b = rhs;
      solveLeastNorm(K, b, P);
    }
    // Warm start of the modes, should these impulses not be the answer: a contact they pull
    // separates, one outside its static cone slides along the pyramid direction nearest them.
    for (std::size_t i = 0; i < contacts_.size(); ++i) {
      ModeContact& m = modes_[i];
      const double P_n = P(m.first);
      m.mode = ContactMode::kSticking;
      if (!(P_n >= 0.0)) {
        m.mode = ContactMode::kSeparating;
      } else if (m.frictional &&
                 P.segment<2>(m.first + 1).norm() > contacts_[i].entry->static_friction * P_n) {
        const double angle = std::atan2(P(m.first + 2), P(m.first + 1));
        m.mode = ContactMode::kSliding;
        m.direction = (static_cast<int>(std::lround(angle * kD / (2.0 * kPi))) + kD) % kD;
      }
    }
    modes_warm_ = P.allFinite();
    inconsistent_ = false;
    if (in_body_space) {
      const double tolerance = 1e-10 * std::max(u_reference_, rhs.cwiseAbs().maxCoeff());
      for (std::size_t i = 0; i < contacts_.size(); ++i) {
        if (normal_miss_[i] > tolerance) missed_targets_ = true;
      }
    }
    if (acceptSticking(P.data(), first, rhs.data(), rhs.cwiseAbs().maxCoeff())) return true;
    // Admissible but short of the targets in body space: an ill-conditioned Delassus matrix
    // (mass ratios of 1e12) the frame solve lost digits on; the general path below decides.
    // (Not when the body-space solve above gave them: the general path would repeat it.)
    if (!inconsistent_ || in_body_space) return false;
  }
  // Unknowns: P_n per contact, and (t1, t2) components for frictional ones.
  std::vector<Index>& first = workspace_.first;
  first.resize(contacts_.size());
  Index unknowns = 0;
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    first[i] = unknowns;
    unknowns += contacts_[i].frictional ? 3 : 1;
  }
  Eigen::VectorXd& rhs = workspace_.rhs;
  rhs.resize(unknowns);
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    const LcpContact& c = contacts_[i];
    const Eigen::Vector3d change = stickingDirections(c).transpose() * -c.u;  // to u' = 0 ...
    rhs.segment(first[i], c.frictional ? 3 : 1) = change.head(c.frictional ? 3 : 1);
    rhs(first[i]) += c.target_u_n;  // ... but u'_n = -e u_n
  }
  // More unknowns than the bodies' degrees of freedom (redundant contacts, as under a box): solved
  // in body space; otherwise, or if a body keeps a free direction, with the Delassus matrix.
  Eigen::VectorXd& P = workspace_.P;
  const bool in_body_space =
      unknowns > problem_.unknowns() &&
      (problem_.bodies().size() == 1 ? stickingInBodySpace<6, Eigen::Dynamic>(
                                           contacts_, problem_.bodies(), first.data(), rhs, P)
                                     : stickingInBodySpace<Eigen::Dynamic, Eigen::Dynamic>(
                                           contacts_, problem_.bodies(), first.data(), rhs, P));
  if (!in_body_space && !stickingTridiagonal(rhs, P)) P = stickingByDelassus(first, rhs);
  return acceptSticking(P.data(), first.data(), rhs.data(), rhs.cwiseAbs().maxCoeff());
}

bool IslandLcp::acceptSticking(const double* P, const Index* first, const double* rhs,
                               double rhs_scale) {
  for (Index i = 0; i < frame_unknowns_; ++i) {
    if (!std::isfinite(P[i])) return false;
  }
  // Admissible: compressive and inside the static cones.
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    const LcpContact& c = contacts_[i];
    const double P_n = P[first[i]];
    if (!(P_n >= 0.0)) return false;
    if (c.frictional &&
        std::hypot(P[first[i] + 1], P[first[i] + 2]) > c.entry->static_friction * P_n)
      return false;
  }
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    LcpContact& c = contacts_[i];
    c.P_n = P[first[i]];
    c.beta.setZero();
    c.P_t = c.frictional ? Eigen::Vector3d(stickingDirections(c).rightCols<2>() *
                                           Eigen::Vector2d(P[first[i] + 1], P[first[i] + 2]))
                         : Eigen::Vector3d::Zero();
  }
  velocityChanges();
  // Consistent: the velocity changes these impulses make reach every target (A P = rhs), to
  // round-off of the island's scale. Otherwise the targets are not reachable together.
  const double tolerance = 1e-10 * std::max(u_reference_, rhs_scale);
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    const LcpContact& c = contacts_[i];
    const Index k = c.frictional ? 3 : 1;
    const Eigen::Vector3d change = stickingDirections(c).transpose() * velocityChangeAt(c);
    for (Index j = 0; j < k; ++j) {
      if (std::abs(change(j) - rhs[first[i] + j]) > tolerance) {
        inconsistent_ = true;
        for (LcpContact& reset : contacts_) reset.P_n = 0.0, reset.P_t.setZero();
        return false;
      }
    }
  }
  return true;
}

double IslandLcp::normalCoupling(int i, int j) const {
  const ProblemContact& ci = *contacts_[i].entry;
  const ProblemContact& cj = *contacts_[j].entry;
  const int local_i[2] = {ci.local_a, ci.local_b};
  const int local_j[2] = {cj.local_a, cj.local_b};
  double sum = 0.0;
  for (int si = 0; si < 2; ++si) {
    if (local_i[si] < 0) continue;
    for (int sj = 0; sj < 2; ++sj) {
      if (local_j[sj] != local_i[si]) continue;
      const ProblemBody& body = problem_.bodies()[local_i[si]];
      if (!body.rigid()) return ci.normal.dot(problem_.delassusBlock(i, j) * cj.normal);
      // The shared body's part of W_ij, +-(m^-1 I - [r_i]x I^-1 [r_j]x), between the normals
      // (+ when both contacts push it from the same side, body a receiving -P and b +P).
      const Eigen::Vector3d torque_i = contacts_[i].r(si).cross(ci.normal);
      const Eigen::Vector3d torque_j = contacts_[j].r(sj).cross(cj.normal);
      sum += (si == sj ? 1.0 : -1.0) * (body.inverse_mass * ci.normal.dot(cj.normal) +
                                        torque_i.dot(body.inverse_inertia * torque_j));
    }
  }
  return sum;
}

bool IslandLcp::stickingTridiagonal(const Eigen::VectorXd& rhs, Eigen::VectorXd& P) {
  // Frictionless contacts each coupled only to the next in the problem's order (a row of bodies,
  // each touching its neighbours): A is tridiagonal, A_ii = n_i^T W_ii n_i, A_i,i+1 = n_i^T
  // W_i,i+1 n_(i+1), and its LDL^T without pivoting (A positive definite) costs O(n).
  const Index n = static_cast<Index>(contacts_.size());
  if (n < 3 || rhs.size() != n) return false;
  for (const LcpContact& c : contacts_) {
    if (c.frictional) return false;
  }
  const std::vector<std::pair<int, int>>& couplings = problem_.couplings();
  for (const auto& [i, j] : couplings) {
    if (j != i + 1) return false;
  }
  Eigen::VectorXd& d = workspace_.d;
  Eigen::VectorXd& l = workspace_.l;  // l(i): L_i,i-1
  d.resize(n);
  l.setZero(n);
  for (Index i = 0; i < n; ++i) {
    const Eigen::Vector3d& normal = contacts_[i].entry->normal;
    d(i) = normal.dot(contacts_[i].entry->delassus * normal);
  }
  for (const auto& [i, j] : couplings) l(j) = normalCoupling(i, j);  // A_ij for now
  for (Index i = 1; i < n; ++i) {
    const double a = l(i);
    l(i) = a / d(i - 1);
    d(i) -= l(i) * a;
  }
  if (!(d.minCoeff() > kRegularPivot * d.maxCoeff())) return false;  // the general path decides
  P = rhs;
  for (Index i = 1; i < n; ++i) P(i) -= l(i) * P(i - 1);
  P.array() /= d.array();
  for (Index i = n - 2; i >= 0; --i) P(i) -= l(i + 1) * P(i + 1);
  return true;
}

Eigen::VectorXd IslandLcp::stickingByDelassus(const std::vector<Index>& first,
                                              const Eigen::VectorXd& rhs) const {
  // A = S^T W S over the sticking unknowns (S_i = n_i, or [n_i t1_i t2_i]), from the problem's
  // Delassus blocks: the contact's own and those of the contacts it shares a body with.
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(rhs.size(), rhs.size());
  const auto count = [](const LcpContact& c) -> Index { return c.frictional ? 3 : 1; };
  for (std::size_t i = 0; i < contacts_.size(); ++i) {
    const LcpContact& c = contacts_[i];
    const Eigen::Matrix3d S = stickingDirections(c);
    const Eigen::Matrix3d block = S.transpose() * c.entry->delassus * S;
    A.block(first[i], first[i], count(c), count(c)) = block.topLeftCorner(count(c), count(c));
  }
  for (const auto& [i, j] : problem_.couplings()) {
    const LcpContact& ci = contacts_[i];
    const LcpContact& cj = contacts_[j];
    const Eigen::Matrix3d block =
        stickingDirections(ci).transpose() * problem_.delassusBlock(i, j) * stickingDirections(cj);
    A.block(first[i], first[j], count(ci), count(cj)) = block.topLeftCorner(count(ci), count(cj));
    A.block(first[j], first[i], count(cj), count(ci)) =
        block.topLeftCorner(count(ci), count(cj)).transpose();
  }
  // Independent contacts: A is positive definite and LDL^T solves it. Redundant ones, or bodies
  // with few freedoms (a singular A): the least-norm solution, by a complete orthogonal
  // decomposition.
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(A);
  if (ldlt.info() == Eigen::Success && ldlt.isPositive()) {
    const Eigen::VectorXd d = ldlt.vectorD();
    if (d.minCoeff() > kRegularPivot * d.maxCoeff()) return ldlt.solve(rhs);
  }
  return A.completeOrthogonalDecomposition().solve(rhs);
}

bool IslandLcp::solve(std::size_t& work, const Deadline& deadline) {
  if (small_ && solveByModes(work)) return true;
  if (!assembled_) {  // only when the all-sticking guess did not answer
    completePyramids();
    assembleDelassus();
    assembleFrictionRows();
    assembled_ = true;
  }
  LcpOptions lcp_options;
  lcp_options.deadline = deadline;
  const LcpResult lcp = solveLcp(M_, q_, lcp_options);
  work += lcp.pivots;
  if (lcp.status != LcpStatus::kSolved) return false;
  for (LcpContact& c : contacts_) {
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
  velocity_changes_.setZero();
  for (const LcpContact& c : contacts_) {
    problem_.addImpulse(c.index, c.impulse(), velocity_changes_);
  }
}

bool IslandLcp::switchSlidingToDynamic() {
  bool changed = false;
  for (LcpContact& c : contacts_) {
    const ProblemContact& entry = *c.entry;
    if (!c.frictional || c.dynamic || entry.dynamic_friction == entry.static_friction) continue;
    const Eigen::Vector3d u = c.u + velocityChangeAt(c);
    const Eigen::Vector3d u_t = u - u.dot(entry.normal) * entry.normal;
    if (u_t.norm() > kSlipTolerance * u_reference_) {
      c.dynamic = true;
      if (assembled_) M_(c.lambda(), c.offset) = c.mu();
      changed = true;
    }
  }
  return changed;
}

}  // namespace

double pyramidFactor() {
  return std::cos(kPi / kD);
}

namespace {

// Complementarity violation of contact c at post-impact relative velocity u [m/s]:
// |min(velocity, k_nn impulse)| is 0 iff both are >= 0 and one of them is 0.
double violation(const LcpContact& c, const Eigen::Vector3d& u, bool all_sticking) {
  const ProblemContact& entry = *c.entry;
  const double u_n = u.dot(entry.normal);
  const double k_nn = entry.normalDelassus();
  const auto pair = [k_nn](double velocity, double impulse) {
    return std::abs(std::min(velocity, k_nn * impulse));
  };
  double worst = pair(u_n - c.target_u_n, c.P_n);
  if (c.frictional && all_sticking) {
    // No pyramid (beta = 0): its terms are min(lambda, k_nn mu P_n) <= min(|u_t|, k_nn mu P_n).
    worst = std::max(worst, pair((u - u_n * entry.normal).norm(), c.mu() * c.P_n));
  } else if (c.frictional) {
    const Eigen::Matrix<double, kD, 1> slip =
        c.directions.rightCols<kD>().transpose() * (u - u_n * entry.normal);
    const double lambda = std::max(0.0, -slip.minCoeff());
    for (int k = 0; k < kD; ++k) worst = std::max(worst, pair(lambda + slip(k), c.beta(k)));
    worst = std::max(worst, pair(lambda, c.mu() * c.P_n - c.beta.sum()));
  }
  return worst;
}

}  // namespace

SolveReport solveExact(ContactProblem& problem, const SolverOptions& options,
                       std::vector<ContactImpulse>& impulses) {
  SolveReport report;
  report.method = SolvedBy::kExact;
  thread_local ExactWorkspace workspace;  // no allocation per solve
  IslandLcp lcp(problem, workspace);
  const bool all_sticking = lcp.solveAllSticking();  // checked against its targets already
  bool solved = all_sticking;
  while (!solved && lcp.solve(report.iterations, options.deadline)) {
    if (!lcp.switchSlidingToDynamic()) {
      solved = true;
      break;
    }
  }
  const auto relative = [&lcp](double worst) {
    return lcp.speed() > 0.0 ? worst / lcp.speed() : worst;
  };

  // Trust the answer, not the pivots: an LCP solution accepted against the scale of huge,
  // cancelling impulses can still leave contacts approaching. It is refused here, from the
  // velocities it would give, and nothing is applied.
  std::vector<LcpContact>& contacts = lcp.contacts();
  if (solved && !all_sticking) {
    double worst = 0.0;
    for (const LcpContact& c : contacts) {
      worst = std::max(worst, violation(c, c.u + lcp.velocityChangeAt(c), false));
    }
    solved = relative(worst) <= kAcceptedResidual;
  }

  // Apply (nothing if unsolved), report, and measure the residual from the final velocities.
  for (LcpContact& c : contacts) {
    if (!solved) c.P_n = 0.0, c.beta.setZero(), c.P_t.setZero();
    problem.applyImpulse(c.index, c.impulse());
  }
  impulses.resize(problem.size());
  double worst = 0.0;
  for (std::size_t i = 0; i < contacts.size(); ++i) {
    const LcpContact& c = contacts[i];
    const Eigen::Vector3d& n = c.entry->normal;
    const Eigen::Vector3d u = problem.relativeMotion(i);
    worst = std::max(worst, violation(c, u, all_sticking));
    const Eigen::Vector3d u_t = u - u.dot(n) * n;
    ContactImpulse& out = impulses[i];
    out.normal_impulse = c.P_n;
    out.friction_impulse = c.P_t;
    out.sticking = c.frictional && c.P_n > 0.0 && u_t.norm() <= kSlipTolerance * lcp.speed();
  }
  report.residual = relative(worst);
  report.converged = solved;
  return report;
}

SolveReport solveExact(std::vector<RigidBody>& bodies, const std::vector<ContactPoint>& contacts,
                       const std::vector<int>& island, const SolverOptions& options,
                       std::vector<ContactImpulse>& impulses) {
  return solveRigidIsland(bodies, contacts, island, impulses,
                          [&](ContactProblem& problem, std::vector<ContactImpulse>& solved) {
                            return solveExact(problem, options, solved);
                          });
}

}  // namespace collision_response::core
