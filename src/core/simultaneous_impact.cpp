#include "collision_response/core/simultaneous_impact.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>

#include "collision_response/core/exact_solver.h"
#include "collision_response/core/impact_derivatives.h"
#include "collision_response/core/impulse_space_integrator.h"
#include "collision_response/core/island_solver.h"
#include "collision_response/core/iterative_solver.h"
#include "collision_response/core/lcp.h"
#include "dual_number.h"

namespace collision_response::core {
namespace {

enum class Phase { kIdle, kCompression, kRestitution };

// Islands of at most this many contacts (the automatic choice's, island_solver.h) are integrated
// with matrices of bounded size, in the scheme's object; larger ones on the heap.
constexpr int kBoundedContacts = static_cast<int>(kSimultaneousMaxContacts);

// Steps of the fictitious time per 1 / sqrt(k max_i n^T W_ii n): about 50 per compression.
constexpr double kStepsPerUnit = 32.0;
// Steps (accepted pieces, events included) before the plastic fallback.
constexpr std::size_t kStepBudget = 20000;
// A sliding contact whose slip direction turns is stepped so that it turns by at most ~this.
constexpr double kMaxTurn = 0.05;
// A slip below this times the largest pre-impact speed is a stop.
constexpr double kStopped = 1e-9;
// kVelocityConsistent: a slip minimum below this times the largest pre-impact speed is a stop
// (the static cone then decides), and a slip resumed after a stop keeps the direction it resumed
// in until it exceeds this (a 3D slip near 0 would otherwise turn by large angles per step).
constexpr double kSmallSlip = 1e-6;

// The scheme runs on T = double (the solve) or on a dual number (its derivatives, Dual<N>: the
// same operations and branches, with gradients along N seeded inputs).
template <typename T>
using Vector3 = Eigen::Matrix<T, 3, 1>;

template <typename T>
struct State {
  Phase phase = Phase::kIdle;
  bool sticking = false;
  bool resumed = false;  // kVelocityConsistent: slip resumed after a stop, direction held
  T delta = 0.0;         // compression of the contact's linear spring [m s / s = velocity x time]
  T delta_max = 0.0;     // at the end of compression
  T start_normal = 0.0;  // P_n at the start of the current cycle [N s]
  T compression_impulse = 0.0;           // p_c of the current cycle
  T compression_work = 0.0;              // W_c of the current cycle (<= 0)
  T work = 0.0;                          // integral of u_n dP_n in the current phase
  Vector3<T> slip = Vector3<T>::Zero();  // slip direction used while |u_t| is ~0
  Vector3<T> impulse = Vector3<T>::Zero();
};

// max and min as std::max and std::min choose (the gradient of the value chosen).
template <typename T>
T maxOf(const T& a, const T& b) {
  return a < b ? b : a;
}
template <typename T>
T minOf(const T& a, const T& b) {
  return b < a ? b : a;
}

// The seeded inputs of a dual run: each gradient entry is one contact's relative velocity
// component (world), its e or its mu_d (mu_s only decides branches: its column is 0).
struct Seed {
  enum Kind { kVelocity, kRestitution, kDynamicFriction } kind = kVelocity;
  std::size_t contact = 0;
  int component = 0;  // kVelocity: x, y, z
};

// The scheme's matrices, of at most kMax contacts (Eigen::Dynamic: unbounded, on the heap; a
// bound keeps them in the object, with no allocation per step).
template <int kMax, typename T = double>
struct Storage {
  static constexpr int kTimes(int k) { return kMax == Eigen::Dynamic ? Eigen::Dynamic : k * kMax; }
  // W and the sticking block: constants of the problem, double.
  using Stacked = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kTimes(3), kTimes(3)>;
  using Sticking = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kTimes(2), kTimes(2)>;
  using StackedVector = Eigen::Matrix<T, Eigen::Dynamic, 1, 0, kTimes(3), 1>;
  using PerContact = Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic, 0, kTimes(3), kTimes(1)>;
  using StickingMap = Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic, 0, kTimes(2), kTimes(1)>;
  using StickingVector = Eigen::Matrix<T, Eigen::Dynamic, 1, 0, kTimes(2), 1>;
  using Square = Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic, 0, kTimes(1), kTimes(1)>;
  using Vector = Eigen::Matrix<T, Eigen::Dynamic, 1, 0, kTimes(1), 1>;
};

// x = A^+ b through a decomposition of a constant double A: for a dual b, the values and every
// gradient direction through the same decomposition (the solve is linear in b).
template <typename Cod, typename Rhs, typename Out>
void solveThrough(const Cod& cod, const Rhs& b, Out& x) {
  using T = typename Rhs::Scalar;
  if constexpr (std::is_same_v<T, double>) {
    x = cod.solve(b);
  } else {
    constexpr int N = static_cast<int>(T::Gradient::RowsAtCompileTime);
    const Eigen::Index rows = b.rows(), cols = b.cols();
    // The values through the very call the double computation makes, the gradients stacked.
    using Values = Eigen::Matrix<double, Rhs::RowsAtCompileTime, Rhs::ColsAtCompileTime, 0,
                                 Rhs::MaxRowsAtCompileTime, Rhs::MaxColsAtCompileTime>;
    Values values(rows, cols);
    Eigen::MatrixXd stacked(rows, cols * N);
    for (Eigen::Index c = 0; c < cols; ++c) {
      for (Eigen::Index r = 0; r < rows; ++r) {
        values(r, c) = b(r, c).v;
        for (int k = 0; k < N; ++k) stacked(r, cols * k + c) = b(r, c).d[k];
      }
    }
    const Values solved_values = cod.solve(values);
    const Eigen::MatrixXd solved = cod.solve(stacked);
    x.resize(solved.rows(), cols);
    for (Eigen::Index c = 0; c < cols; ++c) {
      for (Eigen::Index r = 0; r < solved.rows(); ++r) {
        x(r, c).v = solved_values(r, c);
        for (int k = 0; k < N; ++k) x(r, c).d[k] = solved(r, cols * k + c);
      }
    }
  }
}

template <int kMax, typename T = double>
class Simultaneous {
  static constexpr bool kDual = !std::is_same_v<T, double>;
  using Stacked = typename Storage<kMax, T>::Stacked;
  using StackedVector = typename Storage<kMax, T>::StackedVector;
  using PerContact = typename Storage<kMax, T>::PerContact;
  using Sticking = typename Storage<kMax, T>::Sticking;
  using StickingMap = typename Storage<kMax, T>::StickingMap;
  using StickingVector = typename Storage<kMax, T>::StickingVector;
  using Square = typename Storage<kMax, T>::Square;
  using Vector = typename Storage<kMax, T>::Vector;
  using SquareValues = typename Storage<kMax>::Square;
  using VectorValues = typename Storage<kMax>::Vector;

 public:
  // `seeds` (dual runs only, one per gradient entry): the inputs the gradients are taken along.
  Simultaneous(const ContactProblem& problem, ImpactLaw law, SimultaneousSharing sharing,
               const Deadline& deadline, const std::vector<Seed>& seeds = {})
      : problem_(problem),
        law_(law),
        sharing_(sharing),
        deadline_(deadline),
        m_(problem.size()),
        state_(m_),
        restitution_(m_),
        dynamic_friction_(m_) {
    const Eigen::Index n3 = 3 * static_cast<Eigen::Index>(m_);
    w_.setZero(n3, n3);
    u_.resize(n3);
    for (std::size_t i = 0; i < m_; ++i) {
      const ProblemContact& c = problem.contact(i);
      w_.template block<3, 3>(3 * i, 3 * i) = c.delassus;
      const Eigen::Vector3d u = problem.relativeMotion(i);
      for (int k = 0; k < 3; ++k) u_(3 * static_cast<Eigen::Index>(i) + k) = u(k);
      restitution_[i] = c.restitution;
      dynamic_friction_[i] = c.dynamic_friction;
      scale_ = std::max(scale_, u.norm());
      lambda_ = std::max(lambda_, c.normalDelassus());
    }
    if constexpr (kDual) {
      for (std::size_t k = 0; k < seeds.size(); ++k) {
        const Seed& seed = seeds[k];
        T& input = seed.kind == Seed::kVelocity
                       ? u_(3 * static_cast<Eigen::Index>(seed.contact) + seed.component)
                   : seed.kind == Seed::kRestitution ? restitution_[seed.contact]
                                                     : dynamic_friction_[seed.contact];
        input.d[static_cast<Eigen::Index>(k)] = 1.0;
      }
      switch_.assign(m_, std::string());
    }
    for (const auto& [i, j] : problem.couplings()) {
      const Eigen::Matrix3d block = problem.delassusBlock(i, j);
      w_.template block<3, 3>(3 * i, 3 * j) = block;
      w_.template block<3, 3>(3 * j, 3 * i) = block.transpose();
    }
    // Spring rates are forces in a fictitious time; consistent rates are the impulses still
    // needed, so that one unit of fictitious time ends every phase that stays linear.
    h_ = lambda_ <= 0.0                             ? 0.0
         : sharing_ == SimultaneousSharing::kSpring ? 1.0 / (kStepsPerUnit * std::sqrt(lambda_))
                                                    : 1.0;
    stop_ = sharing_ == SimultaneousSharing::kSpring ? kStopped : kSmallSlip;
    rates_.resize(n3);
    du_.resize(n3);
    base_.resize(n3);
  }

  // Runs to the end; false if the step budget ran out.
  bool run() {
    if (h_ <= 0.0 || scale_ <= 0.0) return true;
    const double approach = 1e-12 * scale_;
    while (steps_ < kStepBudget) {
      // Out of time counts as out of steps: the caller falls back (or the deadline throws there).
      if (steps_ % 16 == 15 && deadline_.expired()) return false;
      bool any = false;
      for (std::size_t i = 0; i < m_; ++i) {
        State<T>& s = state_[i];
        const T un = normalVelocity(i);
        if (s.phase == Phase::kIdle && un < -approach) startCycle(i);
        // Compression over (no longer approaching beyond round-off): its restitution starts.
        if (s.phase == Phase::kCompression && un >= -approach &&
            (s.delta > 0.0 || sharing_ == SimultaneousSharing::kVelocityConsistent)) {
          endCompression(i);
        }
        // Velocity-consistent, Stronge: past its Poisson impulse, a contact that does not separate
        // cannot release the rest of its work (it is held, e.g. wedged): its restitution ends.
        if (sharing_ == SimultaneousSharing::kVelocityConsistent && law_ == ImpactLaw::kStronge &&
            s.phase == Phase::kRestitution && std::abs(valueOf(un)) <= approach &&
            poissonRemaining(i) <= 0.0) {
          s.phase = Phase::kIdle;
          s.sticking = false;
          s.resumed = false;
          ++events_;
        }
        // A sliding contact whose slip is gone stops; the cone decides whether it stays stuck.
        if (s.phase != Phase::kIdle && !problem_.contact(i).frictionless() && !s.resumed &&
            tangentialVelocity(i).norm() <= stop_ * scale_) {
          s.sticking = true;
        }
        any = any || s.phase != Phase::kIdle;
      }
      if (!any) return true;
      if (!step()) return false;  // no consistent rates: jammed
      ++steps_;
    }
    return false;
  }

  std::size_t steps() const { return steps_; }
  std::size_t events() const { return events_; }
  const Vector3<T>& impulse(std::size_t i) const { return state_[i].impulse; }
  // Dual runs: per contact, the switches met on the way (empty: none), for ContactDerivativeMode.
  const std::string& switchDetail(std::size_t i) const { return switch_[i]; }
  // Dual runs: the rates met a degenerate complementarity problem (the gradients are not taken).
  bool degenerate() const { return degenerate_; }

 private:
  Eigen::Matrix<double, 3, 2> tangents(std::size_t i) const {
    Eigen::Matrix<double, 3, 2> t;
    t << problem_.contact(i).tangent1, problem_.contact(i).tangent2;
    return t;
  }
  T normalVelocity(std::size_t i) const {
    return problem_.contact(i).normal.dot(u_.template segment<3>(3 * i));
  }
  Vector3<T> tangentialVelocity(std::size_t i) const {
    const Eigen::Vector3d& n = problem_.contact(i).normal;
    const Vector3<T> u = u_.template segment<3>(3 * i);
    return u - n.dot(u) * n;
  }
  // Dual runs: notes a switch at contact i (once per kind).
  void noteSwitch(std::size_t i, const char* detail) {
    if constexpr (kDual) {
      if (switch_[i].find(detail) != std::string::npos) return;
      if (!switch_[i].empty()) switch_[i] += "; ";
      switch_[i] += detail;
    }
  }

  void startCycle(std::size_t i) {
    State<T>& s = state_[i];
    s.phase = Phase::kCompression;
    s.delta = 0.0;
    s.work = 0.0;
    s.start_normal = s.impulse.dot(problem_.contact(i).normal);
    ++events_;
  }

  void endCompression(std::size_t i) {
    State<T>& s = state_[i];
    const ProblemContact& c = problem_.contact(i);
    s.compression_impulse = s.impulse.dot(c.normal) - s.start_normal;
    s.compression_work = s.work;
    s.delta_max = s.delta;
    s.work = 0.0;
    s.phase =
        c.restitution > 0.0 && s.compression_impulse > 0.0 ? Phase::kRestitution : Phase::kIdle;
    ++events_;
  }

  // Normal impulse rate of an active contact over the next step: its spring force at mid-step.
  T normalRate(std::size_t i) const {
    const State<T>& s = state_[i];
    const T mid = s.delta - 0.5 * h_ * normalVelocity(i);
    if (s.phase == Phase::kCompression) return maxOf<T>(mid, 0.0);
    const T& e = restitution_[i];
    const T force = s.delta_max - (s.delta_max - mid) / (e * e);
    if (force > 1e-3 * s.delta_max) return force;
    // The spring is (nearly) unloaded but the contact's own end condition (Poisson impulse,
    // Stronge work), which decides its end, is not met yet (a discretization residue): the rate
    // that meets it within about one step, at most the peak force.
    const ProblemContact& c = problem_.contact(i);
    T remaining = 0.0;
    if (law_ == ImpactLaw::kPoisson) {
      remaining = s.start_normal + (1.0 + e) * s.compression_impulse - s.impulse.dot(c.normal);
    } else {
      const T un = normalVelocity(i);
      remaining = un > 0.0 ? T((-e * e * s.compression_work - s.work) / un) : T(s.delta_max * h_);
    }
    return maxOf<T>(1e-3 * s.delta_max, minOf<T>(s.delta_max, remaining / h_));
  }

  // The rates of every contact's impulse per unit fictitious time (k = 1): normal spring force,
  // friction -mu_d s while sliding, sticking friction (least norm) while it lies in the mu_s cone.
  void computeSpringRates() {
    rates_.setZero();
    normal_rate_.assign(m_, 0.0);
    for (std::size_t i = 0; i < m_; ++i) {
      const State<T>& s = state_[i];
      if (s.phase == Phase::kIdle) continue;
      const ProblemContact& c = problem_.contact(i);
      normal_rate_[i] = normalRate(i);
      rates_.template segment<3>(3 * i) = normal_rate_[i] * c.normal;
    }
    for (std::size_t i = 0; i < m_; ++i) {
      State<T>& s = state_[i];
      if (s.phase == Phase::kIdle || problem_.contact(i).frictionless() || s.sticking) continue;
      const Vector3<T> ut = tangentialVelocity(i);
      if (ut.norm() > 1e-14 * scale_) s.slip = ut.normalized();
      rates_.template segment<3>(3 * i) -= dynamic_friction_[i] * normal_rate_[i] * s.slip;
    }
    // Sticking contacts: tangential rates holding u_t = 0, in the static cone, else slip resumes.
    for (;;) {
      stick_.clear();
      for (std::size_t i = 0; i < m_; ++i) {
        if (state_[i].phase != Phase::kIdle && state_[i].sticking) stick_.push_back(i);
      }
      if (stick_.empty()) return;
      const Eigen::Index k = 2 * static_cast<Eigen::Index>(stick_.size());
      const Eigen::CompleteOrthogonalDecomposition<Sticking>& cod = factorization();
      b_.resize(k);
      base_.noalias() = w_.lazyProduct(rates_);
      for (std::size_t p = 0; p < stick_.size(); ++p) {
        b_.template segment<2>(2 * p) =
            -tangents(stick_[p]).transpose() * base_.template segment<3>(3 * stick_[p]);
      }
      solveThrough(cod, b_, x_);
      const StickingVector& x = x_;
      bool all_in = true;
      for (std::size_t p = 0; p < stick_.size(); ++p) {
        const std::size_t i = stick_[p];
        const ProblemContact& c = problem_.contact(i);
        const Vector3<T> f = x(2 * p) * c.tangent1 + x(2 * p + 1) * c.tangent2;
        if (f.norm() > c.static_friction * normal_rate_[i] * (1.0 + 1e-9) + 1e-300) {
          // Slip resumes against the friction it would need.
          state_[i].sticking = false;
          state_[i].slip = -f.normalized();
          rates_.template segment<3>(3 * i) -=
              dynamic_friction_[i] * normal_rate_[i] * state_[i].slip;
          all_in = false;
          ++events_;
        }
      }
      if (all_in) {
        for (std::size_t p = 0; p < stick_.size(); ++p) {
          const ProblemContact& c = problem_.contact(stick_[p]);
          rates_.template segment<3>(3 * stick_[p]) +=
              x(2 * p) * c.tangent1 + x(2 * p + 1) * c.tangent2;
        }
        return;
      }
    }
  }

  // The least-norm decomposition of the sticking block of W (tangential rows and columns of the
  // stuck contacts), kept per stuck set (a set recurs as contacts stop and resume).
  const Eigen::CompleteOrthogonalDecomposition<Sticking>& factorization() {
    for (const auto& [set, cod] : factorizations_) {
      if (set == stick_) return cod;
    }
    const Eigen::Index k = 2 * static_cast<Eigen::Index>(stick_.size());
    Sticking a(k, k);
    for (std::size_t p = 0; p < stick_.size(); ++p) {
      for (std::size_t q = 0; q < stick_.size(); ++q) {
        a.template block<2, 2>(2 * p, 2 * q) =
            tangents(stick_[p]).transpose() *
            w_.template block<3, 3>(3 * stick_[p], 3 * stick_[q]) * tangents(stick_[q]);
      }
    }
    Eigen::CompleteOrthogonalDecomposition<Sticking> cod;
    cod.setThreshold(1e-12);
    cod.compute(a);
    factorizations_.emplace_back(stick_, std::move(cod));
    return factorizations_.back().second;
  }

  // Smallest theta in (0, 1] where a theta^2 + b theta + c (c < 0 at 0) reaches 0; 2 if none.
  static T firstRoot(const T& a, const T& b, const T& c) {
    if (c >= 0.0) return 0.0;
    T best = 2.0;
    if (std::abs(valueOf(a)) <= 1e-300) {
      if (b > 0.0) best = -c / b;
    } else {
      const T disc = b * b - 4.0 * a * c;
      if (disc >= 0.0) {
        using std::sqrt;
        const T root = sqrt(disc);
        const T q = -0.5 * (b + (b >= 0.0 ? root : T(-root)));
        for (const T& t : {T(q / a), q != 0.0 ? T(c / q) : T(2.0)}) {
          if (t > 0.0 && t < best) best = t;
        }
      }
    }
    return best <= 1.0 ? best : T(2.0);
  }

  bool unfrictioned(std::size_t i) const {
    return sharing_ == SimultaneousSharing::kVelocityConsistent && unfrictioned_[i];
  }

  // Rates of the chosen rule; false if there are none (kVelocityConsistent on a jammed island).
  bool computeRates() {
    if (sharing_ == SimultaneousSharing::kSpring) {
      computeSpringRates();
      return true;
    }
    return computeConsistentRates();
  }

  // kVelocityConsistent, a restituting contact's rate: the normal impulse it still has to deliver.
  // Poisson: (1 + e) p_c - (P_n - start). Stronge: the same while it lasts (for a lone
  // frictionless contact, or contacts whose velocities stay in proportion, Stronge's end is
  // there); past it, the remaining work over the present separation speed (e p_c if none).
  // The Poisson impulse a restituting contact has still to deliver, 0 within round-off.
  T poissonRemaining(std::size_t i) const {
    const State<T>& s = state_[i];
    const ProblemContact& c = problem_.contact(i);
    const T& e = restitution_[i];
    const T remaining =
        s.start_normal + (1.0 + e) * s.compression_impulse - s.impulse.dot(c.normal);
    return remaining > 1e-9 * (1.0 + e) * s.compression_impulse ? remaining : T(0.0);
  }

  T restitutionRate(std::size_t i) const {
    const State<T>& s = state_[i];
    const T& e = restitution_[i];
    if (law_ == ImpactLaw::kPoisson) {
      const ProblemContact& c = problem_.contact(i);
      return maxOf<T>(s.start_normal + (1.0 + e) * s.compression_impulse - s.impulse.dot(c.normal),
                      0.0);
    }
    const T remaining = poissonRemaining(i);
    if (remaining > 0.0) return remaining;
    const T un = normalVelocity(i);
    const T work_left = maxOf<T>(-e * e * s.compression_work - s.work, 0.0);
    return un > 0.0 ? T(work_left / un) : T(e * s.compression_impulse);
  }

  // M r = -q for one or two compressing contacts in closed form, where it is the least-norm
  // answer the complete orthogonal decomposition gives (threshold 1e-12): one contact, r = -q / M
  // (0 if M = 0, rank 0); two, Cramer's rule when |det M| >= 1e-8 |M|_F^2, which bounds
  // sigma_min / sigma_max >= 1e-8 (sigma_max sigma_min = |det|, sigma_max^2 <= |M|_F^2), so that
  // every pivot of the decomposition's column-pivoted QR (|R_ii| >= sigma_min) is above its
  // threshold: full rank, and the same answer to round-off. False: the decomposition decides.
  static bool solveSmall(const SquareValues& M, const VectorValues& q, VectorValues& r) {
    if (M.rows() == 1) {
      r.resize(1);
      r(0) = M(0, 0) != 0.0 ? -q(0) / M(0, 0) : 0.0;
      return true;
    }
    if (M.rows() != 2) return false;
    const double det = M(0, 0) * M(1, 1) - M(0, 1) * M(1, 0);
    if (!(std::abs(det) >= 1e-8 * M.squaredNorm()) || det == 0.0) return false;
    r.resize(2);
    r(0) = (-q(0) * M(1, 1) + q(1) * M(0, 1)) / det;
    r(1) = (-q(1) * M(0, 0) + q(0) * M(1, 0)) / det;
    return true;
  }

  // The compressing contacts' rates: r >= 0, w = q + M r >= 0, r.w = 0 (M the effective normal
  // map of the compressing contacts, q their normal velocities plus the restituting contacts'
  // effect). First the all-active least-norm answer (redundant contacts share symmetrically),
  // else Lemke's method. False if neither gives one.
  // The double computation of solveCompression(): 0 if there is no answer, 1 for the all-active
  // least-norm answer, 2 for Lemke's.
  int solveCompressionValues(const SquareValues& M, const VectorValues& q, VectorValues& r) {
    const double q_scale = q.cwiseAbs().maxCoeff();
    if (q_scale <= 0.0) {
      r.setZero(q.size());
      return 1;
    }
    if (!solveSmall(M, q, r)) {
      compression_cod_.setThreshold(1e-12);
      compression_cod_.compute(M);
      r = compression_cod_.solve(-q);
    }
    const double r_scale = r.cwiseAbs().maxCoeff();
    residual_.noalias() = M.lazyProduct(r);
    residual_ += q;
    if (r.allFinite() && r.minCoeff() >= -1e-12 * r_scale &&
        residual_.cwiseAbs().maxCoeff() <= 1e-10 * q_scale) {
      r = r.cwiseMax(0.0);
      return 1;
    }
    const LcpResult lcp = solveLcp(Eigen::MatrixXd(M), Eigen::VectorXd(q));
    if (lcp.status != LcpStatus::kSolved) return 0;
    r = lcp.z;
    return 2;
  }

  bool solveCompression(const Square& M, const Vector& q, Vector& r) {
    if constexpr (!kDual) {
      return solveCompressionValues(M, q, r) != 0;
    } else {
      const Eigen::Index k = q.size();
      SquareValues Mv = SquareValues::Zero(k, k);
      VectorValues qv = VectorValues::Zero(k), rv;
      for (Eigen::Index a = 0; a < k; ++a) {
        qv(a) = q(a).v;
        for (Eigen::Index b = 0; b < k; ++b) Mv(a, b) = M(a, b).v;
      }
      const int how = solveCompressionValues(Mv, qv, rv);
      if (how == 0) return false;
      if (how == 2) {
        // Lemke's answer with a contact at r_a = 0 and w_a = 0 (weakly active: redundant
        // contacts, whose answers form a set, Lemke's a vertex of it): the vertex can change with
        // the inputs, so the gradient of this one is not the map's. The caller differences.
        const VectorValues w = Mv * rv + qv;
        const double w_scale = 1e-9 * qv.cwiseAbs().maxCoeff();
        for (Eigen::Index a = 0; a < k; ++a) {
          if (rv(a) <= 0.0 && std::abs(w(a)) <= w_scale) degenerate_ = true;
        }
      }
      r.resize(k);
      for (Eigen::Index a = 0; a < k; ++a) r(a) = T(rv(a));
      differentiateCompression(M, q, how == 1, r);
      return true;
    }
  }

  // Dual runs: the gradients of the compression rates r (their values set) through their
  // equations on the active contacts A (all on the all-active path; those with r_a > 0 after
  // Lemke's), M_AA r_A = -q_A with r_A the least-norm answer: at constant rank (the rank of W's
  // normal rows, which the seeded inputs do not change), with P = M_AA^+,
  //   dr = -P (dM r + dq) + (I - P M) dM^T P^T r - P P^T dM^T (I - M P) q.
  void differentiateCompression(const Square& M, const Vector& q, bool all_active, Vector& r) {
    if constexpr (kDual) {
      constexpr int N = static_cast<int>(T::Gradient::RowsAtCompileTime);
      std::vector<Eigen::Index> active;
      for (Eigen::Index a = 0; a < q.size(); ++a) {
        if (all_active || r(a).v > 0.0) active.push_back(a);
      }
      const Eigen::Index n = static_cast<Eigen::Index>(active.size());
      if (n == 0) return;
      Eigen::MatrixXd Ma(n, n), dM(n, n);
      Eigen::VectorXd qa(n), x(n), dq(n);
      for (Eigen::Index a = 0; a < n; ++a) {
        qa(a) = q(active[a]).v;
        x(a) = r(active[a]).v;
        for (Eigen::Index b = 0; b < n; ++b) Ma(a, b) = M(active[a], active[b]).v;
      }
      Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod;
      cod.setThreshold(1e-12);
      cod.compute(Ma);
      const Eigen::MatrixXd P = cod.pseudoInverse();
      const Eigen::MatrixXd null = Eigen::MatrixXd::Identity(n, n) - P * Ma;
      const Eigen::VectorXd residual = qa + Ma * x;  // (I - M P) q, as M P q = -M x
      const Eigen::VectorXd Ptx = P.transpose() * x;
      for (int k = 0; k < N; ++k) {
        for (Eigen::Index a = 0; a < n; ++a) {
          dq(a) = q(active[a]).d[k];
          for (Eigen::Index b = 0; b < n; ++b) dM(a, b) = M(active[a], active[b]).d[k];
        }
        const Eigen::VectorXd dx = -P * (dM * x + dq) + null * (dM.transpose() * Ptx) -
                                   P * (P.transpose() * (dM.transpose() * residual));
        for (Eigen::Index a = 0; a < n; ++a) r(active[a]).d[k] = dx(a);
      }
    }
  }

  // When the frictional problem has no answer (friction would press contacts closer faster than
  // their normal impulses part them): the rates of the frictionless normal block (W_nn, positive
  // semi-definite), with the restituting contacts' normal rates. Friction then follows them.
  bool frictionlessCompression() {
    const Eigen::Index k = static_cast<Eigen::Index>(compressing_.size());
    Square& M = eff_;
    Vector& q = q_;
    for (Eigen::Index a = 0; a < k; ++a) {
      const std::size_t i = compressing_[a];
      const Eigen::Vector3d& n = problem_.contact(i).normal;
      for (Eigen::Index b = 0; b < k; ++b) {
        const std::size_t j = compressing_[b];
        M(a, b) = n.dot(w_.template block<3, 3>(3 * i, 3 * j) * problem_.contact(j).normal);
      }
      q(a) = normalVelocity(i);
      for (std::size_t j = 0; j < m_; ++j) {
        if (state_[j].phase != Phase::kRestitution) continue;
        q(a) += n.dot(w_.template block<3, 3>(3 * i, 3 * j) * problem_.contact(j).normal) *
                normal_rate_[j];
      }
    }
    return solveCompression(M, q, r_);
  }

  // kVelocityConsistent: the impulse rate of every contact per unit of fictitious time. Each
  // active contact's impulse per unit normal rate is its normal, minus mu_d times its slip
  // direction while sliding, plus (sticking contacts) the tangential impulses that hold the stuck
  // slips at 0 (least norm, a linear map of the normal rates); W through that gives the effective
  // normal map `eff`. Restituting contacts take restitutionRate(); the compressing ones the
  // complementarity rates that bring their normal velocities to 0 together at t = 1.
  bool computeConsistentRates() {
    const Eigen::Index m = static_cast<Eigen::Index>(m_);
    normal_rate_.assign(m_, 0.0);
    unfrictioned_.assign(m_, 0);
    unstuck_now_.assign(m_, 0);
    for (std::size_t i = 0; i < m_; ++i) {
      if (state_[i].phase == Phase::kRestitution) normal_rate_[i] = restitutionRate(i);
    }
    compressing_.clear();
    for (std::size_t i = 0; i < m_; ++i) {
      if (state_[i].phase == Phase::kCompression) compressing_.push_back(i);
    }
    for (;;) {
      g_.setZero(3 * m, m);
      stick_.clear();
      for (std::size_t i = 0; i < m_; ++i) {
        State<T>& s = state_[i];
        if (s.phase == Phase::kIdle) continue;
        const ProblemContact& c = problem_.contact(i);
        Vector3<T> column = c.normal.template cast<T>();
        if (!c.frictionless() && s.sticking) {
          stick_.push_back(i);
        } else if (!c.frictionless() && !unfrictioned_[i]) {
          const Vector3<T> ut = tangentialVelocity(i);
          const T slip = ut.norm();
          if (slip > 1e-14 * scale_ && !(s.resumed && slip < kSmallSlip * scale_)) {
            s.slip = ut.normalized();
            s.resumed = false;
          }
          column -= dynamic_friction_[i] * s.slip;
        }
        g_.template block<3, 1>(3 * i, i) = column;
      }
      // wg_ = W g_ from g_'s structure: column i is contact i's column above, in its own rows.
      wg_.setZero(3 * m, m);
      for (std::size_t i = 0; i < m_; ++i) {
        if (state_[i].phase == Phase::kIdle) continue;
        const Eigen::Index at = 3 * static_cast<Eigen::Index>(i);
        wg_.col(at / 3).noalias() =
            w_.middleCols(at, 3).lazyProduct(g_.template block<3, 1>(at, at / 3));
      }
      if (!stick_.empty()) {
        // Over the active contacts' columns only: an idle contact's column of g_ and W g_ is 0,
        // and so is every map of it (each column is computed on its own).
        active_.clear();
        for (std::size_t i = 0; i < m_; ++i) {
          if (state_[i].phase != Phase::kIdle) active_.push_back(static_cast<Eigen::Index>(i));
        }
        const Eigen::Index columns = static_cast<Eigen::Index>(active_.size());
        wg_active_.resize(3 * m, columns);
        for (Eigen::Index a = 0; a < columns; ++a) wg_active_.col(a) = wg_.col(active_[a]);
        const Eigen::CompleteOrthogonalDecomposition<Sticking>& cod = factorization();
        stick_rhs_.resize(2 * static_cast<Eigen::Index>(stick_.size()), columns);
        for (std::size_t p = 0; p < stick_.size(); ++p) {
          stick_rhs_.middleRows(2 * p, 2).noalias() =
              -tangents(stick_[p]).transpose() * wg_active_.middleRows(3 * stick_[p], 3);
        }
        solveThrough(cod, stick_rhs_, stick_map_);
        // The stuck contacts' tangential impulses fill their rows of g_ (every active column);
        // W g_ takes what they add.
        for (std::size_t p = 0; p < stick_.size(); ++p) {
          const Eigen::Index at = 3 * static_cast<Eigen::Index>(stick_[p]);
          const Eigen::Matrix<T, 3, Eigen::Dynamic, 0, 3, Storage<kMax>::kTimes(1)> added =
              tangents(stick_[p]).lazyProduct(stick_map_.middleRows(2 * p, 2));
          for (Eigen::Index a = 0; a < columns; ++a) {
            g_.template block<3, 1>(at, active_[a]) += added.col(a);
          }
          wg_active_.noalias() += w_.middleCols(at, 3).lazyProduct(added);
        }
        for (Eigen::Index a = 0; a < columns; ++a) wg_.col(active_[a]) = wg_active_.col(a);
      }
      if (!compressing_.empty()) {
        const Eigen::Index k = static_cast<Eigen::Index>(compressing_.size());
        eff_.resize(k, k);
        q_.resize(k);
        for (Eigen::Index a = 0; a < k; ++a) {
          const std::size_t i = compressing_[a];
          const Eigen::Vector3d& n = problem_.contact(i).normal;
          const auto row = [&](Eigen::Index j) {
            return n.dot(wg_.template block<3, 1>(3 * static_cast<Eigen::Index>(i), j));
          };
          for (Eigen::Index b = 0; b < k; ++b) {
            eff_(a, b) = row(static_cast<Eigen::Index>(compressing_[b]));
          }
          q_(a) = normalVelocity(i);
          for (std::size_t j = 0; j < m_; ++j) {
            if (state_[j].phase == Phase::kRestitution) {
              q_(a) += row(static_cast<Eigen::Index>(j)) * normal_rate_[j];
            }
          }
        }
        if (!solveCompression(eff_, q_, r_) && !frictionlessCompression()) {
          // Wedged (no impulse stops every approach): each compressing contact the impulse that
          // would stop it alone.
          for (Eigen::Index a = 0; a < k; ++a) {
            const ProblemContact& c = problem_.contact(compressing_[a]);
            r_(a) = maxOf<T>(-q_(a), 0.0) / c.normalDelassus();
          }
        }
        for (Eigen::Index a = 0; a < k; ++a) normal_rate_[compressing_[a]] = r_(a);
      }
      r_all_ = Eigen::Map<const Eigen::Matrix<T, Eigen::Dynamic, 1>>(normal_rate_.data(), m);
      rates_.noalias() = g_.lazyProduct(r_all_);
      // Sticking contacts whose friction leaves the static cone resume slip against it.
      bool all_in = true;
      for (std::size_t i : stick_) {
        const ProblemContact& c = problem_.contact(i);
        Vector3<T> f = rates_.template segment<3>(3 * i);
        f -= c.normal.dot(f) * c.normal;
        if constexpr (kDual) {
          // The friction needed within kSwitchTolerance of the static cone: stick/slide.
          const double needed = valueOf(f.norm()),
                       cone = valueOf(c.static_friction * normal_rate_[i]);
          if (std::abs(needed - cone) <= kSwitchTolerance * cone) {
            noteSwitch(i, "stick/slide: the friction needed is at mu_s P_n during the impact");
          }
        }
        if (f.norm() > c.static_friction * normal_rate_[i] * (1.0 + 1e-9) + 1e-300) {
          state_[i].sticking = false;
          state_[i].resumed = true;
          state_[i].slip = -f.normalized();
          unstuck_now_[i] = 1;
          all_in = false;
          ++events_;
        }
      }
      if (!all_in) continue;
      // A sliding contact whose slip along its friction's direction is ~0 and would turn against
      // it (friction would work with the slip) is not consistent: it stops (the cone decides);
      // if it has just resumed, it gets no friction for this step (which cannot add energy).
      du_.noalias() = w_.lazyProduct(rates_);
      bool consistent = true;
      for (std::size_t i = 0; i < m_; ++i) {
        State<T>& s = state_[i];
        const ProblemContact& c = problem_.contact(i);
        if (s.phase == Phase::kIdle || c.frictionless() || s.sticking || unfrictioned_[i]) continue;
        Vector3<T> dut = du_.template segment<3>(3 * i);
        dut -= c.normal.dot(dut) * c.normal;
        const T along = s.slip.dot(dut);
        if (along >= 0.0 || s.slip.dot(tangentialVelocity(i)) > -1e-12 * along) continue;
        consistent = false;
        ++events_;
        if (unstuck_now_[i]) {
          unfrictioned_[i] = 1;
        } else {
          s.sticking = true;
        }
      }
      if (!consistent) continue;
      // A touching idle contact (u_n ~ 0) never loaded yet that these rates would make approach
      // joins the compressing contacts now (the complementarity problem then decides its share,
      // possibly 0), as in the plastic problem, where touching contacts take part (Newton's
      // cradle). A contact that has had a cycle starts a new one once it approaches (run()).
      bool joined = false;
      for (std::size_t i = 0; i < m_; ++i) {
        if (state_[i].phase != Phase::kIdle || normalVelocity(i) > 1e-12 * scale_) continue;
        if (state_[i].impulse.squaredNorm() > 0.0) continue;  // not the first time: see run()
        if (problem_.contact(i).normal.dot(du_.template segment<3>(3 * i)) >= -1e-12 * scale_)
          continue;
        startCycle(i);
        compressing_.push_back(i);
        joined = true;
      }
      if (!joined) return true;  // du_ = W rates_ for these rates (step() uses it)
    }
  }

  // Returns false if there are no rates (a jammed island under kVelocityConsistent).
  bool step() {
    if (!computeRates()) return false;
    // The velocity-consistent rates come with du_ = W rates_ (their last consistency check).
    if (sharing_ == SimultaneousSharing::kSpring) du_.noalias() = w_.lazyProduct(rates_);
    du_ *= h_;
    // The step fraction of the first event, and which contacts have it.
    std::vector<T>& event = event_;
    event.assign(m_, T(2.0));
    T limit = 1.0;
    for (std::size_t i = 0; i < m_; ++i) {
      const State<T>& s = state_[i];
      const ProblemContact& c = problem_.contact(i);
      const T un = normalVelocity(i);
      const T dun = c.normal.dot(du_.template segment<3>(3 * i));
      const T dpn = h_ * normal_rate_[i];
      T t = 2.0;
      if (s.phase == Phase::kIdle) {
        // Starts approaching: the step is cut there (the contact starts its compression once it
        // approaches beyond round-off).
        if (un > 1e-12 * scale_ && un + dun < 0.0) t = -un / dun;
      } else if (s.phase == Phase::kCompression) {
        // (A touching contact that joined with u_n ~ 0 ends after the step, in run().)
        if (dun > 0.0 && un + dun >= 0.0 && un < -1e-12 * scale_) t = maxOf<T>(-un / dun, 0.0);
      } else if (law_ == ImpactLaw::kPoisson) {
        const T target = s.start_normal + (1.0 + restitution_[i]) * s.compression_impulse;
        const T now = s.impulse.dot(c.normal);
        t = now >= target ? T(0.0) : dpn > 0.0 ? T((target - now) / dpn) : T(2.0);
      } else {
        const T target = -restitution_[i] * restitution_[i] * s.compression_work;
        t = firstRoot(0.5 * dpn * dun, dpn * un, s.work - target);
      }
      if (s.phase != Phase::kIdle && !s.sticking && !c.frictionless() && !unfrictioned(i)) {
        const Vector3<T> ut = tangentialVelocity(i);
        Vector3<T> dut = du_.template segment<3>(3 * i);
        dut -= c.normal.dot(dut) * c.normal;
        const T dd = dut.squaredNorm();
        if (dd > 0.0) {
          const T tmin = -ut.dot(dut) / dd;
          if (tmin > 1e-12 && tmin < t) t = tmin;
          // kVelocityConsistent: the slip along the friction's direction may not change sign
          // within the step (friction would then work with the slip).
          const T along = s.slip.dot(dut);
          if (sharing_ == SimultaneousSharing::kVelocityConsistent && along < 0.0) {
            const T ts = -s.slip.dot(ut) / along;
            if (ts > 1e-12 && ts < t) t = ts;
          }
          // A turning slip direction: limit the step so that it turns by at most kMaxTurn.
          const T unorm = ut.norm();
          if (unorm > stop_ * scale_ && !s.resumed) {
            const T turn = (dut - dut.dot(ut) / (unorm * unorm) * ut).norm();
            if (turn > kMaxTurn * unorm) limit = minOf<T>(limit, kMaxTurn * unorm / turn);
          }
        }
      }
      event[i] = t;
    }
    T theta = limit;
    for (const T& t : event) theta = minOf(theta, t);
    // Advance by theta: impulses and velocities exactly (linear in the impulse), spring
    // compressions and works by the trapezoid rule (exact: u is linear over the step).
    for (std::size_t i = 0; i < m_; ++i) {
      State<T>& s = state_[i];
      if (s.phase == Phase::kIdle) continue;
      const ProblemContact& c = problem_.contact(i);
      const T un0 = normalVelocity(i);
      const T un1 = un0 + theta * c.normal.dot(du_.template segment<3>(3 * i));
      s.impulse += theta * h_ * rates_.template segment<3>(3 * i);
      s.delta -= theta * h_ * 0.5 * (un0 + un1);
      s.work += theta * h_ * normal_rate_[i] * 0.5 * (un0 + un1);
    }
    u_ += theta * du_;
    // Transitions of the contacts whose event is this one.
    const double theta_value = valueOf(theta);
    const double same = theta_value + 1e-9 * std::max(theta_value, 1e-300);
    if constexpr (kDual) {
      // An event just after this step's end (beyond the grouping, within 1e-7): a perturbation
      // can reorder it with the step's own event.
      if (valueOf(limit) > theta_value) {
        for (std::size_t i = 0; i < m_; ++i) {
          if (event[i] > same && event[i] <= theta_value * (1.0 + 1e-7)) {
            noteSwitch(i, "event order: two events of the integration coincide");
          }
        }
      }
    }
    for (std::size_t i = 0; i < m_; ++i) {
      if (event[i] > same) continue;
      State<T>& s = state_[i];
      const ProblemContact& c = problem_.contact(i);
      switch (s.phase) {
        case Phase::kIdle:
          break;
        case Phase::kCompression:
          if (normalVelocity(i) >= -1e-12 * scale_) {
            endCompression(i);
            break;
          }
          [[fallthrough]];
        case Phase::kRestitution: {
          bool done;
          if (s.phase == Phase::kCompression) {
            done = false;
          } else if (law_ == ImpactLaw::kPoisson) {
            done = s.impulse.dot(c.normal) >= s.start_normal +
                                                  (1.0 + restitution_[i]) * s.compression_impulse -
                                                  1e-12 * s.compression_impulse;
          } else {
            const T target = -restitution_[i] * restitution_[i] * s.compression_work;
            done = s.work >= target - 1e-12 * std::abs(valueOf(s.compression_work));
          }
          if (done) {
            s.phase = Phase::kIdle;
            s.sticking = false;
            s.resumed = false;
            ++events_;
            break;
          }
          // Otherwise a slip minimum: stop if the slip is gone.
          if (!c.frictionless() && tangentialVelocity(i).norm() <= stop_ * scale_) {
            s.sticking = true;
            ++events_;
          }
          break;
        }
      }
    }
    return true;
  }

  const ContactProblem& problem_;
  ImpactLaw law_;
  SimultaneousSharing sharing_;
  Deadline deadline_;
  std::size_t m_;
  std::vector<State<T>> state_;
  // The contacts' e and mu_d (seeded in dual runs; mu_s, which only decides branches, is read
  // from the problem).
  std::vector<T> restitution_, dynamic_friction_;
  std::vector<std::string> switch_;  // dual runs: the switches met, per contact
  bool degenerate_ = false;          // dual runs: a weakly active contact in Lemke's rates
  Stacked w_;                        // the stacked W (3m x 3m)
  StackedVector u_;                  // the stacked current relative velocities
  StackedVector rates_, du_;
  std::vector<T> normal_rate_;
  std::vector<std::size_t> stick_;
  std::vector<std::pair<std::vector<std::size_t>, Eigen::CompleteOrthogonalDecomposition<Sticking>>>
      factorizations_;
  std::vector<T> event_;
  StackedVector base_;
  StickingVector b_, x_;
  // kVelocityConsistent work space: g_ (3m x m) the impulse per unit normal rate, wg_ = W g_,
  // eff_ / q_ / r_ the compressing contacts' complementarity problem and its answer.
  std::vector<std::size_t> compressing_;
  std::vector<char> unfrictioned_, unstuck_now_;  // per contact, this step
  PerContact g_, wg_;
  // The active contacts (indices) and W g_'s columns for them, for the sticking map.
  std::vector<Eigen::Index> active_;
  PerContact wg_active_;
  StickingMap stick_rhs_, stick_map_;
  Square eff_;
  Vector q_, r_, r_all_;
  VectorValues residual_;
  Eigen::CompleteOrthogonalDecomposition<SquareValues> compression_cod_;
  double scale_ = 0.0;   // largest |u| before the impact
  double lambda_ = 0.0;  // largest n^T W_ii n
  double h_ = 0.0;       // fictitious time step
  // A slip at or below stop_ times scale_ is a stop (kStopped or kSmallSlip by the rule).
  double stop_ = kStopped;
  std::size_t steps_ = 0, events_ = 0;
};

// Gradient entries per dual run: the seeded inputs go through the scheme in runs of this many.
constexpr int kDirections = 8;

}  // namespace

bool differentiateSimultaneousImpulseSpace(const ContactProblem& problem,
                                           const SolverOptions& options, bool velocities,
                                           const std::vector<bool>& coefficients,
                                           SimultaneousImpulseDerivatives& out) {
  const std::size_t m = problem.size();
  const Eigen::Index n3 = 3 * static_cast<Eigen::Index>(m);
  if (m < 2 || m > static_cast<std::size_t>(kBoundedContacts) ||
      (options.law != ImpactLaw::kPoisson && options.law != ImpactLaw::kStronge)) {
    return false;
  }
  out.dP_du.setZero(n3, velocities ? n3 : 0);
  out.dP_dtheta.setZero(n3, n3);
  out.impulses.setZero(n3);
  out.switches.assign(m, std::string());
  // The inputs, in the order of the columns: u (3 per contact), then (e, mu_s, mu_d) per contact.
  std::vector<Seed> seeds;
  std::vector<Eigen::Index> column;  // per seed: its column, theta's offset by n3
  if (velocities) {
    for (std::size_t i = 0; i < m; ++i) {
      for (int k = 0; k < 3; ++k) {
        seeds.push_back({Seed::kVelocity, i, k});
        column.push_back(3 * static_cast<Eigen::Index>(i) + k);
      }
    }
  }
  for (std::size_t i = 0; i < m; ++i) {
    for (int k = 0; k < 3; ++k) {
      const std::size_t at = 3 * i + static_cast<std::size_t>(k);
      if (!coefficients.empty() && !coefficients[at]) continue;
      // A frictionless contact's friction enters the integration only once mu > 0 (the scheme
      // skips its friction): its one-sided column is not the scheme's piece.
      if (k > 0 && problem.contact(i).frictionless()) return false;
      // Likewise e = 0: the contact goes idle after its compression and e enters nowhere, so the
      // scheme's column would be 0, not the one-sided (increasing e) derivative.
      if (k == 0 && !(problem.contact(i).restitution > 0.0)) return false;
      // mu_s only decides branches (the static cone's tests): its column is 0 on the piece.
      if (k == 1) continue;
      seeds.push_back({k == 0 ? Seed::kRestitution : Seed::kDynamicFriction, i, 0});
      column.push_back(n3 + static_cast<Eigen::Index>(at));
    }
  }
  using D = Dual<kDirections>;
  using Scheme = Simultaneous<kBoundedContacts, D>;
  bool first = true;
  for (std::size_t begin = 0; begin < seeds.size() || first; begin += kDirections) {
    const std::size_t end = std::min(seeds.size(), begin + kDirections);
    const std::vector<Seed> chunk(seeds.begin() + static_cast<std::ptrdiff_t>(begin),
                                  seeds.begin() + static_cast<std::ptrdiff_t>(end));
    // On the heap: the dual matrices are some 100 KB.
    const auto scheme = std::make_unique<Scheme>(problem, options.law, options.simultaneous_sharing,
                                                 options.deadline, chunk);
    if (!scheme->run() || scheme->degenerate()) return false;
    for (std::size_t i = 0; i < m; ++i) {
      const Vector3<D>& P = scheme->impulse(i);
      for (int r = 0; r < 3; ++r) {
        const Eigen::Index row = 3 * static_cast<Eigen::Index>(i) + r;
        if (first) out.impulses(row) = P(r).v;
        for (std::size_t k = begin; k < end; ++k) {
          const double g = P(r).d[static_cast<Eigen::Index>(k - begin)];
          if (column[k] < n3) {
            out.dP_du(row, column[k]) = g;
          } else {
            out.dP_dtheta(row, column[k] - n3) = g;
          }
        }
      }
      if (first) out.switches[i] = scheme->switchDetail(i);
    }
    first = false;
    if (end >= seeds.size()) break;
  }
  return true;
}

SolveReport solveSimultaneousImpulseSpace(ContactProblem& problem, const SolverOptions& options,
                                          std::vector<ContactImpulse>& impulses,
                                          bool plastic_rest) {
  if (options.law != ImpactLaw::kPoisson && options.law != ImpactLaw::kStronge) {
    throw std::invalid_argument("solveSimultaneousImpulseSpace: Poisson or Stronge only");
  }
  impulses.assign(problem.size(), ContactImpulse{});
  SolveReport report;
  report.method = SolvedBy::kSimultaneousImpulseSpace;
  ImpulseSpaceDetail detail;
  if (problem.size() == 1) {
    impulses[0] =
        integrateSingleContact(problem, 0, options.law, options.integration_tolerance, &detail);
    problem.applyImpulse(0, impulses[0].total(problem.contact(0).normal));
    report.iterations = detail.steps + detail.segments;
    report.residual = detail.error_estimate;
    report.impulse_space = detail;
    return report;
  }
  // Falling back to the two-phase scheme, the integration gets half of the time left, so that the
  // fallback has the rest; finishing it here, all of it.
  const Deadline deadline = plastic_rest ? options.deadline : options.deadline.portion(0.5);
  std::vector<Eigen::Vector3d> totals(problem.size());
  const auto integrate = [&](auto& scheme) {
    const bool done = scheme.run();
    detail.steps = scheme.steps();
    detail.segments = scheme.events();
    for (std::size_t i = 0; i < problem.size(); ++i) totals[i] = scheme.impulse(i);
    return done;
  };
  bool finished;
  if (problem.size() <= static_cast<std::size_t>(kBoundedContacts)) {
    Simultaneous<kBoundedContacts> scheme(problem, options.law, options.simultaneous_sharing,
                                          deadline);
    finished = integrate(scheme);
  } else {
    Simultaneous<Eigen::Dynamic> scheme(problem, options.law, options.simultaneous_sharing,
                                        deadline);
    finished = integrate(scheme);
  }
  report.iterations = detail.steps;
  if (!finished && !plastic_rest) {
    detail.fallback = true;
    report.converged = false;
    report.impulse_space = detail;
    return report;
  }
  for (std::size_t i = 0; i < problem.size(); ++i) {
    const ProblemContact& c = problem.contact(i);
    const Eigen::Vector3d& p = totals[i];
    problem.applyImpulse(i, p);
    impulses[i].normal_impulse = p.dot(c.normal);
    impulses[i].friction_impulse = p - impulses[i].normal_impulse * c.normal;
  }
  if (!finished) {
    // Budget exhausted: the rest as a plastic problem with friction, so nothing ends approaching.
    detail.fallback = true;
    report.converged = false;
    problem.makePlastic();
    std::vector<ContactImpulse> rest;
    const SolveReport plastic = problem.size() <= 128 ? solveExact(problem, options, rest)
                                                      : solveIterative(problem, options, rest);
    for (std::size_t i = 0; i < problem.size(); ++i) {
      impulses[i].normal_impulse += rest[i].normal_impulse;
      impulses[i].friction_impulse += rest[i].friction_impulse;
    }
    report.iterations += plastic.iterations;
  }
  double speed = 0.0;
  for (std::size_t i = 0; i < problem.size(); ++i)
    speed = std::max(speed, problem.relativeMotion(i).norm());
  for (std::size_t i = 0; i < problem.size(); ++i) {
    const ProblemContact& c = problem.contact(i);
    const Eigen::Vector3d u = problem.relativeMotion(i);
    const double slip = (u - u.dot(c.normal) * c.normal).norm();
    impulses[i].sticking = !c.frictionless() && impulses[i].normal_impulse > 0.0 &&
                           slip <= 1e-9 * std::max(speed, 1e-300);
  }
  report.impulse_space = detail;
  return report;
}

}  // namespace collision_response::core
