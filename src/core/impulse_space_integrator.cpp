// Routh's method for one frictional contact (docs/physics.md, "Frictional impact in impulse
// space").
//
// Symbols, in the contact basis (t1, t2, n) of tangentBasis():
//   K = [A b; b^T c]   contact-space inverse mass matrix: A = K_tt (2x2), b = K_tn, c = K_nn
//   p = P_n            normal impulse, the time-like variable [N s]
//   P_t                tangential (friction) impulse [N s]
//   u_t = u0_t + A P_t + b p,  u_n = u0_n + b.P_t + c p      relative contact velocity [m/s]
//   sigma = |u_t|, s = u_t / sigma                           slip speed and direction
//   g(s) = b - mu_d A s                                      du_t/dp while sliding
//   sigma' = s.g(s)                                          d sigma/dp while sliding
//   W(p) = integral_0^p u_n dp                               work of the normal impulse [J]
//   p_c, W_c                                                 values at maximum compression (u_n =
//   0) end: Poisson p = (1 + e) p_c; Stronge W = (1 - e^2) W_c
//
// Rotating slip is integrated in xi with dp/dxi = sigma, which removes the 1/sigma singularity of
// ds/dp at stick: dP_t/dxi = -mu_d u_t, dW/dxi = sigma u_n are analytic while sigma > 0, and stick
// becomes an equilibrium approached exponentially. The steps are Taylor polynomials of the path
// (slip_taylor.h), each as long as its truncation allows. The last piece into stick is taken in
// closed form (approachStick) once the slip direction has settled near an attracting direction.
// Fallback: a segment or step budget overrun, or a segment that can never end (impossible for
// positive definite K, where u_n falling during compression forces the slip to slow), finishes
// the impact with the perfectly plastic sticking impulse -K^-1 u (u' = 0, no energy gain).
// Singular K (bodies with fewer freedoms): K_nn = 0 gives no impulse; a singular K_tt (A) is
// handled in stickOrResume() (least-norm sticking rate, or slip resumes); sliding friction is
// Coulomb's, mu_d p against the slip, along whatever direction the slip takes.
#include "collision_response/core/impulse_space_integrator.h"

#include <Eigen/Core>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>

#include "collision_response/core/friction_disk.h"
#include "collision_response/core/least_norm.h"
#include "collision_response/core/single_contact.h"
#include "collision_response/core/slip_taylor.h"
#include "collision_response/core/stick_approach.h"

namespace collision_response::core {
namespace {

using Vec2 = Eigen::Vector2d;
using Mat2 = Eigen::Matrix2d;
using Vec4 = Eigen::Vector4d;  // integrated state (p, P_t1, P_t2, W)

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr std::size_t kMaxSegments = 16;
constexpr std::size_t kMaxSteps = 20000;
/// Slip speeds below this fraction of |u0| count as u_t = 0.
constexpr double kStickSpeed = 1e-14;
// A slip below this times |u0| that grows again from one step to the next has stopped (a near
// miss of its stop: integrateSlip()); impulse_space_sensitivity.ipp uses the same.
constexpr double kNearMiss = 1e-11;
/// |s x g| below this fraction of |b| + mu_d |A| counts as a constant slip direction.
constexpr double kParallel = 1e-12;
/// Share of the tolerance allowed to the local error of one step (errors of successive steps add).
constexpr double kStepShare = 0.3;
/// The closed-form approach to stop (stick_approach.h) is tried only on slips whose exponent m
/// (sigma ~ y^m near the stop) is at least this. The turning rate dy/dp ~ y^(1 - m) then grows
/// without bound as the slip stops, and the steps shrink with it: the slips the series shortens
/// most. Where m is smaller the steps to the stop are few and the series' set-up and orders cost
/// more than they save (docs/physics.md, "When the series is used", has the measurements).
constexpr double kSeriesExponent = 2.0;
/// ... and first when the slip's angle distance to its stop is below this fraction of the
/// series' radius of convergence (StickApproach::radius()): further out the terms fall too slowly
/// for the series to converge within StickApproach::kMaxOrder (on random 3D contacts no attempt
/// beyond 0.7 of the radius converged, and those beyond 0.5 needed 45 to 64 orders).
constexpr double kSeriesReach = 0.5;

double cross2(const Vec2& x, const Vec2& y) {
  return x.x() * y.y() - x.y() * y.x();
}

struct Problem {
  Mat2 A;
  Vec2 b;
  double c;
  Vec2 u0_t;
  double u0_n;
  double e;
  double mu_s;
  double mu_d;
  bool stronge;
  /// Impulse scale [N s]: |u0_n| / (c + max(mu_s, mu_d) |b|), a lower bound of the normal impulse
  /// (u_n rises at most that fast per unit normal impulse, whatever friction does), so that an
  /// error within tol J is within tol of the impulse itself (docs/physics.md, "Guarantee").
  double J;
  double V;    ///< slip scale |u0| [m/s]: a slip below kStickSpeed V counts as stopped
  double V_n;  ///< normal velocity scale |u0_n| [m/s]; the work's scale is V_n J [J]
  double tol;  ///< relative error tolerance

  Vec2 slip(double p, const Vec2& P_t) const { return u0_t + A * P_t + b * p; }
  double normal(double p, const Vec2& P_t) const { return u0_n + b.dot(P_t) + c * p; }
};

struct State {
  double p = 0.0;
  Vec2 P_t = Vec2::Zero();
  double W = 0.0;
  bool restitution = false;
  bool done = false;
  double p_c = 0.0;
  double W_c = 0.0;
  double p_end = kInf;
  double W_end = kInf;

  Vec4 vec() const { return Vec4(p, P_t.x(), P_t.y(), W); }
  void set(const Vec4& y) {
    p = y[0];
    P_t = y.segment<2>(1);
    W = y[3];
  }
};

/// Maximum compression reached: fix the law's end condition, and end at once if it already holds.
void beginRestitution(const Problem& pr, State& st) {
  st.restitution = true;
  st.p_c = st.p;
  st.W_c = st.W;
  st.p_end = (1.0 + pr.e) * st.p_c;
  st.W_end = (1.0 - pr.e * pr.e) * st.W_c;
  st.done = pr.stronge ? st.W >= st.W_end : st.p >= st.p_end;
}

/// Smallest x >= 0 with D = u_n x + h x^2 / 2 (the Stronge end on a linear segment), or kInf.
double strongeDistance(double D, double u_n, double h) {
  if (D <= 0.0) return 0.0;
  const double disc = u_n * u_n + 2.0 * h * D;
  if (disc < 0.0) return kInf;
  if (u_n >= 0.0) {
    const double den = u_n + std::sqrt(disc);
    return den > 0.0 ? 2.0 * D / den : kInf;
  }
  return h > 0.0 ? (std::sqrt(disc) - u_n) / h : kInf;
}

/// Distance in p to the event of the current phase along constant rates dP_t/dp = r (kInf if
/// none): maximum compression, then the end of the impact (as in advanceLinear()).
double eventDistance(const Problem& pr, const State& st, const Vec2& r) {
  const double h = pr.c + pr.b.dot(r);
  const double u_n = pr.normal(st.p, st.P_t);
  if (!st.restitution) return u_n >= 0.0 ? 0.0 : (h > 0.0 ? -u_n / h : kInf);
  if (pr.stronge) return strongeDistance(st.W_end - st.W, u_n, h);
  return std::max(0.0, st.p_end - st.p);
}

/// Closed-form segment: constant rates dP_t/dp = r, du_n/dp = h = c + b.r, for at most x_max in
/// p, stopping early at maximum compression (then continuing) and at the end of the impact.
/// Returns false if the segment is unbounded and never ends (a jam).
bool advanceLinear(const Problem& pr, State& st, const Vec2& r, double x_max) {
  const double h = pr.c + pr.b.dot(r);
  while (!st.done) {
    const double u_n = pr.normal(st.p, st.P_t);
    double x;
    if (!st.restitution) {
      x = u_n >= 0.0 ? 0.0 : (h > 0.0 ? -u_n / h : kInf);
    } else if (pr.stronge) {
      x = strongeDistance(st.W_end - st.W, u_n, h);
    } else {
      x = std::max(0.0, st.p_end - st.p);
    }
    // No event within reach (x infinite: a rate that never ends compression, such as sticking at
    // a contact whose K is singular, h = c - b^T A^+ b = 0, a one-joint robot): a jam.
    const bool event = x <= x_max && x < kInf;
    if (!event) {
      if (x_max == kInf) return false;
      x = x_max;
    }
    st.p += x;
    st.P_t += r * x;
    st.W += (u_n + 0.5 * h * x) * x;
    if (!event) return true;
    x_max -= x;
    if (!st.restitution) {
      beginRestitution(pr, st);
    } else {
      if (!pr.stronge) st.p = st.p_end;
      st.done = true;
    }
  }
  return true;
}

/// Slip direction on leaving stick: (lambda I + mu_d A) s = b, |s| = 1, lambda > 0, so that
/// du_t/dp = lambda s and friction -mu_d s opposes the growing slip. Requires
/// |A^-1 b| > mu_d. The same root find as the iterative solver's friction disk
/// (friction_disk.h, slipDirection()).
Vec2 resumeDirection(const Problem& pr) {
  return slipDirection(pr.mu_d * pr.A, pr.b);
}

/// u_t = 0: stick while the sticking rate tau = -A^-1 b lies in the static cone, otherwise slip
/// resumes along resumeDirection(). Both are final segments. Returns false on a jam.
/// Singular A (K_tt; bodies with fewer freedoms): tau = -A^+ b, the least-norm friction rate, and
/// stick only if it holds the slip (A tau = -b, i.e. b in the range of A); otherwise no friction
/// can hold it and slip resumes.
bool stickOrResume(const Problem& pr, State& st, bool& sticking) {
  const Vec2 tau = -(symmetricPseudoInverse(pr.A) * pr.b);
  const double trace = pr.A.trace();
  const bool regular = pr.A.determinant() > kSingularRelative * trace * trace;
  const bool holds = regular || (pr.A * tau + pr.b).norm() <= 1e-9 * (pr.b.norm() + pr.c);
  if (holds && tau.norm() <= std::max(pr.mu_s, pr.mu_d)) {
    sticking = true;
    return advanceLinear(pr, st, tau, kInf);
  }
  return advanceLinear(pr, st, -pr.mu_d * resumeDirection(pr), kInf);
}

/// d(p, P_t, W)/dxi while sliding, with dp/dxi = sigma.
inline Vec4 slipField(const Problem& pr, const Vec4& y) {
  const double p = y[0], P1 = y[1], P2 = y[2];
  const double u1 = pr.u0_t.x() + pr.A(0, 0) * P1 + pr.A(0, 1) * P2 + pr.b.x() * p;
  const double u2 = pr.u0_t.y() + pr.A(1, 0) * P1 + pr.A(1, 1) * P2 + pr.b.y() * p;
  const double u_n = pr.u0_n + pr.b.x() * P1 + pr.b.y() * P2 + pr.c * p;
  const double sigma = std::sqrt(u1 * u1 + u2 * u2);
  return Vec4(sigma, -pr.mu_d * u1, -pr.mu_d * u2, sigma * u_n);
}

/// The event of the current phase as a linear function grad.y + offset of the state: u_n during
/// compression, then p - p_end (Poisson) or W - W_end (Stronge).
void phaseEvent(const Problem& pr, const State& st, Vec4& grad, double& offset) {
  if (!st.restitution) {
    grad << pr.c, pr.b.x(), pr.b.y(), 0.0;
    offset = pr.u0_n;
  } else if (pr.stronge) {
    grad << 0.0, 0.0, 0.0, 1.0;
    offset = -st.W_end;
  } else {
    grad << 1.0, 0.0, 0.0, 0.0;
    offset = -st.p_end;
  }
}

/// Near stick, slip is self-similar: with theta the angle of s, dtheta/dln(sigma) = R(theta) =
/// (s x g) / (s.g), and sigma' = s.g < 0. About an attracting direction theta* (R = 0, k = R' > 0)
/// the angle error delta = theta - theta* = R / k decays as sigma^k, so the remaining piece, of
/// length sigma / -sigma' in p, equals to O(delta^2) the linear one with s taken at the weighted
/// mean angle theta - R / (1 + k). Takes that piece (closed form) and returns true once its error
/// (1 + mu_d) (sigma / -sigma') delta^2 is below the tolerance, or once the piece itself is.
bool approachStick(const Problem& pr, State& st) {
  const Vec2 u_t = pr.slip(st.p, st.P_t);
  const double sigma = u_t.norm();
  const Vec2 s = u_t / sigma;
  const Vec2 g = pr.b - pr.mu_d * (pr.A * s);
  const double rate = s.dot(g);  // sigma'
  if (sigma <= kStickSpeed * pr.V) return advanceLinear(pr, st, -pr.mu_d * s, 0.0);
  if (!(rate < 0.0)) return false;
  const double remaining = sigma / -rate;
  const double budget = 0.01 * pr.tol * pr.J;
  if (remaining <= budget) return advanceLinear(pr, st, -pr.mu_d * s, remaining);
  const Vec2 s_perp(-s.y(), s.x());
  const Vec2 g_theta = -pr.mu_d * (pr.A * s_perp);
  const double cross = cross2(s, g);
  const double R = cross / rate;
  const double k =
      ((cross2(s_perp, g) + cross2(s, g_theta)) * rate - cross * (s_perp.dot(g) + s.dot(g_theta))) /
      (rate * rate);
  if (!(k > 0.0)) return false;
  const double delta = R / k;
  if (std::abs(delta) > 0.1 || (1.0 + pr.mu_d) * remaining * delta * delta > budget) return false;
  const double phi = -R / (1.0 + k);
  const Vec2 s_mean = std::cos(phi) * s + std::sin(phi) * s_perp;
  const double rate_mean = s_mean.dot(pr.b - pr.mu_d * (pr.A * s_mean));
  if (!(rate_mean < 0.0)) return false;
  const double piece = sigma / -rate_mean;
  // Inside the piece the straight path is off the true one by O(delta) (only its end is O(delta^2)
  // accurate): an event inside it (maximum compression, the end of the impact) is located there to
  // within (1 + mu_d) piece |delta|, which must then be within the budget too.
  if ((1.0 + pr.mu_d) * piece * std::abs(delta) > budget &&
      eventDistance(pr, st, -pr.mu_d * s_mean) <= piece)
    return false;
  return advanceLinear(pr, st, -pr.mu_d * s_mean, piece);
}

/// A central contact (K_tn = 0, to 1e-12 of trace K: the normal through a free body's centre of
/// mass, a box struck by a locked robot) whose slip surely stops within the impact, in closed form.
/// With K_tn = 0 the normal motion ignores friction, u_n = u0_n + c p, so both laws end at
/// p_end = (1 + e) p_c (Stronge's work is Poisson's); the slip slows at
/// d|u_t|/dp = -mu_d s^T A s <= -mu_d lambda_min(A), so it stops by |u0_t| / (mu_d lambda_min),
/// and once that is within p_end the friction impulse is the one that stops it, -A^-1 u0_t, after
/// which the contact sticks (the sticking rate -A^-1 K_tn is 0). Returns false (integrate
/// instead) if the contact is not central or the bound exceeds p_end.
bool centralStop(const Problem& pr, State& st) {
  const double trace = pr.A.trace();
  if (!(pr.b.norm() <= 1e-12 * (trace + pr.c)) || !(pr.mu_d > 0.0)) return false;
  const double lambda_min = symmetricEigenvalues(pr.A)(0);
  if (!(lambda_min > kSingularRelative * trace)) return false;
  const double p_c = -pr.u0_n / pr.c;
  const double p_end = (1.0 + pr.e) * p_c;
  if (!(pr.u0_t.norm() <= pr.mu_d * lambda_min * p_end)) return false;
  st.p_c = p_c;
  st.W_c = 0.5 * pr.u0_n * p_c;  // integral of u0_n + c p over [0, p_c]
  st.p = p_end;
  st.P_t = -pr.A.inverse() * pr.u0_t;
  st.W = (1.0 - pr.e * pr.e) * st.W_c;
  st.restitution = true;
  st.done = true;
  return true;
}

/// Root y in [0, hi] of a value v(y) falling in y, v(hi) < 0 <= v(0), to |v| <= v_tol.
/// Near the stop the path's quantities go as y^m, so Newton's method runs in w = y^m, where they
/// are nearly linear; it bisects instead whenever Newton's step would leave the bracket or not
/// halve the step before last (as rtsafe does). `value` returns v and sets dv/dy. Returns -1 if v
/// is still negative at
/// y = 1e-12 hi: the event lies where the slip direction has settled to within 1e-12 rad, and its
/// y is not resolved in floating point (a slip that hardly slows, m << 1); the stepping takes
/// such events.
template <class Value>
double fallingRoot(double hi, double m, double v_tol, Value value) {
  double slope;
  if (value(1e-12 * hi, slope) < 0.0) return -1.0;
  const double w_top = std::pow(hi, m);
  double lo = 0.0, w_hi = w_top, w = w_top, y = hi;
  double step = w_top, step_before = w_top;
  for (int i = 0; i < 100; ++i) {
    const double v = value(y, slope);
    if (std::abs(v) <= v_tol) return y;
    if (v < 0.0) {
      w_hi = w;
    } else {
      lo = w;
    }
    const double slope_w = slope * y / (m * w);  // dv/dw
    const double newton = slope_w < 0.0 ? w - v / slope_w : -1.0;
    step_before = step;
    if (newton > lo && newton < w_hi && std::abs(2.0 * (newton - w)) <= step_before) {
      step = std::abs(newton - w);
      w = newton;
    } else {
      step = 0.5 * (w_hi - lo);
      w = lo + step;
    }
    y = std::pow(w, 1.0 / m);
    if (step <= 1e-15 * w_top) return y;  // Newton has converged, or the bracket has closed
  }
  return std::pow(lo, 1.0 / m);  // v >= 0 there: the event has happened
}

/// The rest of a rotating slip to its stop in closed form (stick_approach.h), with the events on
/// the way (maximum compression, the end of the impact) located on the same path. kTaken: the
/// state is at the end of the impact (done) or at the stop (`stuck`). Otherwise integrate on:
/// kNotConverged, the series do not converge at the slip's current angle to the tolerance, or
/// their stop does not cancel the slip (try again closer); kIllConditioned, a slip that hardly
/// slows as it turns (m << 1: the stop is far, and the sums cancel beyond the tolerance, or an
/// event lies where the slip direction has settled, fallingRoot()), do not try again; the state
/// may then have advanced along the path (to maximum compression).
enum class SeriesResult { kTaken, kNotConverged, kIllConditioned };
SeriesResult seriesToStop(const Problem& pr, State& st, StickApproach& approach, bool& stuck) {
  const Vec2 u_t = pr.slip(st.p, st.P_t);
  const double sigma = u_t.norm();
  const double x = approach.distance(u_t / sigma);
  if (x < 0.0) return SeriesResult::kNotConverged;
  // The tolerance is on the impulse (scale J) and the work (scale V_n J), so each series needs
  // its sums only to the tolerance over its share of them: 0.05 tol J / p_rem for the impulses
  // (also through u_n,stop p_rem in the work), 0.05 tol V_n J / work_drop for the work. First
  // from estimates (the linear stop sigma / -sigma', u_n rising at most (c + mu_d |b|) per unit
  // impulse), then checked against the sums themselves (the series extended if they need more).
  const Vec2 s = u_t / sigma;
  const double rate = s.dot(pr.b - pr.mu_d * (pr.A * s));
  const double rise = pr.c + pr.mu_d * pr.b.norm();
  const double p_guess = rate < 0.0 ? std::min(sigma / -rate, 1e6 * pr.J) : pr.J;
  const double u_n_now = std::abs(pr.normal(st.p, st.P_t));
  const auto share = [&](double p_rem, double u_n_stop, double work_drop, double& rel_p,
                         double& rel_w) {
    const double budget = 0.05 * pr.tol;
    rel_p = std::min(
        {1e-3, budget * pr.J / p_rem, budget * pr.V_n * pr.J / (std::abs(u_n_stop) * p_rem)});
    rel_w = std::min(1e-3, budget * pr.V_n * pr.J / work_drop);
  };
  double rel_p, rel_w;
  share(p_guess, u_n_now + rise * p_guess, rise * p_guess * p_guess, rel_p, rel_w);
  if (!approach.converged(x, rel_p, rel_w)) return SeriesResult::kNotConverged;
  double log_scale = approach.logScale(x, sigma);
  StickApproach::Remaining rest = approach.remaining(x, log_scale);
  double u_n_stop = pr.normal(st.p + rest.p, st.P_t + rest.P_t);
  double need_p, need_w;
  share(rest.p, u_n_stop, rest.work_drop, need_p, need_w);
  if (need_p < rel_p || need_w < rel_w) {
    if (!approach.converged(x, need_p, need_w)) return SeriesResult::kNotConverged;
    log_scale = approach.logScale(x, sigma);
    rest = approach.remaining(x, log_scale);
    u_n_stop = pr.normal(st.p + rest.p, st.P_t + rest.P_t);
  }
  // (Written so that a NaN, from sums that went wrong, fails too.)
  if (!((u_t + pr.A * rest.P_t + pr.b * rest.p).norm() <= pr.tol * pr.V_n)) {
    return SeriesResult::kNotConverged;
  }
  // A slip that hardly slows as it turns (m << 1) is far from its stop: the path's states are
  // then differences of sums much larger than the impulse and work scales, and their round-off
  // must stay within the tolerance too.
  const double magnitude =
      std::max(rest.p / pr.J, (std::abs(u_n_stop) * rest.p + rest.work_drop) / (pr.V_n * pr.J));
  if (!(1e-15 * magnitude <= 0.05 * pr.tol)) return SeriesResult::kIllConditioned;
  // The stop, and the state at angle distance y along the path to it.
  const double p_stop = st.p + rest.p;
  const Vec2 P_stop = st.P_t + rest.P_t;
  const double W_stop = st.W + u_n_stop * rest.p - rest.work_drop;
  const double m = approach.exponent();
  const auto remainingAt = [&](double y) {
    return approach.remaining(y, log_scale + m * std::log(y / x));
  };
  const auto setAt = [&](double y) {
    const StickApproach::Remaining r = remainingAt(y);
    st.p = p_stop - r.p;
    st.P_t = P_stop - r.P_t;
    st.W = W_stop - (u_n_stop * r.p - r.work_drop);
  };
  double y_now = x;
  while (true) {
    double y;
    if (!st.restitution) {
      if (u_n_stop < 0.0) break;  // compression goes on past the stop
      y = fallingRoot(y_now, m, 1e-3 * pr.tol * pr.V_n, [&](double z, double& slope) {
        const StickApproach::Remaining r = remainingAt(z);
        slope = -(pr.c - pr.mu_d * pr.b.dot(r.direction)) * r.rate;
        return u_n_stop - r.u_n_rise;
      });
      if (y < 0.0) return SeriesResult::kIllConditioned;
      setAt(y);
      beginRestitution(pr, st);
      if (st.done) return SeriesResult::kTaken;
      y_now = y;
      continue;
    }
    if (pr.stronge) {
      if (W_stop < st.W_end) break;
      y = fallingRoot(y_now, m, 1e-3 * pr.tol * pr.V_n * pr.J, [&](double z, double& slope) {
        const StickApproach::Remaining r = remainingAt(z);
        slope = -(u_n_stop - r.u_n_rise) * r.rate;
        return W_stop - (u_n_stop * r.p - r.work_drop) - st.W_end;
      });
      if (y < 0.0) return SeriesResult::kIllConditioned;
      setAt(y);
      st.W = st.W_end;
    } else {
      if (p_stop < st.p_end) break;
      y = fallingRoot(y_now, m, 1e-3 * pr.tol * pr.J, [&](double z, double& slope) {
        const StickApproach::Remaining r = remainingAt(z);
        slope = -r.rate;
        return p_stop - r.p - st.p_end;
      });
      if (y < 0.0) return SeriesResult::kIllConditioned;
      setAt(y);
      st.p = st.p_end;
    }
    st.done = true;
    return SeriesResult::kTaken;
  }
  st.p = p_stop;
  st.P_t = P_stop;
  st.W = W_stop;
  stuck = true;
  return SeriesResult::kTaken;
}

/// The Taylor order of the slip's steps at a step tolerance eps (relative): about -0.6 ln eps,
/// from 12 to 24 (15 at the default tolerance). Higher orders take longer steps at O(n^2) each;
/// measured on the real tosses' contacts (docs/physics.md, "Rotating slip in 3D: Taylor steps").
int taylorOrder(double eps) {
  return std::clamp(static_cast<int>(std::lround(-0.6 * std::log(eps))), 12, 24);
}

/// The longest step t (in the path's clock s = xi rate) with the truncation within eps (scaled by
/// the impulse scale J and the work scale V_n J): sizes m_k of the last two orders k = n - 1, n
/// (two, so that one small by chance does not pass), t = kTaylorSafety (eps / m_k)^(1/k), and no
/// more than half the ratio estimate m_(n-1) / m_n of the series' radius, nor 64 (|sigma'| / sigma
/// <= rate: sigma changes at most e^64-fold). Sets `truncation` to m_n t^n, the step's error
/// estimate (relative, as eps).
double taylorStep(const SlipTaylor& path, const Problem& pr, double eps, double& truncation) {
  constexpr double kTaylorSafety = 0.9;
  const int n = path.order();
  const double m_n = path.size(n, pr.V_n) / pr.J;
  const double m_last = path.size(n - 1, pr.V_n) / pr.J;
  double t = 64.0;
  if (m_n > 0.0) {
    const double root = std::pow(eps / m_n, 1.0 / n);  // m_n root^n = eps
    // The order before at that step: m_last root^(n - 1) = m_last eps / (m_n root).
    t = std::min(t, m_last <= m_n * root ? root : std::pow(eps / m_last, 1.0 / (n - 1)));
    if (m_last > 0.0) t = std::min(t, 0.5 * m_last / m_n);
  } else if (m_last > 0.0) {
    t = std::min(t, std::pow(eps / m_last, 1.0 / (n - 1)));
  }
  t *= kTaylorSafety;
  double power = m_n;
  for (int k = 0; k < n; ++k) power *= t;
  truncation = power;
  return t;
}

/// The first s in (0, h] where the event's polynomial `e` (below 0 at s = 0) reaches 0, or -1 if
/// it does not within the step. A monotone event (`monotone`) reaches 0 within the step if and
/// only if it does at h. Otherwise the polynomial is sampled at kEventSamples points (a crossing
/// and return between two of them would need the path to turn within a sixteenth of a step, at
/// most a fifth of the series' radius) and the first sample at or above 0 brackets the root.
/// Newton's method kept in the bracket by bisection finds it to round-off of the event's values.
double eventRoot(const double* e, int order, double h, bool monotone) {
  constexpr int kEventSamples = 16;
  double slope;
  double lo = 0.0, hi = -1.0, v_hi = 0.0;
  if (monotone) {
    v_hi = SlipTaylor::value(e, order, h, slope);
    if (v_hi >= 0.0) hi = h;
  } else {
    for (int i = 1; i <= kEventSamples; ++i) {
      const double s = h * i / kEventSamples;
      const double v = SlipTaylor::value(e, order, s);
      if (v >= 0.0) {
        hi = s;
        v_hi = v;
        break;
      }
      lo = s;
    }
  }
  if (hi < 0.0) return -1.0;
  const double v_tol = 1e-14 * (std::abs(e[0]) + std::abs(v_hi));
  double t = hi;
  for (int i = 0; i < 100; ++i) {
    const double v = SlipTaylor::value(e, order, t, slope);
    if (std::abs(v) <= v_tol) break;
    (v > 0.0 ? hi : lo) = t;
    if (hi - lo <= 1e-15 * h) break;
    const double newton = slope > 0.0 ? t - v / slope : -1.0;
    t = newton > lo && newton < hi ? newton : 0.5 * (lo + hi);
  }
  return t;
}

/// Rotating slip: integrates until the impact ends or slip stops (returns with `stuck` set after
/// the closed-form last piece). Taylor steps (SlipTaylor) in the clock s = xi rate, each as long as
/// its truncation allows (taylorStep()) and checked at its end: the polynomial's rate against the
/// field there, else the step is halved. An event inside a step (maximum compression, the end of
/// the impact) is located on the step's polynomial (eventRoot()) and polished by one step along the
/// field. Returns false if the step budget is exhausted or the path leaves the finite numbers.
bool integrateSlip(const Problem& pr, State& st, bool& stuck, ImpulseSpaceDetail& stats) {
  const double rate = pr.b.norm() + pr.mu_d * pr.A.norm();  // bounds |d u_t/dxi| / sigma
  if (!(rate > 0.0 && rate < kInf)) return false;
  const double clock = 1.0 / rate;  // [kg]
  const double eps = kStepShare * pr.tol;
  const int order = taylorOrder(eps);
  // The events are monotone along the slide where du_n/dp = K_nn - mu_d K_tn.s >= K_nn - mu_d
  // |K_tn| > 0 (u_n rises, and with it W once u_n >= 0 in restitution), and Poisson's end
  // (p - p_end, dp/dxi = sigma > 0) always.
  const bool normal_rises = pr.c > pr.mu_d * pr.b.norm();
  // The closed-form approach to stop (stick_approach.h), tried on a slip with m >=
  // kSeriesExponent once within kSeriesReach of the series' radius of its final direction s*,
  // and again each time it has turned 30 % closer (the cosine of the angle to s* above
  // retry_cos).
  StickApproach approach;
  bool series = approach.build(pr.A, pr.b, pr.c, pr.mu_d, pr.slip(st.p, st.P_t).normalized()) &&
                approach.exponent() >= kSeriesExponent;
  double retry_cos = series ? std::cos(std::min(3.0, kSeriesReach * approach.radius())) : 2.0;
  SlipTaylor path;
  double event[SlipTaylor::kMaxOrder + 1];
  while (true) {
    if (series) {
      const Vec2 u_t = pr.slip(st.p, st.P_t);
      if (approach.direction().dot(u_t) > retry_cos * u_t.norm()) {
        bool stuck_now = false;
        const SeriesResult result = seriesToStop(pr, st, approach, stuck_now);
        if (result == SeriesResult::kTaken) {
          stuck = stuck_now;
          stats.series_order = static_cast<std::size_t>(approach.order());
          return true;
        }
        series = result == SeriesResult::kNotConverged;
        const Vec2 u_now = pr.slip(st.p, st.P_t);
        retry_cos = std::cos(0.7 * approach.distance(u_now.normalized()));
      }
    }
    if (approachStick(pr, st)) {
      stuck = true;
      return true;
    }
    if (stats.steps >= kMaxSteps) return false;
    ++stats.steps;
    const Vec4 y = st.vec();
    // (approachStick() has taken a slip at or below kStickSpeed: sigma > 0 here.)
    if (!path.expand(pr.A, pr.b, pr.c, pr.u0_t, pr.u0_n, pr.mu_d, y, order, clock)) return false;
    double truncation;
    double h = taylorStep(path, pr, eps, truncation);
    // The check at the step's end: the polynomial's rate against the field (clock F(y)); the
    // truncation's rate is about n / h times its value, so a mismatch beyond 10 n eps / h (scaled
    // as the state) says the step overreached the series: halve it.
    Vec4 y1 = path.at(h);
    for (int halvings = 0;; ++halvings) {
      const Vec4 mismatch = path.rate(h) - clock * slipField(pr, y1);
      const double scaled =
          std::max(mismatch.head<3>().cwiseAbs().maxCoeff(), std::abs(mismatch[3]) / pr.V_n) / pr.J;
      if (scaled * h <= 10.0 * order * eps || halvings == 30) break;
      h *= 0.5;
      truncation *= std::pow(0.5, order);
      y1 = path.at(h);
    }
    if (!y1.allFinite() || !(h > 0.0)) return false;
    // A slip that has fallen below kNearMiss V and grows again has passed its stop at a distance
    // no integration resolves (its direction swings about a stop direction that repels it): the
    // slip has stopped, at the step's start; the cone then decides between sticking and resuming.
    if (pr.mu_d > 0.0) {
      const double sigma0 = pr.slip(st.p, st.P_t).norm();
      if (sigma0 <= kNearMiss * pr.V && pr.slip(y1[0], y1.segment<2>(1)).norm() > sigma0) {
        stuck = true;
        return true;
      }
    }
    stats.error_estimate += truncation;
    Vec4 grad;
    double offset;
    phaseEvent(pr, st, grad, offset);
    const bool monotone = normal_rises || (st.restitution && !pr.stronge);
    if (monotone && grad.dot(y1) + offset < 0.0) {
      st.set(y1);
      continue;
    }
    path.linear(grad, offset, event);
    const double t = event[0] >= 0.0 ? 0.0 : eventRoot(event, path.order(), h, monotone);
    if (t < 0.0) {
      st.set(y1);
      continue;
    }
    y1 = path.at(t);
    const Vec4 f1 = slipField(pr, y1);
    const double slope = grad.dot(f1);
    if (slope > 0.0) y1 -= ((grad.dot(y1) + offset) / slope) * f1;
    st.set(y1);
    if (!st.restitution) {
      beginRestitution(pr, st);
    } else {
      if (pr.stronge)
        st.W = st.W_end;
      else
        st.p = st.p_end;
      st.done = true;
    }
    if (st.done) return true;
  }
}

}  // namespace

ContactImpulse integrateSingleContact(const ProblemContact& contact, const Eigen::Vector3d& u,
                                      ImpactLaw law, double tolerance, ImpulseSpaceDetail* detail) {
  if (law != ImpactLaw::kPoisson && law != ImpactLaw::kStronge) {
    return solveSingleContact(contact, u, law);
  }
  ImpulseSpaceDetail local;
  ImpulseSpaceDetail& st_out = detail ? *detail : local;
  st_out = ImpulseSpaceDetail();

  ContactImpulse impulse;
  const Eigen::Vector3d& n = contact.normal;
  const Eigen::Matrix3d& K = contact.delassus;
  const double u_n = u.dot(n);
  impulse.normal_velocity_before = u_n;
  impulse.normal_velocity_after = u_n;
  const double K_nn = n.dot(K * n);
  // K_nn = 0: no impulse moves the contact along n (singular W): zero impulse.
  if (u_n >= 0.0 || !(K_nn > kSingularRelative * K.trace())) return impulse;

  // Contact basis: B = [t1 t2 n], K' = B^T K B.
  const Eigen::Vector3d& t1 = contact.tangent1;
  const Eigen::Vector3d& t2 = contact.tangent2;
  Eigen::Matrix3d B;
  B << t1, t2, n;
  const Eigen::Matrix3d Kc = B.transpose() * K * B;
  Problem pr;
  pr.A = Kc.topLeftCorner<2, 2>();
  pr.b = Kc.topRightCorner<2, 1>();
  pr.c = Kc(2, 2);
  pr.u0_t = Vec2(t1.dot(u), t2.dot(u));
  pr.u0_n = u_n;
  pr.e = contact.restitution;
  pr.mu_s = contact.static_friction;
  pr.mu_d = contact.dynamic_friction;
  pr.stronge = law == ImpactLaw::kStronge;
  pr.V = u.norm();
  pr.V_n = -u_n;
  pr.J = pr.V_n / (pr.c + std::max(pr.mu_s, pr.mu_d) * pr.b.norm());
  pr.tol = std::max(tolerance, 1e-15);

  State st;
  bool stuck = false;
  bool ok = true;
  if (pr.u0_t.norm() > kStickSpeed * pr.V && centralStop(pr, st)) {
    impulse.sticking = true;
    st_out.segments = 2;  // slip to its stop, then stick
  }
  while (!st.done && ok) {
    if (++st_out.segments > kMaxSegments) {
      ok = false;
      break;
    }
    const Vec2 u_t = pr.slip(st.p, st.P_t);
    const double sigma = u_t.norm();
    if (stuck || sigma <= kStickSpeed * pr.V) {
      ok = stickOrResume(pr, st, impulse.sticking);
      break;
    }
    const Vec2 s = u_t / sigma;
    const Vec2 g = pr.b - pr.mu_d * (pr.A * s);
    const bool parallel =
        std::abs(cross2(s, g)) <= kParallel * (pr.b.norm() + pr.mu_d * pr.A.norm());
    if (parallel || pr.mu_d == 0.0) {
      // Constant slip direction: u is linear in p until slip stops at sigma / -sigma'.
      const double sigma_rate = s.dot(g);
      const double x_stop = parallel && sigma_rate < 0.0 ? sigma / -sigma_rate : kInf;
      ok = advanceLinear(pr, st, -pr.mu_d * s, x_stop);
      stuck = true;
    } else {
      ok = integrateSlip(pr, st, stuck, st_out);
    }
  }

  Eigen::Vector3d P = st.p * n + st.P_t.x() * t1 + st.P_t.y() * t2;
  if (!ok) {
    // Fallback: finish with the perfectly plastic sticking impulse from the current state,
    // u' = 0, which never adds kinetic energy (it removes u^T K^-1 u / 2); least-norm (K^+) if K
    // is singular.
    st_out.fallback = true;
    P -= symmetricPseudoInverse(K) * (u + K * P);
    impulse.sticking = true;
  }
  if (contact.frictionless()) impulse.sticking = false;  // nothing holds it (contact_impulse.h)
  st_out.compression_impulse = st.p_c;
  st_out.compression_work = st.W_c;
  impulse.normal_impulse = P.dot(n);
  impulse.friction_impulse = P - impulse.normal_impulse * n;
  impulse.normal_velocity_after = u_n + n.dot(K * P);
  return impulse;
}

}  // namespace collision_response::core
